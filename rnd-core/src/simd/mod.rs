//! Every vector instruction of `rnd-core`, and the only module with `unsafe` code
//! (`unsafe_code` is denied elsewhere).
//!
//! - [`Simd`]: the vector level, chosen once per render and passed down (no global).
//! - `load`: voxel rows to f32 lanes (SSE2, AVX2, AVX-512F), for `f32` and `i16`.
//! - `in_range_bits`: which voxels of a row lie in two intervals, eight per compare at
//!   AVX2 (the skip grid's start bits, [`crate::skip`]).
//! - `sse`: the support-2 and support-4 sums of one sample in SSE registers, and four
//!   world-space gradient magnitudes at once (the f64 engine, [`crate::convo`]).
//! - `cubic`: the support-4 sums of two (AVX2) or four (AVX-512) samples at once, one
//!   sample per 128-bit lane, lane for lane the SSE operations.
//! - `lanes`: the reference arithmetic's running sums of [`LANES`] samples side by
//!   side, one sample per f32 lane ([`crate::refarith::Lanes`]).
//!
//! Voxels are read without bounds checks only through `Supports`, whose constructor
//! checks every support against the data. Every path performs the same f32 operations
//! in the same order as the portable code (no fused multiply-add), so images are the
//! same bits at every level.

/// A vector instruction level asked for (e.g. `RenderParams::simd`); [`Simd::at_most`]
/// turns it into one this processor runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub enum SimdLevel {
    /// The baseline of the target (SSE2 on x86_64), or portable code.
    Baseline,
    /// AVX2 (x86_64).
    Avx2,
    /// AVX2 and AVX-512F (x86_64): the best there is.
    #[default]
    Avx512,
}

/// A vector instruction level this processor and operating system support, chosen once
/// per render and passed down to every convolution sum (no global state). Only
/// [`Simd::detect`] and [`Simd::at_most`] make one, so holding it proves the support.
/// Images are the same bits at every level.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Simd(SimdLevel);

impl Simd {
    /// The best level this processor and operating system support.
    pub fn detect() -> Simd {
        Simd(match detect() {
            3 => SimdLevel::Avx512,
            2 => SimdLevel::Avx2,
            _ => SimdLevel::Baseline,
        })
    }

    /// `level`, or the best supported level below it.
    pub fn at_most(level: SimdLevel) -> Simd {
        Simd(level.min(Simd::detect().0))
    }

    /// The level.
    pub fn level(self) -> SimdLevel {
        self.0
    }

    /// Whether the AVX2 paths run at this level.
    #[inline(always)]
    pub fn avx2(self) -> bool {
        self.0 >= SimdLevel::Avx2
    }

    /// Whether the AVX-512 paths run at this level.
    #[inline(always)]
    pub fn avx512(self) -> bool {
        self.0 >= SimdLevel::Avx512
    }

    /// What the level uses, for people ("SSE2, AVX2", ...).
    pub fn describe(self) -> &'static str {
        match (self.0, cfg!(target_arch = "x86_64")) {
            (_, false) => "none (portable code)",
            (SimdLevel::Baseline, true) => "SSE2",
            (SimdLevel::Avx2, true) => "SSE2, AVX2",
            (SimdLevel::Avx512, true) => "SSE2, AVX2, AVX-512",
        }
    }
}

/// Runs `f` compiled for the widest level `simd` allows where the compiler inlines it
/// (the ray loop's position and weight arithmetic over lanes; the same operations, no
/// fused multiply-add, so the same bits).
#[inline(always)]
pub(crate) fn wide<R>(simd: Simd, f: impl FnOnce() -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    if simd.avx2() {
        // SAFETY: a `Simd` of level AVX2 or above exists only where the processor and
        // operating system support AVX2 (`Simd::detect`, `Simd::at_most`).
        return unsafe { with_avx2(f) };
    }
    f()
}

/// `f()` in a function compiled with AVX2.
///
/// # Safety
/// The processor must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn with_avx2<R>(f: impl FnOnce() -> R) -> R {
    f()
}

