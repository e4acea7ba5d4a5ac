//! AVX2, chosen at run time: the support-4 sums of two samples at once, one sample in
//! each 128-bit half of the 256-bit registers. Every lane sees exactly the operations of
//! the SSE path ([`crate::convo`]), so the results are the same bits with or without
//! AVX2, on every x86_64 processor.

use core::sync::atomic::{AtomicU8, Ordering};

/// 0: not yet detected; 1: off; 2: on.
static STATE: AtomicU8 = AtomicU8::new(0);

/// Whether the AVX2 paths are used: the processor and the operating system support
/// AVX2, and [`set_avx2`] has not turned them off.
pub fn avx2_enabled() -> bool {
    match STATE.load(Ordering::Relaxed) {
        0 => {
            let on = detect();
            STATE.store(if on { 2 } else { 1 }, Ordering::Relaxed);
            on
        }
        s => s == 2,
    }
}

/// Turns the AVX2 paths off (`false`), or back on where supported (`true`). Images are
/// the same bits either way; this is for comparisons and benchmarks. Takes effect for
/// convolution states created afterwards.
pub fn set_avx2(on: bool) {
    let on = on && detect();
    STATE.store(if on { 2 } else { 1 }, Ordering::Relaxed);
}

#[cfg(target_arch = "x86_64")]
fn detect() -> bool {
    use core::arch::x86_64::{__cpuid, __cpuid_count};
    // CPUID leaf 1: OSXSAVE (ecx bit 27) and AVX (bit 28); XCR0 bits 1 and 2: the
    // operating system saves SSE and AVX state; leaf 7: AVX2 (ebx bit 5).
    #[allow(unused_unsafe)]
    // SAFETY: CPUID exists on every x86_64 processor.
    let (max, l1) = unsafe { (__cpuid(0).eax, __cpuid(1)) };
    if max < 7 || l1.ecx & (1 << 27) == 0 || l1.ecx & (1 << 28) == 0 {
        return false;
    }
    // SAFETY: OSXSAVE is set, so XGETBV is available.
    if unsafe { xcr0() } & 6 != 6 {
        return false;
    }
    #[allow(unused_unsafe)]
    // SAFETY: as above; leaf 7 exists (max >= 7).
    let l7 = unsafe { __cpuid_count(7, 0) };
    l7.ebx & (1 << 5) != 0
}

#[cfg(not(target_arch = "x86_64"))]
fn detect() -> bool {
    false
}

/// The extended control register XCR0.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "xsave")]
unsafe fn xcr0() -> u64 {
    // SAFETY: the caller checked that the OS enabled XGETBV (OSXSAVE).
    unsafe { core::arch::x86_64::_xgetbv(0) }
}

#[cfg(target_arch = "x86_64")]
pub(crate) use imp::{sums_pairs, sums_run};

#[cfg(target_arch = "x86_64")]
mod imp {
    use core::arch::x86_64::*;

    use crate::voxel::Voxel;

