//! Rows of voxels into f32 vector lanes, for each voxel type (the conversion from i16
//! is exact). [`Load`] is also what seals [`crate::voxel::Voxel`]: it is implemented for
//! `f32` and `i16` only, and cannot be named outside the crate.

/// The row loaders of a voxel type.
pub trait Load: Copy {
    /// Four consecutive voxels starting at `p`, converted to f32 lanes (SSE2).
    ///
    /// # Safety
    /// `p` must point at four readable consecutive voxels.
    #[cfg(target_arch = "x86_64")]
    unsafe fn load4(p: *const Self) -> core::arch::x86_64::__m128;
    /// Two rows of four voxels, from `p[0]` in the low 128 bits and from `p[1]` in the
    /// high 128 bits, converted to f32 lanes (AVX2).
    ///
    /// # Safety
    /// Each pointer must point at four readable consecutive voxels, and the CPU must
    /// support AVX2.
    #[cfg(target_arch = "x86_64")]
    unsafe fn load4x2(p: [*const Self; 2]) -> core::arch::x86_64::__m256;
    /// Eight consecutive voxels starting at `p`, converted to f32 lanes (AVX2).
    ///
    /// # Safety
    /// `p` must point at eight readable consecutive voxels, and the CPU must support
    /// AVX2.
    #[cfg(target_arch = "x86_64")]
    unsafe fn load8(p: *const Self) -> core::arch::x86_64::__m256;
    /// Four rows of four voxels, from `p[i]` in 128-bit lane i, converted to f32 lanes
    /// (AVX-512F).
    ///
    /// # Safety
    /// Each pointer must point at four readable consecutive voxels, and the CPU must
    /// support AVX-512F.
    #[cfg(target_arch = "x86_64")]
    unsafe fn load4x4(p: [*const Self; 4]) -> core::arch::x86_64::__m512;
    /// Sixteen consecutive voxels starting at `p`, converted to f32 lanes (AVX-512F).
    ///
    /// # Safety
    /// `p` must point at sixteen readable consecutive voxels, and the CPU must support
    /// AVX-512F.
    #[cfg(target_arch = "x86_64")]
    unsafe fn load16(p: *const Self) -> core::arch::x86_64::__m512;
    /// Four rows of two voxels, as two vectors of f32 lanes: `[*a, *(a+1), *b, *(b+1)]`
    /// and `[*c, *(c+1), *d, *(d+1)]` (SSE2).
    ///
    /// # Safety
    /// Each pointer must point at two readable consecutive voxels.
    #[cfg(target_arch = "x86_64")]
    unsafe fn load2x4(
        a: *const Self,
        b: *const Self,
        c: *const Self,
        d: *const Self,
    ) -> [core::arch::x86_64::__m128; 2];
}

impl Load for f32 {
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn load4(p: *const f32) -> core::arch::x86_64::__m128 {
        // SAFETY: the caller guarantees 4 readable f32 at p; SSE is x86_64 baseline.
        unsafe { core::arch::x86_64::_mm_loadu_ps(p) }
    }
    #[cfg(target_arch = "x86_64")]
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn load4x2(p: [*const f32; 2]) -> core::arch::x86_64::__m256 {
        // SAFETY: the caller guarantees 4 readable f32 at each pointer.
        unsafe { core::arch::x86_64::_mm256_loadu2_m128(p[1], p[0]) }
    }
    #[cfg(target_arch = "x86_64")]
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn load8(p: *const f32) -> core::arch::x86_64::__m256 {
        // SAFETY: the caller guarantees 8 readable f32 at p.
        unsafe { core::arch::x86_64::_mm256_loadu_ps(p) }
    }
    #[cfg(target_arch = "x86_64")]
    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn load4x4(p: [*const f32; 4]) -> core::arch::x86_64::__m512 {
        use core::arch::x86_64::*;
        // SAFETY: the caller guarantees 4 readable f32 at each pointer.
        unsafe {
            let v = _mm512_castps128_ps512(_mm_loadu_ps(p[0]));
            let v = _mm512_insertf32x4::<1>(v, _mm_loadu_ps(p[1]));
            let v = _mm512_insertf32x4::<2>(v, _mm_loadu_ps(p[2]));
            _mm512_insertf32x4::<3>(v, _mm_loadu_ps(p[3]))
        }
    }
    #[cfg(target_arch = "x86_64")]
    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn load16(p: *const f32) -> core::arch::x86_64::__m512 {
        // SAFETY: the caller guarantees 16 readable f32 at p.
        unsafe { core::arch::x86_64::_mm512_loadu_ps(p) }
    }
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn load2x4(
        a: *const f32,
        b: *const f32,
        c: *const f32,
        d: *const f32,
    ) -> [core::arch::x86_64::__m128; 2] {
        use core::arch::x86_64::*;
        // SAFETY: the caller guarantees two readable f32 (8 bytes) at each pointer, which
        // is what each unaligned 64-bit load reads; SSE2 is x86_64 baseline.
        unsafe {
            let two = |p: *const f32, q: *const f32| {
                _mm_castpd_ps(_mm_loadh_pd(_mm_load_sd(p as *const f64), q as *const f64))
            };
            [two(a, b), two(c, d)]
        }
    }
}