/// The best level the processor and operating system support (1, 2 or 3).
#[cfg(target_arch = "x86_64")]
fn detect() -> u8 {
    use core::arch::x86_64::{__cpuid, __cpuid_count};
    // CPUID leaf 1: OSXSAVE (ecx bit 27) and AVX (bit 28); XCR0 bits 1 and 2: the
    // operating system saves SSE and AVX state; leaf 7: AVX2 (ebx bit 5), AVX-512F (ebx
    // bit 16), whose state (XCR0 bits 5 to 7) the system must save too.
    #[allow(unused_unsafe)]
    // SAFETY: CPUID exists on every x86_64 processor.
    let (max, l1) = unsafe { (__cpuid(0).eax, __cpuid(1)) };
    if max < 7 || l1.ecx & (1 << 27) == 0 || l1.ecx & (1 << 28) == 0 {
        return 1;
    }
    // SAFETY: OSXSAVE is set, so XGETBV is available.
    let xcr0 = unsafe { xcr0() };
    if xcr0 & 6 != 6 {
        return 1;
    }
    #[allow(unused_unsafe)]
    // SAFETY: as above; leaf 7 exists (max >= 7).
    let l7 = unsafe { __cpuid_count(7, 0) };
    match (
        l7.ebx & (1 << 5) != 0,
        l7.ebx & (1 << 16) != 0 && xcr0 & 0xE0 == 0xE0,
    ) {
        (true, true) => 3,
        (true, false) => 2,
        _ => 1,
    }
}

#[cfg(not(target_arch = "x86_64"))]
fn detect() -> u8 {
    1
}

/// The extended control register XCR0.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "xsave")]
unsafe fn xcr0() -> u64 {
    // SAFETY: the caller checked that the OS enabled XGETBV (OSXSAVE).
    unsafe { core::arch::x86_64::_xgetbv(0) }
}

#[cfg(target_arch = "x86_64")]
mod cubic;
mod lanes;
mod load;
#[cfg(target_arch = "x86_64")]
pub(crate) mod sse;

pub use lanes::LANES;
pub(crate) use lanes::{lane_sums, lane_sums_pair, lane_sums_soa, store_lanes, LaneBatch};
pub(crate) use load::Load;

/// `y` truncated toward zero, for |y| < 2^63 (outside that, some wrong but defined
/// value: callers range-check first). On x86_64 one instruction, without the saturation
/// handling of `as`.
#[inline(always)]
pub(crate) fn trunc_i64(y: f64) -> i64 {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: SSE2 is part of the x86_64 baseline; the conversion has no
        // preconditions (out of range and NaN give i64::MIN).
        unsafe { core::arch::x86_64::_mm_cvttsd_si64(core::arch::x86_64::_mm_set_sd(y)) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        y as i64
    }
}

/// [`crate::math::floorf`] of every lane of `x`, the same bits: at AVX2 and above one
/// rounding instruction per eight lanes, and one per lane left over (rounding toward −∞
/// is exact, keeps −0, ±∞ and NaN), else the portable function lane by lane.
#[inline(always)]
pub(crate) fn floor_lanes<const N: usize>(simd: Simd, x: &mut [f32; N]) {
    #[cfg(target_arch = "x86_64")]
    if simd.avx2() {
        use core::arch::x86_64::{
            _mm256_loadu_ps, _mm256_round_ps, _mm256_storeu_ps, _mm_cvtss_f32, _mm_round_ss,
            _mm_set_ss, _MM_FROUND_NO_EXC, _MM_FROUND_TO_NEG_INF,
        };
        const DOWN: i32 = _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC;
        let mut c = x.chunks_exact_mut(8);
        for c in &mut c {
            // SAFETY: a `Simd` of level AVX2 or above exists only where AVX2 (and so
            // AVX) is supported; the chunk holds exactly eight f32 for the unaligned
            // load and store.
            unsafe {
                let v = _mm256_loadu_ps(c.as_ptr());
                _mm256_storeu_ps(c.as_mut_ptr(), _mm256_round_ps::<DOWN>(v));
            }
        }
        for v in c.into_remainder() {
            // SAFETY: as above (SSE4.1, which AVX2 implies); registers only.
            *v = unsafe {
                let r = _mm_set_ss(*v);
                _mm_cvtss_f32(_mm_round_ss::<DOWN>(r, r))
            };
        }
        return;
    }
    for v in x.iter_mut() {
        *v = crate::math::floorf(*v);
    }
}

