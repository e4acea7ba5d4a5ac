//! The support-4 sums of two (AVX2) or four (AVX-512F) samples at once, one sample in
//! each 128-bit lane of the 256- or 512-bit registers. Every lane sees exactly the
//! operations of the SSE path ([`super::sse::sums4`]), so the results are the same bits
//! whichever is used, on every x86_64 processor.

use core::arch::x86_64::*;

use crate::voxel::Voxel;

/// The sums of `N` samples, `L` per register (one per 128-bit lane), for one vector
/// width: `$vt` the register type, `$feat` its target feature, `$load` the row loader
/// (`L` pointers), `$xs` a function putting `L` scalars each into a whole 128-bit
/// lane, `$bc` one putting four f32 into every 128-bit lane, and the intrinsics.
macro_rules! lane_sums {
    ($name:ident, $feat:literal, $vt:ty, $l:literal, $load:ident, $xs:ident, $bc:ident,
     $zero:ident, $mul:ident, $add:ident, $shuf:ident, $unlo:ident, $unhi:ident,
     $store:ident) => {
        /// Phase 1 (weights) and phase 2 (sums) for `N` samples whose supports
        /// start at `base` and whose offsets (as f32) are `alpha`, in the order of
        /// `convo::sums`, lane for lane the SSE path.
        ///
        /// # Safety
        /// The CPU supports the feature, `N` is a multiple of the samples per
        /// register, and every support's last voxel `base[i] + 3 (1 + s0 + s01)`
        /// lies inside `data`.
        #[inline]
        #[target_feature(enable = $feat)]
        #[allow(clippy::too_many_arguments)]
        unsafe fn $name<V: Voxel, const G: bool, const N: usize>(
            data: &[V],
            base: &[usize; N],
            s0: usize,
            s01: usize,
            alpha: &[[f32; 3]; N],
            co: &[[[f32; 4]; 4]; 2],
            out: &mut [[f32; 4]; N],
        ) {
            const L: usize = $l;
            debug_assert!(N % L == 0);
            let zero = $zero();
            let horner = |c: &[[f32; 4]; 4], x: $vt| {
                let t = $add($mul($bc(&c[3]), x), $bc(&c[2]));
                let t = $add($mul(t, x), $bc(&c[1]));
                $add($mul(t, x), $bc(&c[0]))
            };
            let lane = |v: $vt, i: usize| match i {
                0 => $shuf::<0x00>(v, v),
                1 => $shuf::<0x55>(v, v),
                2 => $shuf::<0xAA>(v, v),
                _ => $shuf::<0xFF>(v, v),
            };
            // Phase 1: the weights of every register's samples.
            let mut w = [[zero; 3]; N];
            let mut d = [[zero; 3]; N];
            for i in 0..N / L {
                for ax in 0..3 {
                    let x = $xs(core::array::from_fn(|s| alpha[L * i + s][ax]));
                    w[i][ax] = horner(&co[0], x);
                    if G {
                        d[i][ax] = horner(&co[1], x);
                    }
                }
            }
            // Phase 2: the sums.
            let ptr = data.as_ptr();
            for i in 0..N / L {
                let b: [usize; L] = core::array::from_fn(|s| base[L * i + s]);
                let row = |j: usize, k: usize| {
                    let o = j * s0 + k * s01;
                    // SAFETY: row (j, k) of every sample ends at or before its
                    // support's last voxel, inside `data` (caller); the CPU has the
                    // feature (caller).
                    unsafe { V::$load(core::array::from_fn(|s| ptr.add(b[s] + o))) }
                };
                let (w, d) = (&w[i], &d[i]);
                let (mut acc, mut accy, mut accz) = (zero, zero, zero);
                for j in 0..4 {
                    let r0 = row(j, 0);
                    let mut p = $mul(lane(w[2], 0), r0);
                    let mut q = if G { $mul(lane(d[2], 0), r0) } else { zero };
                    for k in 1..4 {
                        let r = row(j, k);
                        p = $add(p, $mul(lane(w[2], k), r));
                        if G {
                            q = $add(q, $mul(lane(d[2], k), r));
                        }
                    }
                    let (wy, dy) = (lane(w[1], j), lane(d[1], j));
                    if j == 0 {
                        acc = $mul(wy, p);
                        if G {
                            accy = $mul(dy, p);
                            accz = $mul(wy, q);
                        }
                    } else {
                        acc = $add(acc, $mul(wy, p));
                        if G {
                            accy = $add(accy, $mul(dy, p));
                            accz = $add(accz, $mul(wy, q));
                        }
                    }
                }
                let wx = w[0];
                let m0 = $mul(wx, acc);
                let mut res = [0.0f32; 4 * L];
                if G {
                    let m1 = $mul(d[0], acc);
                    let m2 = $mul(wx, accy);
                    let m3 = $mul(wx, accz);
                    // In each 128-bit lane, the transpose of the SSE path, then the
                    // same column sums.
                    let t0 = $unlo(m0, m1);
                    let t1 = $unlo(m2, m3);
                    let t2 = $unhi(m0, m1);
                    let t3 = $unhi(m2, m3);
                    let c0 = $shuf::<0x44>(t0, t1);
                    let c1 = $shuf::<0xEE>(t0, t1);
                    let c2 = $shuf::<0x44>(t2, t3);
                    let c3 = $shuf::<0xEE>(t2, t3);
                    let s = $add($add($add(c0, c1), c2), c3);
                    // SAFETY: writes the 4 L f32 of `res`.
                    unsafe { $store(res.as_mut_ptr(), s) };
                    for s in 0..L {
                        out[L * i + s] =
                            [res[4 * s], res[4 * s + 1], res[4 * s + 2], res[4 * s + 3]];
                    }
                } else {
                    let s = $add(m0, $shuf::<0b01>(m0, m0));
                    let s = $add(s, $shuf::<0b10>(m0, m0));
                    let s = $add(s, $shuf::<0b11>(m0, m0));
                    // SAFETY: writes the 4 L f32 of `res`.
                    unsafe { $store(res.as_mut_ptr(), s) };
                    for s in 0..L {
                        out[L * i + s] = [res[4 * s], 0.0, 0.0, 0.0];
                    }
                }
            }
        }
    };
}