impl Load for i16 {
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn load4(p: *const i16) -> core::arch::x86_64::__m128 {
        use core::arch::x86_64::*;
        // SAFETY: the caller guarantees 4 readable i16 (8 bytes) at p, which is what the
        // unaligned 64-bit load reads; SSE2 is x86_64 baseline. Interleaving each value
        // with itself and shifting right arithmetically sign-extends it to 32 bits.
        unsafe {
            let v = _mm_loadl_epi64(p as *const __m128i);
            _mm_cvtepi32_ps(_mm_srai_epi32::<16>(_mm_unpacklo_epi16(v, v)))
        }
    }
    #[cfg(target_arch = "x86_64")]
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn load4x2(p: [*const i16; 2]) -> core::arch::x86_64::__m256 {
        use core::arch::x86_64::*;
        // SAFETY: the caller guarantees 4 readable i16 (8 bytes) at each pointer: one
        // 64-bit load each into the two halves of a register, then sign extension to 32
        // bits and conversion (both exact).
        unsafe {
            let lo = _mm_loadl_epi64(p[0] as *const __m128i);
            let both = _mm_castpd_si128(_mm_loadh_pd(_mm_castsi128_pd(lo), p[1] as *const f64));
            _mm256_cvtepi32_ps(_mm256_cvtepi16_epi32(both))
        }
    }
    #[cfg(target_arch = "x86_64")]
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn load8(p: *const i16) -> core::arch::x86_64::__m256 {
        use core::arch::x86_64::*;
        // SAFETY: the caller guarantees 8 readable i16 (16 bytes) at p, read unaligned;
        // sign extension to 32 bits and conversion are exact.
        unsafe { _mm256_cvtepi32_ps(_mm256_cvtepi16_epi32(_mm_loadu_si128(p as *const __m128i))) }
    }
    #[cfg(target_arch = "x86_64")]
    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn load4x4(p: [*const i16; 4]) -> core::arch::x86_64::__m512 {
        use core::arch::x86_64::*;
        // SAFETY: the caller guarantees 4 readable i16 (8 bytes) at each pointer, read
        // unaligned as one 64-bit integer each; sign extension and conversion are exact.
        unsafe {
            let q = p.map(|x| (x as *const i64).read_unaligned());
            let all = _mm256_set_epi64x(q[3], q[2], q[1], q[0]);
            _mm512_cvtepi32_ps(_mm512_cvtepi16_epi32(all))
        }
    }
    #[cfg(target_arch = "x86_64")]
    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn load16(p: *const i16) -> core::arch::x86_64::__m512 {
        use core::arch::x86_64::*;
        // SAFETY: the caller guarantees 16 readable i16 (32 bytes) at p, read unaligned;
        // sign extension to 32 bits and conversion are exact.
        unsafe {
            _mm512_cvtepi32_ps(_mm512_cvtepi16_epi32(_mm256_loadu_si256(
                p as *const __m256i,
            )))
        }
    }
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn load2x4(
        a: *const i16,
        b: *const i16,
        c: *const i16,
        d: *const i16,
    ) -> [core::arch::x86_64::__m128; 2] {
        use core::arch::x86_64::*;
        // SAFETY: the caller guarantees two readable i16 (4 bytes) at each pointer, read
        // unaligned; SSE2 is x86_64 baseline. The eight values are packed into one
        // register, then each half is sign-extended (interleave with itself, shift right
        // arithmetically) and converted, all exactly.
        unsafe {
            let w = |p: *const i16| _mm_cvtsi32_si128((p as *const i32).read_unaligned());
            let ab = _mm_unpacklo_epi32(w(a), w(b));
            let cd = _mm_unpacklo_epi32(w(c), w(d));
            let all = _mm_unpacklo_epi64(ab, cd);
            let lo = _mm_srai_epi32::<16>(_mm_unpacklo_epi16(all, all));
            let hi = _mm_srai_epi32::<16>(_mm_unpackhi_epi16(all, all));
            [_mm_cvtepi32_ps(lo), _mm_cvtepi32_ps(hi)]
        }
    }
}