/// One axis of the reference's placement of `N` lanes (`refarith::place`, lane by lane):
/// with base = ⌊x⌋ (⌊x + 0.5⌋ with `half`, odd supports), `first` = base + `lo_off`,
/// `frac` = x − base, and `inside` left 1 only where first ≥ 0 and first + `last` ≤ `top`
/// (a NaN lane is outside). At AVX2 and above eight lanes an instruction (the same
/// operations, so the same bits; the portable loop compiled into a tangle of shuffles
/// there), else the portable loop.
#[inline(always)]
pub(crate) fn place_axis_lanes<const N: usize>(
    simd: Simd,
    x: &[f32; N],
    half: bool,
    (lo_off, last, top): (f32, f32, f32),
    first: &mut [f32; N],
    frac: &mut [f32; N],
    inside: &mut [u32; N],
) {
    #[cfg(target_arch = "x86_64")]
    if simd.avx2() && N.is_multiple_of(8) {
        use core::arch::x86_64::*;
        const DOWN: i32 = _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC;
        for c in 0..N / 8 {
            // SAFETY: a `Simd` of level AVX2 or above exists only where AVX2 is
            // supported; lanes 8 c .. 8 c + 8 lie inside each array (N is a multiple of
            // 8), for the unaligned loads and stores.
            unsafe {
                let xv = _mm256_loadu_ps(x.as_ptr().add(8 * c));
                let y = if half {
                    _mm256_add_ps(xv, _mm256_set1_ps(0.5))
                } else {
                    xv
                };
                let b = _mm256_round_ps::<DOWN>(y);
                let f = _mm256_add_ps(b, _mm256_set1_ps(lo_off));
                let ge = _mm256_cmp_ps::<_CMP_GE_OQ>(f, _mm256_setzero_ps());
                let end = _mm256_add_ps(f, _mm256_set1_ps(last));
                let le = _mm256_cmp_ps::<_CMP_LE_OQ>(end, _mm256_set1_ps(top));
                let ok = _mm256_srli_epi32::<31>(_mm256_castps_si256(_mm256_and_ps(ge, le)));
                let at = inside.as_mut_ptr().add(8 * c) as *mut __m256i;
                _mm256_storeu_si256(at, _mm256_and_si256(_mm256_loadu_si256(at), ok));
                _mm256_storeu_ps(first.as_mut_ptr().add(8 * c), f);
                _mm256_storeu_ps(frac.as_mut_ptr().add(8 * c), _mm256_sub_ps(xv, b));
            }
        }
        return;
    }
    let mut base = [0.0f32; N];
    for l in 0..N {
        base[l] = if half { x[l] + 0.5 } else { x[l] };
    }
    floor_lanes(simd, &mut base);
    for l in 0..N {
        first[l] = base[l] + lo_off;
        frac[l] = x[l] - base[l];
        inside[l] &= u32::from((first[l] >= 0.0) & (first[l] + last <= top));
    }
}

/// [`crate::math::sqrtf`] of every lane of `x`, the same bits (IEEE square roots are
/// correctly rounded): at AVX2 and above one instruction per eight lanes, else the
/// portable function lane by lane.
#[inline(always)]
pub(crate) fn sqrt_lanes<const N: usize>(simd: Simd, x: &mut [f32; N]) {
    #[cfg(target_arch = "x86_64")]
    if simd.avx2() && N.is_multiple_of(8) {
        use core::arch::x86_64::{_mm256_loadu_ps, _mm256_sqrt_ps, _mm256_storeu_ps};
        for c in x.chunks_exact_mut(8) {
            // SAFETY: a `Simd` of level AVX2 or above exists only where AVX2 (and so
            // AVX) is supported; the chunk holds exactly eight f32 for the unaligned
            // load and store.
            unsafe {
                let v = _mm256_loadu_ps(c.as_ptr());
                _mm256_storeu_ps(c.as_mut_ptr(), _mm256_sqrt_ps(v));
            }
        }
        return;
    }
    for v in x.iter_mut() {
        *v = crate::math::sqrtf(*v);
    }
}