    /// The same four f32 in both halves.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn both(x: &[f32; 4]) -> __m256 {
        // SAFETY: reads the 4 f32 of `x`.
        let v = unsafe { _mm_loadu_ps(x.as_ptr()) };
        _mm256_set_m128(v, v)
    }

    /// Cubic Horner evaluation of coefficient rows `co` (as `sse::horner`) at `a` in the
    /// low half and `b` in the high half.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn horner(co: &[[f32; 4]; 4], a: f32, b: f32) -> __m256 {
        let x = _mm256_set_m128(_mm_set1_ps(b), _mm_set1_ps(a));
        let t = _mm256_add_ps(_mm256_mul_ps(both(&co[3]), x), both(&co[2]));
        let t = _mm256_add_ps(_mm256_mul_ps(t, x), both(&co[1]));
        _mm256_add_ps(_mm256_mul_ps(t, x), both(&co[0]))
    }

    /// Lane `i` of each half of `v` throughout that half.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn lane(v: __m256, i: usize) -> __m256 {
        match i {
            0 => _mm256_shuffle_ps::<0x00>(v, v),
            1 => _mm256_shuffle_ps::<0x55>(v, v),
            2 => _mm256_shuffle_ps::<0xAA>(v, v),
            _ => _mm256_shuffle_ps::<0xFF>(v, v),
        }
    }

    /// Support-4 sums [value, ∂x, ∂y, ∂z] (the last three only when `G`) of `N`
    /// samples, two at a time: sample i's support starts at voxel `base[i]` of `data`
    /// (rows `s0` apart, slices `s01` apart), its fractional offsets are `alpha[i]`, and
    /// `co` holds the kernel's cubic coefficients for the value and the derivative.
    /// Bit for bit what `Convo::sums` gives for each sample.
    ///
    /// # Safety
    /// The CPU supports AVX2, `N` is even, and for every i the voxel
    /// `base[i] + 3 (1 + s0 + s01)` lies inside `data`.
    #[inline]
    #[target_feature(enable = "avx2")]
    #[allow(clippy::too_many_arguments)]
    pub(crate) unsafe fn sums_pairs<V: Voxel, const G: bool, const N: usize>(
        data: &[V],
        base: &[usize; N],
        s0: usize,
        s01: usize,
        alpha: &[[f64; 3]; N],
        co: &[[[f32; 4]; 4]; 2],
        out: &mut [[f32; 4]; N],
    ) {
        let al: [[f32; 3]; N] = core::array::from_fn(|i| alpha[i].map(|a| a as f32));
        // SAFETY: passed on from the caller.
        unsafe { pairs::<V, G, N>(data, base, s0, s01, &al, co, out) }
    }

    /// [`sums_pairs`] for the `N` consecutive samples k, k + 1, … of the ray `start +
    /// k step` (index space), all inside the volume (support start `floor(x) + lo` on
    /// each axis, fractional offset `x − floor(x)`, as `convo::locate` for even
    /// supports): positions, floors and offsets in 256-bit f64 lanes, the same operations
    /// as the scalar code, so the same bits.
    ///
    /// # Safety
    /// The CPU supports AVX2 and `N` is even.
    #[inline]
    #[target_feature(enable = "avx2")]
    #[allow(clippy::too_many_arguments)]
    pub(crate) unsafe fn sums_run<V: Voxel, const G: bool, const N: usize>(
        data: &[V],
        s0: usize,
        s01: usize,
        lo: i64,
        start: &[f64; 3],
        step: &[f64; 3],
        k: u32,
        co: &[[[f32; 4]; 4]; 2],
        out: &mut [[f32; 4]; N],
    ) {
        let st = _mm256_set_pd(0.0, start[2], start[1], start[0]);
        let sp = _mm256_set_pd(0.0, step[2], step[1], step[0]);
        let mut base = [0usize; N];
        let mut al = [[0.0f32; 3]; N];
        for i in 0..N {
            let kf = _mm256_set1_pd((k + i as u32) as f64);
            let x = _mm256_add_pd(st, _mm256_mul_pd(kf, sp));
            let f = _mm256_floor_pd(x);
            // Rounded to f32 as `as f32` does (to nearest, the MXCSR default).
            let a = _mm256_cvtpd_ps(_mm256_sub_pd(x, f));
            let n = _mm256_cvttpd_epi32(f);
            let mut ni = [0i32; 4];
            let mut af = [0.0f32; 4];
            // SAFETY: 4 i32 / 4 f32 stores into local arrays.
            unsafe {
                _mm_storeu_si128(ni.as_mut_ptr() as *mut __m128i, n);
                _mm_storeu_ps(af.as_mut_ptr(), a);
            }
            let n = [0, 1, 2].map(|c| i64::from(ni[c]) + lo);
            let b = n[0] as usize + s0 * n[1] as usize + s01 * n[2] as usize;
            // Memory safety rests on this check (the caller's span makes it hold).
            assert!(n.iter().all(|&c| c >= 0) && b + 3 * (1 + s0 + s01) < data.len());
            base[i] = b;
            al[i] = [af[0], af[1], af[2]];
        }
        // SAFETY: AVX2 (caller), N even (caller), every support checked above.
        unsafe { pairs::<V, G, N>(data, &base, s0, s01, &al, co, out) }
    }

    /// Phase 1 (weights) and phase 2 (sums) of [`sums_pairs`], offsets already in f32.
    ///
    /// # Safety
    /// As [`sums_pairs`].
    #[inline]
    #[target_feature(enable = "avx2")]
    #[allow(clippy::too_many_arguments)]
    unsafe fn pairs<V: Voxel, const G: bool, const N: usize>(
        data: &[V],
        base: &[usize; N],
        s0: usize,
        s01: usize,
        alpha: &[[f32; 3]; N],
        co: &[[[f32; 4]; 4]; 2],
        out: &mut [[f32; 4]; N],
    ) {
        debug_assert!(N % 2 == 0);
        let zero = _mm256_setzero_ps();
        // Phase 1: the weights of every pair (value, and derivative when G).
        let mut w = [[zero; 3]; N];
        let mut d = [[zero; 3]; N];
        for i in 0..N / 2 {
            let (a, b) = (&alpha[2 * i], &alpha[2 * i + 1]);
            for ax in 0..3 {
                w[i][ax] = horner(&co[0], a[ax], b[ax]);
                if G {
                    d[i][ax] = horner(&co[1], a[ax], b[ax]);
                }
            }
        }
        // Phase 2: the sums of every pair, in the order of `convo::sums`.
        let ptr = data.as_ptr();
        for i in 0..N / 2 {
            let (ba, bb) = (base[2 * i], base[2 * i + 1]);
            let row = |j: usize, k: usize| {
                let o = j * s0 + k * s01;
                // SAFETY: row (j, k) of either sample ends at or before its support's
                // last voxel, which the caller guarantees is inside `data`; AVX2 is
                // supported (caller).
                unsafe { V::load4x2(ptr.add(ba + o), ptr.add(bb + o)) }
            };
            let (w, d) = (&w[i], &d[i]);
            let (mut acc, mut accy, mut accz) = (zero, zero, zero);
            for j in 0..4 {
                let r0 = row(j, 0);
                let mut p = _mm256_mul_ps(lane(w[2], 0), r0);
                let mut q = if G {
                    _mm256_mul_ps(lane(d[2], 0), r0)
                } else {
                    zero
                };
                for k in 1..4 {
                    let r = row(j, k);
                    p = _mm256_add_ps(p, _mm256_mul_ps(lane(w[2], k), r));
                    if G {
                        q = _mm256_add_ps(q, _mm256_mul_ps(lane(d[2], k), r));
                    }
                }
                let (wy, dy) = (lane(w[1], j), lane(d[1], j));
                if j == 0 {
                    acc = _mm256_mul_ps(wy, p);
                    if G {
                        accy = _mm256_mul_ps(dy, p);
                        accz = _mm256_mul_ps(wy, q);
                    }
                } else {
                    acc = _mm256_add_ps(acc, _mm256_mul_ps(wy, p));
                    if G {
                        accy = _mm256_add_ps(accy, _mm256_mul_ps(dy, p));
                        accz = _mm256_add_ps(accz, _mm256_mul_ps(wy, q));
                    }
                }
            }
            let wx = w[0];
            let m0 = _mm256_mul_ps(wx, acc);
            let mut res = [0.0f32; 8];
            if G {
                let m1 = _mm256_mul_ps(d[0], acc);
                let m2 = _mm256_mul_ps(wx, accy);
                let m3 = _mm256_mul_ps(wx, accz);
                // In each half, the transpose of the SSE path, then the same column sums.
                let t0 = _mm256_unpacklo_ps(m0, m1);
                let t1 = _mm256_unpacklo_ps(m2, m3);
                let t2 = _mm256_unpackhi_ps(m0, m1);
                let t3 = _mm256_unpackhi_ps(m2, m3);
                let c0 = _mm256_shuffle_ps::<0x44>(t0, t1);
                let c1 = _mm256_shuffle_ps::<0xEE>(t0, t1);
                let c2 = _mm256_shuffle_ps::<0x44>(t2, t3);
                let c3 = _mm256_shuffle_ps::<0xEE>(t2, t3);
                let s = _mm256_add_ps(_mm256_add_ps(_mm256_add_ps(c0, c1), c2), c3);
                // SAFETY: writes the 8 f32 of `res`.
                unsafe { _mm256_storeu_ps(res.as_mut_ptr(), s) };
                out[2 * i] = [res[0], res[1], res[2], res[3]];
                out[2 * i + 1] = [res[4], res[5], res[6], res[7]];
            } else {
                let s = _mm256_add_ps(m0, _mm256_shuffle_ps::<0b01>(m0, m0));
                let s = _mm256_add_ps(s, _mm256_shuffle_ps::<0b10>(m0, m0));
                let s = _mm256_add_ps(s, _mm256_shuffle_ps::<0b11>(m0, m0));
                // SAFETY: writes the 8 f32 of `res`.
                unsafe { _mm256_storeu_ps(res.as_mut_ptr(), s) };
                out[2 * i] = [res[0], 0.0, 0.0, 0.0];
                out[2 * i + 1] = [res[4], 0.0, 0.0, 0.0];
            }
        }
    }
}