/// Two scalars, each in all four lanes of one half.
#[inline]
#[target_feature(enable = "avx2")]
fn xs2(a: [f32; 2]) -> __m256 {
    _mm256_set_m128(_mm_set1_ps(a[1]), _mm_set1_ps(a[0]))
}

/// The same four f32 in both halves.
#[inline]
#[target_feature(enable = "avx2")]
fn bc2(x: &[f32; 4]) -> __m256 {
    // SAFETY: reads the 4 f32 of `x`.
    let v = unsafe { _mm_loadu_ps(x.as_ptr()) };
    _mm256_set_m128(v, v)
}

/// Four scalars, each in all four lanes of one 128-bit lane.
#[inline]
#[target_feature(enable = "avx512f")]
fn xs4(a: [f32; 4]) -> __m512 {
    let v = _mm512_castps128_ps512(_mm_set1_ps(a[0]));
    let v = _mm512_insertf32x4::<1>(v, _mm_set1_ps(a[1]));
    let v = _mm512_insertf32x4::<2>(v, _mm_set1_ps(a[2]));
    _mm512_insertf32x4::<3>(v, _mm_set1_ps(a[3]))
}

/// The same four f32 in all four 128-bit lanes.
#[inline]
#[target_feature(enable = "avx512f")]
fn bc4(x: &[f32; 4]) -> __m512 {
    // SAFETY: reads the 4 f32 of `x`.
    _mm512_broadcast_f32x4(unsafe { _mm_loadu_ps(x.as_ptr()) })
}

lane_sums!(
    pairs,
    "avx2",
    __m256,
    2,
    load4x2,
    xs2,
    bc2,
    _mm256_setzero_ps,
    _mm256_mul_ps,
    _mm256_add_ps,
    _mm256_shuffle_ps,
    _mm256_unpacklo_ps,
    _mm256_unpackhi_ps,
    _mm256_storeu_ps
);
lane_sums!(
    quads,
    "avx512f",
    __m512,
    4,
    load4x4,
    xs4,
    bc4,
    _mm512_setzero_ps,
    _mm512_mul_ps,
    _mm512_add_ps,
    _mm512_shuffle_ps,
    _mm512_unpacklo_ps,
    _mm512_unpackhi_ps,
    _mm512_storeu_ps
);

/// Support-4 sums [value, ∂x, ∂y, ∂z] (the last three only when `G`) of `N`
/// samples: sample i's support starts at voxel `base[i]` of `data` (rows `s0`
/// apart, slices `s01` apart), its fractional offsets are `alpha[i]`, and `co` holds
/// the kernel's cubic coefficients for the value and the derivative. Four samples
/// per register with AVX-512 (`wide`), else two. Bit for bit what `Convo::sums`
/// gives for each sample.
///
/// # Safety
/// The CPU supports AVX2 (and AVX-512F when `wide`), `N` is a multiple of 4, and
/// for every i the voxel `base[i] + 3 (1 + s0 + s01)` lies inside `data`.
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
    wide: bool,
    out: &mut [[f32; 4]; N],
) {
    let al: [[f32; 3]; N] = core::array::from_fn(|i| alpha[i].map(|a| a as f32));
    // SAFETY: passed on from the caller.
    unsafe {
        if wide {
            quads::<V, G, N>(data, base, s0, s01, &al, co, out)
        } else {
            pairs::<V, G, N>(data, base, s0, s01, &al, co, out)
        }
    }
}

/// [`sums_pairs`] for the `N` consecutive samples k, k + 1, … of the ray `start +
/// k step` (index space), all inside the volume (support start `floor(x) + lo` on
/// each axis, fractional offset `x − floor(x)`, as `convo::locate` for even
/// supports): positions, floors and offsets in 256-bit f64 lanes, the same operations
/// as the scalar code, so the same bits.
///
/// # Safety
/// The CPU supports AVX2 (and AVX-512F when `wide`), and `N` is a multiple of 4.
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
    wide: bool,
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
    // SAFETY: the features (caller), N a multiple of 4 (caller), every support
    // checked above.
    unsafe {
        if wide {
            quads::<V, G, N>(data, &base, s0, s01, &al, co, out)
        } else {
            pairs::<V, G, N>(data, &base, s0, s01, &al, co, out)
        }
    }
}