/// The bits of voxels `row[..8·C]` (as f32) that pass two interval tests: bit t when
/// `row[t]` lies in `tests[0]` (`l ≤ v ≤ h`), bit 16 + t when it lies in `tests[1]` (a
/// NaN voxel passes neither). At AVX2 and above eight voxels per compare; `None` below
/// AVX2, or where `row` holds fewer than 8·C voxels (the caller tests voxel by voxel).
#[inline(always)]
pub(crate) fn in_range_bits<V: Load, const C: usize>(
    simd: Simd,
    row: &[V],
    tests: &[(f32, f32); 2],
) -> Option<u32> {
    const { assert!(C == 1 || C == 2) };
    #[cfg(target_arch = "x86_64")]
    if simd.avx2() && row.len() >= 8 * C {
        use core::arch::x86_64::{
            _mm256_and_ps, _mm256_cmp_ps, _mm256_movemask_ps, _mm256_set1_ps, _CMP_GE_OQ,
            _CMP_LE_OQ,
        };
        // SAFETY: a `Simd` of level AVX2 or above exists only where AVX2 is supported;
        // registers only. The ordered compares are false for NaN, as `>=` and `<=` are.
        let pass = |v, (l, h): (f32, f32)| unsafe {
            let ge = _mm256_cmp_ps::<_CMP_GE_OQ>(v, _mm256_set1_ps(l));
            let le = _mm256_cmp_ps::<_CMP_LE_OQ>(v, _mm256_set1_ps(h));
            _mm256_movemask_ps(_mm256_and_ps(ge, le)) as u32
        };
        let mut bits = 0u32;
        for c in 0..C {
            // SAFETY: AVX2 as above; `row` holds at least 8·C voxels, so the eight from
            // 8·c are readable.
            let v = unsafe { V::load8(row.as_ptr().add(8 * c)) };
            bits |= pass(v, tests[0]) << (8 * c) | pass(v, tests[1]) << (16 + 8 * c);
        }
        return Some(bits);
    }
    let _ = (simd, row, tests);
    None
}

/// The S×S×S supports of N samples in a volume's data (x fastest, rows `s0` voxels
/// apart, slices `s01` apart), checked once to lie inside the data so that their voxels
/// are then read without bounds checks.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Supports<'d, V, const S: usize, const N: usize> {
    data: &'d [V],
    base: [usize; N],
    s0: usize,
    s01: usize,
}

impl<'d, V: crate::voxel::Voxel, const S: usize, const N: usize> Supports<'d, V, S, N> {
    /// The supports whose first voxels are `base`; panics when one does not end inside
    /// `data` (the callers' inside rule makes them fit).
    #[inline(always)]
    pub(crate) fn new(data: &'d [V], base: [usize; N], s0: usize, s01: usize) -> Self {
        let end = Self::end(data.len(), s0, s01);
        // (A fold without early exit: compares side by side, one branch.)
        assert!(base.iter().fold(true, |ok, &b| ok & (b < end)));
        Supports {
            data,
            base,
            s0,
            s01,
        }
    }

    /// The bound every support's first voxel must lie below for the support to end
    /// inside data of `len` voxels (rows `s0` apart, slices `s01`).
    #[inline(always)]
    pub(crate) fn end(len: usize, s0: usize, s01: usize) -> usize {
        len.saturating_sub((S - 1) * (1 + s0 + s01))
    }

