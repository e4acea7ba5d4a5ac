//! The voxel types a volume may hold: `f32` and `i16` (a sealed trait).

mod sealed {
    pub trait Sealed {}
    impl Sealed for f32 {}
    impl Sealed for i16 {}
}

/// A voxel sample type. Implemented for `f32` and `i16` only (sealed).
pub trait Voxel: sealed::Sealed + Copy + Send + Sync + Default + PartialOrd + 'static {
    /// NRRD-style type name (`float`, `short`).
    const TYPE_NAME: &'static str;
    /// The value as f32 (i16 converts exactly).
    fn to_f32(self) -> f32;
    /// The samples as f32 without conversion, when they already are f32.
    #[inline(always)]
    fn as_f32_slice(_s: &[Self]) -> Option<&[f32]> {
        None
    }
    /// Four consecutive voxels starting at `p`, converted to f32 lanes (SSE2).
    ///
    /// # Safety
    /// `p` must point at four readable consecutive voxels.
    #[cfg(target_arch = "x86_64")]
    unsafe fn load4(p: *const Self) -> core::arch::x86_64::__m128;
}

impl Voxel for f32 {
    const TYPE_NAME: &'static str = "float";
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self
    }
    #[inline(always)]
    fn as_f32_slice(s: &[f32]) -> Option<&[f32]> {
        Some(s)
    }
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn load4(p: *const f32) -> core::arch::x86_64::__m128 {
        // SAFETY: the caller guarantees 4 readable f32 at p; SSE is x86_64 baseline.
        unsafe { core::arch::x86_64::_mm_loadu_ps(p) }
    }
}

impl Voxel for i16 {
    const TYPE_NAME: &'static str = "short";
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self as f32
    }
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
}