    /// Row `j` of slice `k` of sample `i`'s support (S voxels along x), as f32.
    #[inline(always)]
    pub(crate) fn row(&self, i: usize, j: usize, k: usize) -> [f32; S] {
        assert!(j < S && k < S);
        let o = self.base[i] + j * self.s0 + k * self.s01;
        // SAFETY: o + S − 1 ≤ base[i] + (S − 1)(1 + s0 + s01), inside the data (`new`).
        let r = unsafe { self.data.get_unchecked(o..o + S) };
        core::array::from_fn(|x| r[x].to_f32())
    }

    /// [`Supports::row`] for support 4, as one SSE vector.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) fn row4(&self, i: usize, j: usize, k: usize) -> sse::F4 {
        assert!(S == 4 && j < S && k < S);
        let o = self.base[i] + j * self.s0 + k * self.s01;
        // SAFETY: the four voxels from o end inside sample i's support, inside the data.
        unsafe { V::load4(self.data.as_ptr().add(o)) }
    }

    /// The whole support of sample `i` for support 2, as two SSE vectors: rows (0, 0)
    /// and (1, 0), then rows (0, 1) and (1, 1) (row (j, k): row j of slice k).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) fn rows2(&self, i: usize) -> [sse::F4; 2] {
        assert!(S == 2);
        let (s0, s01) = (self.s0, self.s01);
        // SAFETY: the four rows of two voxels are the support of sample i, inside the
        // data (`new`).
        unsafe {
            let p = self.data.as_ptr().add(self.base[i]);
            V::load2x4(p, p.add(s0), p.add(s01), p.add(s0 + s01))
        }
    }

    /// The support-4 sums of all N samples with AVX2 (two per register) or AVX-512F
    /// (four), for fractional offsets `alpha` and the kernel's cubic coefficients `co`
    /// (value, derivative), bit for bit what [`sse`] gives sample by sample. False (and
    /// nothing written) when `simd` has no AVX2 or N is not a multiple of 4.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) fn cubic_sums<const G: bool>(
        &self,
        simd: Simd,
        alpha: &[[f64; 3]; N],
        co: &[[[f32; 4]; 4]; 2],
        out: &mut [[f32; 4]; N],
    ) -> bool {
        if S != 4 || !simd.avx2() || !N.is_multiple_of(4) {
            return false;
        }
        let (d, b) = (self.data, &self.base);
        // SAFETY: AVX2 (and AVX-512F when asked) are supported (a `Simd` proves it), N
        // is a multiple of 4, and every support was checked in `new`.
        unsafe {
            cubic::sums_pairs::<V, G, N>(d, b, self.s0, self.s01, alpha, co, simd.avx512(), out)
        };
        true
    }
}

/// The support-4 sums of the N consecutive samples k, k + 1, … of the index-space ray
/// `start + k step`, with AVX2 or AVX-512F, support starts `floor(x) + lo` and offsets
/// `x − floor(x)` computed in f64 lanes as the scalar code does (so the same bits).
/// Panics when a support is not inside `data`; false (nothing written) when `simd` has
/// no AVX2 or N is not a multiple of 4.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn cubic_run<V: crate::voxel::Voxel, const G: bool, const N: usize>(
    simd: Simd,
    data: &[V],
    s0: usize,
    s01: usize,
    lo: i64,
    start: &[f64; 3],
    step: &[f64; 3],
    k: u32,
    co: &[[[f32; 4]; 4]; 2],
    out: &mut [[f32; 4]; N],
) -> bool {
    if !simd.avx2() || !N.is_multiple_of(4) {
        return false;
    }
    let wide = simd.avx512();
    // SAFETY: the features are supported (a `Simd` proves it), N is a multiple of 4; the
    // supports are checked inside.
    unsafe { cubic::sums_run::<V, G, N>(data, s0, s01, lo, start, step, k, co, wide, out) };
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use alloc::vec;

    /// `Kernel::ref_weights_lanes` is `ref_weights` (and `ref_weights_d1`) lane by lane,
    /// for every kernel that has it: offsets across [0, 1) (odd supports: [−½, ½)), their ends, ½
    /// and −0 included.
    #[test]
    fn lane_weights_are_ref_weights() {
        use crate::kernel::{BoxK, Bspln2, Bspln3, C4Hexic, Ctmr, Kernel, Tent};
        fn get<K: Kernel<S>, const S: usize, const D1: bool>(
            al: &[f32; 16],
        ) -> Option<[[u32; 16]; S]> {
            K::ref_weights_lanes::<D1, 16>(al).map(|w| w.map(|r| r.map(f32::to_bits)))
        }
        fn check<K: Kernel<S>, const S: usize>(al: [f32; 16]) {
            let al = if S % 2 == 1 { al.map(|a| a - 0.5) } else { al };
            let (Some(w), Some(d)) = (get::<K, S, false>(&al), get::<K, S, true>(&al)) else {
                // (Tent has the lane forms.)
                assert_ne!(K::NAME, crate::kernel::KernelName::Tent);
                return;
            };
            for l in 0..16 {
                let (ws, ds) = (K::ref_weights(al[l]), K::ref_weights_d1(al[l]));
                for i in 0..S {
                    let name = K::NAME;
                    assert_eq!(
                        w[i][l],
                        ws[i].to_bits(),
                        "{name:?} weight {i} at {:e}",
                        al[l]
                    );
                    assert_eq!(d[i][l], ds[i].to_bits(), "{name:?} d1 {i} at {:e}", al[l]);
                }
            }
        }
        let one = 1.0f32.to_bits();
        let mut als = vec![
            0.0f32,
            -0.0,
            0.5,
            f32::from_bits(one - 1),
            f32::from_bits(1),
        ];
        let mut x = 0x9e37_79b9u32;
        for _ in 0..4000 {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            als.push(f32::from_bits(x % one));
        }
        for c in als.chunks_exact(16) {
            let al: [f32; 16] = c.try_into().unwrap();
            check::<BoxK, 1>(al);
            check::<Tent, 2>(al);
            check::<Bspln2, 3>(al);
            check::<Bspln3, 4>(al);
            check::<Ctmr, 4>(al);
            check::<C4Hexic, 6>(al);
        }
    }

    #[test]
    fn floor_lanes_is_floorf_at_every_level() {
        // Integers and their neighbours, halves, signed zeros, the magnitudes near 2^23,
        // infinities, NaN and a stride through all bit patterns, 16 lanes at a time (and
        // 13).
        let mut xs = vec![0.0f32, -0.0, f32::INFINITY, f32::NEG_INFINITY, f32::NAN];
        for i in -300i32..=300 {
            let b = (i as f32).to_bits();
            xs.extend(
                (0..8u32).flat_map(|d| [b.wrapping_add(d), b.wrapping_sub(d)].map(f32::from_bits)),
            );
            xs.push(i as f32 + 0.5);
        }
        for d in 0..64u32 {
            let b = 8_388_608.0f32.to_bits();
            xs.extend(
                [b - d, b + d]
                    .map(f32::from_bits)
                    .into_iter()
                    .flat_map(|x| [x, -x]),
            );
        }
        xs.extend((0..u32::MAX / 1_000_003).map(|i| f32::from_bits(i * 1_000_003)));
        for level in [SimdLevel::Baseline, SimdLevel::Avx2, SimdLevel::Avx512] {
            let simd = Simd::at_most(level);
            for chunk in xs.chunks(16) {
                let mut lanes = [0.0f32; 16];
                lanes[..chunk.len()].copy_from_slice(chunk);
                let want = lanes.map(crate::math::floorf);
                // Sixteen lanes, and thirteen (eight and five left over).
                let mut odd: [f32; 13] = core::array::from_fn(|l| lanes[l]);
                wide(simd, || floor_lanes(simd, &mut lanes));
                wide(simd, || floor_lanes(simd, &mut odd));
                for (g, w) in lanes.iter().chain(&odd).zip(want.iter().chain(&want[..13])) {
                    assert!(
                        g.to_bits() == w.to_bits() || (g.is_nan() && w.is_nan()),
                        "{:?}: {g:e} != {w:e}",
                        simd.level()
                    );
                }
            }
        }
    }
}
