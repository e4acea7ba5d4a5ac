//! The reference arithmetic's running sums of [`LANES`] samples side by side, one
//! sample per f32 lane: every lane does exactly the operations of
//! [`crate::refarith::convolve`] for its sample (so the same bits), and the lanes' chains
//! of S³ dependent additions are independent, so they fill the vector registers.

use core::mem::MaybeUninit;

use crate::kernel::Kernel;
use crate::voxel::Voxel;

use super::Simd;

/// Samples convolved together by [`crate::refarith::Lanes`].
pub const LANES: usize = 16;

/// Kernel weights per axis, support index and lane.
pub(crate) type LaneWeights<const S: usize> = [[[f32; LANES]; S]; 3];

/// Up to [`LANES`] samples of a volume: the flat index of each one's first support
/// voxel (inside the volume, by the caller's inside rule), its fractional offsets per
/// axis, and how many lanes are taken (at least one).
#[derive(Debug, Clone, Copy)]
pub(crate) struct LaneBatch<'a, V: Voxel> {
    /// The volume's voxels and sizes.
    pub(crate) vol: &'a crate::volume::Volume<'a, V>,
    /// First support voxel of each lane.
    pub(crate) base: &'a [usize; LANES],
    /// Fractional offsets per axis and lane.
    pub(crate) al: &'a [[f32; LANES]; 3],
    /// Lanes taken.
    pub(crate) len: usize,
    /// Whether the value sums are wanted: without, where the gradient is, they may be
    /// left 0 (a gradient-only probe; the gradient's bits are the same).
    pub(crate) value: bool,
}

impl<'a, V: Voxel> LaneBatch<'a, V> {
    /// Groups of eight lanes that hold the batch's samples.
    #[inline(always)]
    fn groups(&self) -> usize {
        self.len.div_ceil(8)
    }

    /// The supports, checked (unused lanes repeat lane 0), and the offsets.
    #[inline(always)]
    fn supports<const S: usize>(self) -> (LaneSupports<'a, V, S>, &'a [[f32; LANES]; 3]) {
        assert!(self.len > 0, "convolving an empty batch");
        let base = if self.len >= LANES {
            *self.base
        } else {
            core::array::from_fn(|l| self.base[if l < self.len { l } else { 0 }])
        };
        let (s0, s01) = (self.vol.row_stride(), self.vol.slice_stride());
        let sup = LaneSupports::new(self.vol.data(), base, s0, s01);
        (sup, self.al)
    }
}

/// The checked supports of a batch's lanes.
type LaneSupports<'d, V, const S: usize> = super::Supports<'d, V, S, LANES>;

/// The lanes' running sums [value, ∂x, ∂y, ∂z] (the gradient only with `G`; with it,
/// the value may be left 0 where `batch.value` is false) into `out` (one entry per
/// lane): [`lane_sums_soa`], stored sample by sample.
#[inline(always)]
pub(crate) fn lane_sums<V: Voxel, K: Kernel<S>, const S: usize, const G: bool>(
    simd: Simd,
    batch: LaneBatch<'_, V>,
    out: &mut [[f32; 4]; LANES],
) {
    store_lanes::<G>(&lane_sums_soa::<V, K, S, G>(simd, batch), out)
}

/// The lanes' running sums, lane-major (`[value, ∂x, ∂y, ∂z][lane]`; the gradient only
/// with `G`; with it, the value may be left 0 where `batch.value` is false), for kernel
/// `K` and the samples of `batch`, at the widest level `simd` allows: AVX-512F for
/// support 4 (all lanes in one register), AVX2 (eight lanes per register; support 4
/// reads rows with one load each), else portable code. The weights are computed in the
/// code compiled for the level, so that they vectorize too.
#[inline(always)]
pub(crate) fn lane_sums_soa<V: Voxel, K: Kernel<S>, const S: usize, const G: bool>(
    simd: Simd,
    batch: LaneBatch<'_, V>,
) -> [[f32; LANES]; 4] {
    #[cfg(target_arch = "x86_64")]
    if S == 4 && simd.avx512() {
        // SAFETY: a `Simd` of level AVX-512 exists only where it is supported.
        return unsafe { with_avx512::<V, K, S, G>(batch) };
    }
    #[cfg(target_arch = "x86_64")]
    if simd.avx2() {
        // SAFETY: a `Simd` of level AVX2 exists only where it is supported.
        return unsafe { with_avx2::<V, K, S, G>(batch) };
    }
    let _ = simd;
    let groups = batch.groups();
    with_weights::<V, K, S, G, _>(batch, |sup, w, dw| {
        sums_lanes::<V, S, G>(sup, w, dw, groups)
    })
}

/// [`lane_sums_soa`] of two batches at once where that is quicker (AVX-512F, support
/// 4: their two chains of additions side by side); None where the level has no such
/// path (then nothing was done). Each batch's sums are the same bits as alone.
#[inline(always)]
pub(crate) fn lane_sums_pair<V: Voxel, K: Kernel<S>, const S: usize, const G: bool>(
    simd: Simd,
    batches: [LaneBatch<'_, V>; 2],
) -> Option<[[[f32; LANES]; 4]; 2]> {
    #[cfg(target_arch = "x86_64")]
    if S == 4 && simd.avx512() {
        // SAFETY: a `Simd` of level AVX-512 exists only where it is supported.
        return Some(unsafe { with_avx512_pair::<V, K, S, G>(batches) });
    }
    let _ = (simd, batches);
    None
}

/// Weights being filled: every element written before the array is read.
type LaneWeightsUninit<const S: usize> = [[[MaybeUninit<f32>; LANES]; S]; 3];

/// `f` of the batch's checked supports and each lane's weights per axis and support
/// index (`w`), and derivative weights (`dw`; with `G` only, else `w` again), as
/// [`crate::refarith::convolve`] computes them ([`Kernel::ref_weights`], or the
/// kernel's [`Kernel::ref_weights_lanes`]). The arrays are filled in place, never
/// zeroed first, and lent to `f` (no copies).
#[inline(always)]
fn with_weights<V: Voxel, K: Kernel<S>, const S: usize, const G: bool, R>(
    batch: LaneBatch<'_, V>,
    f: impl FnOnce(&LaneSupports<'_, V, S>, &LaneWeights<S>, &LaneWeights<S>) -> R,
) -> R {
    let (sup, al) = batch.supports::<S>();
    let mut w: LaneWeightsUninit<S> = [[[MaybeUninit::uninit(); LANES]; S]; 3];
    let mut dw: LaneWeightsUninit<S> = [[[MaybeUninit::uninit(); LANES]; S]; 3];
    for a in 0..3 {
        fill::<K, S, false>(&al[a], &mut w[a]);
        if G {
            fill::<K, S, true>(&al[a], &mut dw[a]);
        }
    }
    // SAFETY: `fill` wrote every element of `w` (and of `dw` with `G`), and
    // `MaybeUninit<f32>` has the layout of `f32`, so the arrays are their f32 arrays.
    let (w, dw) = unsafe {
        let w = &*(&w as *const LaneWeightsUninit<S> as *const LaneWeights<S>);
        let dw = if G {
            &*(&dw as *const LaneWeightsUninit<S> as *const LaneWeights<S>)
        } else {
            w
        };
        (w, dw)
    };
    f(&sup, w, dw)
}

/// Writes every element of `w`: the weights (`D1`: derivative weights) of each lane's
/// offset `al`.
#[inline(always)]
fn fill<K: Kernel<S>, const S: usize, const D1: bool>(
    al: &[f32; LANES],
    w: &mut [[MaybeUninit<f32>; LANES]; S],
) {
    if let Some(ws) = K::ref_weights_lanes::<D1, LANES>(al) {
        for i in 0..S {
            for l in 0..LANES {
                w[i][l].write(ws[i][l]);
            }
        }
        return;
    }
    for l in 0..LANES {
        let ws = if D1 {
            K::ref_weights_d1(al[l])
        } else {
            K::ref_weights(al[l])
        };
        for i in 0..S {
            w[i][l].write(ws[i]);
        }
    }
}

/// Lane-major sums into per-sample results (the value only, without `G`).
#[inline(always)]
pub(crate) fn store_lanes<const G: bool>(r: &[[f32; LANES]; 4], out: &mut [[f32; 4]; LANES]) {
    for l in 0..LANES {
        out[l][0] = r[0][l];
        if G {
            out[l][1] = r[1][l];
            out[l][2] = r[2][l];
            out[l][3] = r[3][l];
        }
    }
}

/// How lane l's support lies against lane 0's in `sup` (see `sums4_avx512`): one row
/// (or one slice) after lane l − 1's, or before it (`desc`): a ray along the volume's
/// second (third) axis, one voxel a step, whose rows (slices) are shared; one voxel
/// after or before it (a ray along the first axis): each row of all lanes is one load;
/// else none of these (0).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn placement<V: Voxel, const S: usize>(sup: &LaneSupports<'_, V, S>) -> (usize, bool) {
    let b = &sup.base;
    let up = |d: usize| (1..LANES).all(|l| b[l] == b[0] + l * d);
    let down = |d: usize| (1..LANES).all(|l| b[l] + l * d == b[0]);
    if up(sup.s0) {
        (ROWS, false)
    } else if down(sup.s0) {
        (ROWS, true)
    } else if up(sup.s01) {
        (SLICES, false)
    } else if down(sup.s01) {
        (SLICES, true)
    } else if up(1) {
        (RUN, false)
    } else if down(1) {
        (RUN, true)
    } else {
        (0, false)
    }
}

/// `sums4_avx512` of one batch placed as `placement` says, for a value (`value`) or
/// not.
///
/// # Safety
/// The CPU must support AVX-512F, and the batch's supports must be placed as `share`
/// and `desc` say (`placement`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn sums4_placed<V: Voxel, const S: usize, const G: bool>(
    value: bool,
    (share, desc): (usize, bool),
    sup: &LaneSupports<'_, V, S>,
    w: &LaneWeights<S>,
    dw: &LaneWeights<S>,
) -> [[f32; LANES]; 4] {
    // SAFETY: AVX-512F is enabled here, and the supports are placed as `share` says (the
    // caller's promise).
    let [r] = unsafe {
        match (value, share) {
            (true, 0) => sums4_avx512::<V, S, G, true, 0, 1>([sup], [w], [dw], false),
            (false, 0) => sums4_avx512::<V, S, G, false, 0, 1>([sup], [w], [dw], false),
            (true, RUN) => sums4_avx512::<V, S, G, true, RUN, 1>([sup], [w], [dw], desc),
            (false, RUN) => sums4_avx512::<V, S, G, false, RUN, 1>([sup], [w], [dw], desc),
            (true, ROWS) => sums4_avx512::<V, S, G, true, ROWS, 1>([sup], [w], [dw], desc),
            (false, ROWS) => sums4_avx512::<V, S, G, false, ROWS, 1>([sup], [w], [dw], desc),
            (true, _) => sums4_avx512::<V, S, G, true, SLICES, 1>([sup], [w], [dw], desc),
            (false, _) => sums4_avx512::<V, S, G, false, SLICES, 1>([sup], [w], [dw], desc),
        }
    };
    r
}

/// [`lane_sums`] compiled for AVX-512F (support 4).
///
/// # Safety
/// The CPU must support AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn with_avx512<V: Voxel, K: Kernel<S>, const S: usize, const G: bool>(
    batch: LaneBatch<'_, V>,
) -> [[f32; LANES]; 4] {
    let value = !G || batch.value;
    with_weights::<V, K, S, G, _>(batch, |sup, w, dw| {
        // SAFETY: AVX-512F is enabled here, and `placement` says how the supports lie.
        unsafe { sums4_placed::<V, S, G>(value, placement(sup), sup, w, dw) }
    })
}

/// [`lane_sums_pair`] compiled for AVX-512F (support 4): two batches of the same
/// placement summed side by side, else one after the other.
///
/// # Safety
/// The CPU must support AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn with_avx512_pair<V: Voxel, K: Kernel<S>, const S: usize, const G: bool>(
    batches: [LaneBatch<'_, V>; 2],
) -> [[[f32; LANES]; 4]; 2] {
    let value = !G || batches[0].value;
    with_weights::<V, K, S, G, _>(batches[0], |sa, wa, dwa| {
        with_weights::<V, K, S, G, _>(batches[1], |sb, wb, dwb| {
            let (pa, pb) = (placement(sa), placement(sb));
            let (sups, ws, dws) = ([sa, sb], [wa, wb], [dwa, dwb]);
            // (Batches a row or a slice apart are not paired: measured no quicker.)
            match (pa == pb, value, pa) {
                // SAFETY: AVX-512F is enabled here, and both batches lie as `pa` says.
                (true, true, (0, _)) => unsafe {
                    sums4_avx512::<V, S, G, true, 0, 2>(sups, ws, dws, false)
                },
                // SAFETY: as above.
                (true, false, (0, _)) => unsafe {
                    sums4_avx512::<V, S, G, false, 0, 2>(sups, ws, dws, false)
                },
                // SAFETY: as above.
                (true, true, (RUN, desc)) => unsafe {
                    sums4_avx512::<V, S, G, true, RUN, 2>(sups, ws, dws, desc)
                },
                // SAFETY: as above.
                (true, false, (RUN, desc)) => unsafe {
                    sums4_avx512::<V, S, G, false, RUN, 2>(sups, ws, dws, desc)
                },
                // SAFETY: as in `with_avx512`, batch by batch.
                _ => unsafe {
                    [
                        sums4_placed::<V, S, G>(value, pa, sa, wa, dwa),
                        sums4_placed::<V, S, G>(value, pb, sb, wb, dwb),
                    ]
                },
            }
        })
    })
}

/// [`sums4_avx512`]'s `SHARE` for lanes whose supports are a row apart.
#[cfg(target_arch = "x86_64")]
const ROWS: usize = 1;
/// [`sums4_avx512`]'s `SHARE` for lanes whose supports are a slice apart.
#[cfg(target_arch = "x86_64")]
const SLICES: usize = 2;
/// [`sums4_avx512`]'s `SHARE` for lanes whose supports are a voxel apart.
#[cfg(target_arch = "x86_64")]
const RUN: usize = 3;

/// [`lane_sums`] compiled for AVX2.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn with_avx2<V: Voxel, K: Kernel<S>, const S: usize, const G: bool>(
    batch: LaneBatch<'_, V>,
) -> [[f32; LANES]; 4] {
    let (groups, value) = (batch.groups(), batch.value);
    with_weights::<V, K, S, G, _>(batch, |sup, w, dw| {
        if S == 4 && G && value {
            // SAFETY: AVX2 is enabled here.
            unsafe { grad4_avx2::<V, S, true>(sup, w, dw) }
        } else if S == 4 && G {
            // SAFETY: AVX2 is enabled here.
            unsafe { grad4_avx2::<V, S, false>(sup, w, dw) }
        } else if S == 4 {
            // SAFETY: AVX2 is enabled here.
            unsafe { value4_avx2::<V, S>(sup, w) }
        } else if S == 2 {
            // SAFETY: AVX2 is enabled here.
            unsafe { sums2_avx2::<V, S, G>(sup, w, dw, groups) }
        } else {
            sums_lanes::<V, S, G>(sup, w, dw, groups)
        }
    })
}

/// The lanes' running sums (value, then the gradient's three with `G`), each term
/// ((v·w₀)·w₁)·w₂ with one factor a derivative weight for the gradient, z slowest and x
/// fastest: `convolve`'s operations, lane by lane, for the first `groups` groups of
/// eight lanes (the others' sums stay 0).
#[inline(always)]
fn sums_lanes<V: Voxel, const S: usize, const G: bool>(
    sup: &LaneSupports<'_, V, S>,
    w: &LaneWeights<S>,
    dw: &LaneWeights<S>,
    groups: usize,
) -> [[f32; LANES]; 4] {
    let LaneSupports {
        data,
        base,
        s0,
        s01,
    } = *sup;
    let mut r = [[0.0f32; LANES]; 4];
    for g in 0..groups.min(LANES / 8) {
        for k in 0..S {
            for j in 0..S {
                for i in 0..S {
                    let o = i + j * s0 + k * s01;
                    for l in g * 8..g * 8 + 8 {
                        // SAFETY: base[l] + o lies in lane l's support, checked in `Supports::new`.
                        let x = unsafe { data.get_unchecked(base[l] + o) }.to_f32();
                        let xw0 = x * w[0][i][l];
                        r[0][l] += xw0 * w[1][j][l] * w[2][k][l];
                        if G {
                            r[1][l] += x * dw[0][i][l] * w[1][j][l] * w[2][k][l];
                            r[2][l] += xw0 * dw[1][j][l] * w[2][k][l];
                            r[3][l] += xw0 * w[1][j][l] * dw[2][k][l];
                        }
                    }
                }
            }
        }
    }
    r
}

/// [`sums_lanes`] for support 2 with AVX2: each lane's two voxels along x are one load
/// (`Load::load2x4`, four lanes a call), and two shuffles put voxel 0 and voxel 1 of
/// eight lanes in a register each; then the same operations per lane, in the same
/// order.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn sums2_avx2<V: Voxel, const S: usize, const G: bool>(
    sup: &LaneSupports<'_, V, S>,
    w: &LaneWeights<S>,
    dw: &LaneWeights<S>,
    groups: usize,
) -> [[f32; LANES]; 4] {
    use core::arch::x86_64::*;
    assert!(S == 2 && LANES.is_multiple_of(8));
    let LaneSupports {
        data,
        base,
        s0,
        s01,
    } = *sup;
    let ptr = data.as_ptr();
    // SAFETY: eight readable floats from lane 8 g on (g < LANES / 8).
    let ld = |v: &[f32; LANES], g: usize| unsafe { _mm256_loadu_ps(v.as_ptr().add(8 * g)) };
    let mut r = [[0.0f32; LANES]; 4];
    for g in 0..groups.min(LANES / 8) {
        let mut acc = [_mm256_setzero_ps(); 4];
        for k in 0..S {
            let (w2, d2) = (ld(&w[2][k], g), ld(&dw[2][k], g));
            for j in 0..S {
                let (w1, d1) = (ld(&w[1][j], g), ld(&dw[1][j], g));
                let o = j * s0 + k * s01;
                // SAFETY: base[l] + o and the voxel after it lie in lane l's support,
                // checked in `Supports::new`.
                let p = |l: usize| unsafe { ptr.add(base[8 * g + l] + o) };
                // SAFETY: two readable voxels at each pointer (above).
                let [q0, q1] = unsafe { V::load2x4(p(0), p(1), p(2), p(3)) };
                // SAFETY: as above.
                let [q2, q3] = unsafe { V::load2x4(p(4), p(5), p(6), p(7)) };
                // [l0 l1 | l4 l5] and [l2 l3 | l6 l7], each lane's pair side by side.
                let (a, c) = (_mm256_set_m128(q2, q0), _mm256_set_m128(q3, q1));
                let xs = [
                    _mm256_shuffle_ps::<0x88>(a, c),
                    _mm256_shuffle_ps::<0xDD>(a, c),
                ];
                for (i, x) in xs.into_iter().enumerate() {
                    let xw0 = _mm256_mul_ps(x, ld(&w[0][i], g));
                    let t = _mm256_mul_ps(_mm256_mul_ps(xw0, w1), w2);
                    acc[0] = _mm256_add_ps(acc[0], t);
                    if G {
                        let d0 = _mm256_mul_ps(x, ld(&dw[0][i], g));
                        let t1 = _mm256_mul_ps(_mm256_mul_ps(d0, w1), w2);
                        acc[1] = _mm256_add_ps(acc[1], t1);
                        let t2 = _mm256_mul_ps(_mm256_mul_ps(xw0, d1), w2);
                        acc[2] = _mm256_add_ps(acc[2], t2);
                        let t3 = _mm256_mul_ps(_mm256_mul_ps(xw0, w1), d2);
                        acc[3] = _mm256_add_ps(acc[3], t3);
                    }
                }
            }
        }
        for (c, a) in acc.iter().enumerate() {
            // SAFETY: eight writable floats from lane 8 g on.
            unsafe { _mm256_storeu_ps(r[c].as_mut_ptr().add(8 * g), *a) };
        }
    }
    r
}

/// Row `o` (offset from each support's first voxel) of the eight supports starting at
/// `b`, as four registers of eight lanes (register i holds voxel i of each lane's row):
/// each lane's row of four voxels is one load (two lanes per register, see
/// `Load::load4x2`), and a 4 × 4 transpose in each 128-bit half turns rows into lanes.
///
/// # Safety
/// The CPU must support AVX2, and `b[l] + o .. + 3` must lie inside the data at `ptr`
/// for every lane l.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn rows8<V: Voxel>(
    ptr: *const V,
    b: &[usize; 8],
    o: usize,
) -> [core::arch::x86_64::__m256; 4] {
    use core::arch::x86_64::*;
    // SAFETY: each row lies inside the data (caller); AVX2 is enabled here.
    let row = |l: usize| unsafe { V::load4x2([ptr.add(b[l] + o), ptr.add(b[l + 4] + o)]) };
    let (a0, a1, a2, a3) = (row(0), row(1), row(2), row(3));
    let (t0, t1) = (_mm256_unpacklo_ps(a0, a1), _mm256_unpackhi_ps(a0, a1));
    let (t2, t3) = (_mm256_unpacklo_ps(a2, a3), _mm256_unpackhi_ps(a2, a3));
    [
        _mm256_shuffle_ps::<0x44>(t0, t2),
        _mm256_shuffle_ps::<0xEE>(t0, t2),
        _mm256_shuffle_ps::<0x44>(t1, t3),
        _mm256_shuffle_ps::<0xEE>(t1, t3),
    ]
}

/// [`sums_lanes`]'s value sums for support 4 with AVX2, rows into lanes by [`rows8`]:
/// the same operations per lane. The two registers of eight lanes are interleaved:
/// their chains are independent, so the additions of one hide the latency of the
/// other's.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn value4_avx2<V: Voxel, const S: usize>(
    sup: &LaneSupports<'_, V, S>,
    w: &LaneWeights<S>,
) -> [[f32; LANES]; 4] {
    use core::arch::x86_64::*;
    const H: usize = LANES / 8;
    assert!(S == 4 && LANES.is_multiple_of(8));
    let LaneSupports {
        data,
        base,
        s0,
        s01,
    } = *sup;
    let ptr = data.as_ptr();
    let ld = |v: &[f32; LANES], h: usize| {
        // SAFETY: eight readable floats from lane 8 h on.
        unsafe { _mm256_loadu_ps(v.as_ptr().add(8 * h)) }
    };
    let b: [[usize; 8]; H] = core::array::from_fn(|h| core::array::from_fn(|l| base[8 * h + l]));
    let mut val = [_mm256_setzero_ps(); H];
    for k in 0..S {
        for j in 0..S {
            let o = j * s0 + k * s01;
            // SAFETY: b[h][l] + o .. + 3 lies in the support of lane 8 h + l (checked in
            // `Supports::new`; S is 4); AVX2 is enabled here.
            let x: [[__m256; 4]; H] = core::array::from_fn(|h| unsafe { rows8(ptr, &b[h], o) });
            for i in 0..S {
                for h in 0..H {
                    let (w1, w2) = (ld(&w[1][j], h), ld(&w[2][k], h));
                    let xw0 = _mm256_mul_ps(x[h][i], ld(&w[0][i], h));
                    val[h] = _mm256_add_ps(val[h], _mm256_mul_ps(_mm256_mul_ps(xw0, w1), w2));
                }
            }
        }
    }
    let mut r = [[0.0f32; LANES]; 4];
    for (h, v) in val.into_iter().enumerate() {
        // SAFETY: eight writable floats from lane 8 h on.
        unsafe { _mm256_storeu_ps(r[0].as_mut_ptr().add(8 * h), v) };
    }
    r
}

/// [`value4_avx2`] with the gradient (and the value only with `VAL`), one register of
/// eight lanes at a time: its running sums are independent chains already, so the two
/// registers need not be interleaved. The sixteen rows of a support are a loop, not
/// unrolled, so that the sums stay in registers from row to row (unrolled, the
/// compiler spilled them, and each addition waited on a reload), and each row is read
/// one iteration ahead, so that its products wait on no load. The same operations per
/// lane; without `VAL` the value sums are left 0.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn grad4_avx2<V: Voxel, const S: usize, const VAL: bool>(
    sup: &LaneSupports<'_, V, S>,
    w: &LaneWeights<S>,
    dw: &LaneWeights<S>,
) -> [[f32; LANES]; 4] {
    use core::arch::x86_64::*;
    assert!(S == 4 && LANES.is_multiple_of(8));
    let LaneSupports {
        data,
        base,
        s0,
        s01,
    } = *sup;
    let ptr = data.as_ptr();
    let mut r = [[0.0f32; LANES]; 4];
    for h in 0..LANES / 8 {
        let ld = |v: &[f32; LANES]| {
            // SAFETY: eight readable floats from lane 8 h on.
            unsafe { _mm256_loadu_ps(v.as_ptr().add(8 * h)) }
        };
        let b: [usize; 8] = core::array::from_fn(|l| base[8 * h + l]);
        let mut val = _mm256_setzero_ps();
        let (mut g0, mut g1, mut g2) = (val, val, val);
        // SAFETY: b[l] + j s0 + k s01 .. + 3 (j, k < S) lies in the support of lane
        // 8 h + l (checked in `Supports::new`; S is 4); AVX2 is enabled here.
        let rows = |row: usize| unsafe { rows8(ptr, &b, row % S * s0 + row / S * s01) };
        let mut x = rows(0);
        let mut row = 0;
        while row < S * S {
            let (j, k) = (row % S, row / S);
            // (The last row reads the first again, unused.)
            let next = rows((row + 1) % (S * S));
            let (w1, d1, w2, d2) = (ld(&w[1][j]), ld(&dw[1][j]), ld(&w[2][k]), ld(&dw[2][k]));
            for (i, &xi) in x.iter().enumerate() {
                let xw0 = _mm256_mul_ps(xi, ld(&w[0][i]));
                let xw0w1 = _mm256_mul_ps(xw0, w1);
                if VAL {
                    val = _mm256_add_ps(val, _mm256_mul_ps(xw0w1, w2));
                }
                let xd0 = _mm256_mul_ps(xi, ld(&dw[0][i]));
                g0 = _mm256_add_ps(g0, _mm256_mul_ps(_mm256_mul_ps(xd0, w1), w2));
                g1 = _mm256_add_ps(g1, _mm256_mul_ps(_mm256_mul_ps(xw0, d1), w2));
                g2 = _mm256_add_ps(g2, _mm256_mul_ps(xw0w1, d2));
            }
            x = next;
            row += 1;
        }
        for (dst, v) in r.iter_mut().zip([val, g0, g1, g2]) {
            // SAFETY: eight writable floats from lane 8 h on.
            unsafe { _mm256_storeu_ps(dst.as_mut_ptr().add(8 * h), v) };
        }
    }
    r
}

/// [`value4_avx2`] and [`grad4_avx2`] with AVX-512F: the sixteen lanes in one register. Four loads of four
/// rows each (lanes l, l + 4, l + 8 and l + 12 in the four 128-bit parts, see
/// `Load::load4x4`) and a 4 × 4 transpose in each part give each row element for all
/// lanes in order; the arithmetic per lane is [`sums_lanes`]'s. Without `VAL` (a
/// gradient-only probe) the value sums are left 0 and `((x·w₀)·w₁)` serves the third
/// gradient sum alone: 8 multiplies and 3 additions per voxel instead of 10 and 4, the
/// same gradient bits.
///
/// With `SHARE` = `ROWS` each lane's support starts one row after the previous lane's
/// (or before it, with `desc`), so row j of lane l is row 0 of lane l + j (l − j):
/// each slice's nineteen rows are put into lanes once (each lane's row 0, then the
/// three rows past the last lane's), and rows 1–3 of all lanes are those shifted by
/// one to three lanes (`valignd`). The same voxels reach the same lanes, so the same
/// bits, with a third of the row loads, a quarter of the insertions and half the
/// transposes, for twelve shifts a slice (run 52: on Intel's AVX-512 cores these and
/// the arithmetic share two ports). With `SLICES` the same along the third axis: each
/// lane's support starts one slice after (before) the previous lane's, so row j of the
/// nineteen slices is put into lanes once, before the sums, and slice k of all lanes is
/// that shifted by k lanes.
///
/// With `RUN` each lane's support starts one voxel after the previous lane's (before
/// it, with `desc`: a ray along the first axis), so element i of a row of every lane is
/// one load of sixteen consecutive voxels (in reverse lane order with `desc`, put back
/// by one permute): no insertions, transposes or shifts.
///
/// With `ROWS` and `SLICES` every voxel read lies in a lane's checked support whatever
/// the lanes' placement; the sums are right with `ROWS` only where `sup.base[l] =
/// sup.base[0] + l s0` for every lane l (`sup.base[l] + l s0 = sup.base[0]` with
/// `desc`), and with `SLICES` the same with `s01`.
///
/// With `B` = 2 two batches are summed side by side, each exactly as alone (the same
/// placement kind, `SHARE` and `desc`, for both): two independent chains of additions,
/// where one batch's single chain per lane (S³ dependent additions) would bind.
///
/// # Safety
/// The CPU must support AVX-512F, and with `RUN` `sup.base[l] = sup.base[0] + l` for
/// every lane l (`sup.base[l] + l = sup.base[0]` with `desc`) of every batch.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn sums4_avx512<
    V: Voxel,
    const S: usize,
    const G: bool,
    const VAL: bool,
    const SHARE: usize,
    const B: usize,
>(
    sups: [&LaneSupports<'_, V, S>; B],
    ws: [&LaneWeights<S>; B],
    dws: [&LaneWeights<S>; B],
    desc: bool,
) -> [[[f32; LANES]; 4]; B] {
    use core::arch::x86_64::*;
    assert!(S == 4 && LANES == 16);
    let ld = |v: &[f32; LANES]| {
        // SAFETY: sixteen readable floats.
        unsafe { _mm512_loadu_ps(v.as_ptr()) }
    };
    // Element i of every lane's row, from four registers holding the rows of lanes
    // (q, q + 4, q + 8, q + 12) in their 128-bit parts (register q): a 4 × 4 transpose
    // in each part.
    let lanes_of = |a: [__m512; 4]| {
        let (t0, t1) = (
            _mm512_unpacklo_ps(a[0], a[1]),
            _mm512_unpackhi_ps(a[0], a[1]),
        );
        let (t2, t3) = (
            _mm512_unpacklo_ps(a[2], a[3]),
            _mm512_unpackhi_ps(a[2], a[3]),
        );
        [
            _mm512_shuffle_ps::<0x44>(t0, t2),
            _mm512_shuffle_ps::<0xEE>(t0, t2),
            _mm512_shuffle_ps::<0x44>(t1, t3),
            _mm512_shuffle_ps::<0xEE>(t1, t3),
        ]
    };
    // Element i of every lane's row `o` voxels from its support's first (`o` a row of the
    // support: j s0 + k s01, j, k < 4), in batch `b`.
    let lanes_at = |b: usize, o: usize| {
        let (ptr, base) = (sups[b].data.as_ptr(), &sups[b].base);
        // SAFETY: base[l] + o .. + 3 lies in the support of lane l (checked in
        // `Supports::new`; S is 4).
        let row = |l: usize| unsafe {
            V::load4x4([
                ptr.add(base[l] + o),
                ptr.add(base[l + 4] + o),
                ptr.add(base[l + 8] + o),
                ptr.add(base[l + 12] + o),
            ])
        };
        lanes_of([row(0), row(1), row(2), row(3)])
    };
    // With ROWS (SLICES), `stride` s0 (s01): element i of row (slice) t of every lane's
    // support, t = 0..3, for the rows `off` from each support's first voxel (the slice
    // of rows, or the row of slices). Each lane's row 0 is put into lanes, and the three
    // past the last lane's (lane 15's rows 1–3, or with `desc` lane 0's); row t of lane l
    // is row 0 of lane l + t (l − t), so row t of all lanes is those shifted by t lanes.
    let spread = |b: usize, off: usize, stride: usize| -> [[__m512; 4]; 2] {
        let lo = lanes_at(b, off);
        let (ptr, base) = (sups[b].data.as_ptr(), &sups[b].base);
        // SAFETY: base[l] + off + r stride (r < 4, off within a support: the caller's
        // j s0 or k s01) lies in lane l's support, and its four voxels (S is 4; checked
        // in `Supports::new`).
        let p = |l: usize, r: usize| unsafe { ptr.add(base[l] + off + r * stride) };
        // Lanes 0–2 get lane 15's rows 1–3 (lanes 13–15 lane 0's rows 3–1 with `desc`):
        // register q's parts all the same row, so its lanes 4m + q hold it for every m.
        // SAFETY: as above.
        let hi = lanes_of(core::array::from_fn(|q| unsafe {
            V::load4x4(
                [if desc {
                    p(0, 4 - q.max(1))
                } else {
                    p(15, 1 + q.min(2))
                }; 4],
            )
        }));
        [lo, hi]
    };
    // Row t of every lane from `spread`'s rows: element i.
    let shift = |[lo, hi]: &[[__m512; 4]; 2], t: usize, i: usize| {
        let (lo, hi) = (_mm512_castps_si512(lo[i]), _mm512_castps_si512(hi[i]));
        _mm512_castsi512_ps(match (t, desc) {
            (0, _) => lo,
            (1, false) => _mm512_alignr_epi32::<1>(hi, lo),
            (2, false) => _mm512_alignr_epi32::<2>(hi, lo),
            (_, false) => _mm512_alignr_epi32::<3>(hi, lo),
            (1, true) => _mm512_alignr_epi32::<15>(lo, hi),
            (2, true) => _mm512_alignr_epi32::<14>(lo, hi),
            (_, true) => _mm512_alignr_epi32::<13>(lo, hi),
        })
    };
    // With RUN: the support of the lane whose voxels come first in memory (lane 15's
    // with `desc`), and the permute that puts lanes back in order with `desc`.
    let first = sups.map(|sup| {
        if desc {
            sup.base[LANES - 1]
        } else {
            sup.base[0]
        }
    });
    let backwards = _mm512_set_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    let (s0, s01) = (sups[0].s0, sups[0].s01);
    // With SLICES: row j of every lane's slices 0..3, for every j, before the sums.
    let zero = _mm512_setzero_ps();
    let mut by_row = [[[[zero; 4]; 2]; 4]; B];
    if SHARE == SLICES {
        for (b, rows) in by_row.iter_mut().enumerate() {
            for (j, r) in rows.iter_mut().enumerate() {
                *r = spread(b, j * s0, s01);
            }
        }
    }
    let (mut val, mut g0, mut g1, mut g2) = ([zero; B], [zero; B], [zero; B], [zero; B]);
    for k in 0..S {
        let (mut w2, mut d2) = ([zero; B], [zero; B]);
        for b in 0..B {
            (w2[b], d2[b]) = (ld(&ws[b][2][k]), ld(&dws[b][2][k]));
        }
        // With ROWS: rows 0..3 of every lane's slice k.
        let mut by_slice = [[[zero; 4]; 2]; B];
        if SHARE == ROWS {
            for (b, r) in by_slice.iter_mut().enumerate() {
                *r = spread(b, k * s01, s0);
            }
        }
        for j in 0..S {
            let (mut w1, mut d1) = ([zero; B], [zero; B]);
            for b in 0..B {
                (w1[b], d1[b]) = (ld(&ws[b][1][j]), ld(&dws[b][1][j]));
            }
            let mut x = [[zero; 4]; B];
            for (b, x) in x.iter_mut().enumerate() {
                *x = match SHARE {
                    ROWS => core::array::from_fn(|i| shift(&by_slice[b], j, i)),
                    SLICES => core::array::from_fn(|i| shift(&by_row[b][j], k, i)),
                    RUN => core::array::from_fn(|i| {
                        // SAFETY: lane l's support starts at base[0] + l (base[15] + 15 −
                        // l with `desc`: the caller's promise), so voxel m of these
                        // sixteen is lane m's (lane 15 − m's) voxel i of this row, in its
                        // checked support.
                        let x = unsafe {
                            V::load16(sups[b].data.as_ptr().add(first[b] + j * s0 + k * s01 + i))
                        };
                        if desc {
                            _mm512_permutexvar_ps(backwards, x)
                        } else {
                            x
                        }
                    }),
                    _ => lanes_at(b, j * s0 + k * s01),
                };
            }
            for i in 0..S {
                for b in 0..B {
                    let (w1, w2, d1, d2) = (w1[b], w2[b], d1[b], d2[b]);
                    let xi = x[b][i];
                    let xw0 = _mm512_mul_ps(xi, ld(&ws[b][0][i]));
                    let xw0w1 = _mm512_mul_ps(xw0, w1);
                    if VAL || !G {
                        val[b] = _mm512_add_ps(val[b], _mm512_mul_ps(xw0w1, w2));
                    }
                    if G {
                        let xd0 = _mm512_mul_ps(xi, ld(&dws[b][0][i]));
                        g0[b] = _mm512_add_ps(g0[b], _mm512_mul_ps(_mm512_mul_ps(xd0, w1), w2));
                        g1[b] = _mm512_add_ps(g1[b], _mm512_mul_ps(_mm512_mul_ps(xw0, d1), w2));
                        g2[b] = _mm512_add_ps(g2[b], _mm512_mul_ps(xw0w1, d2));
                    }
                }
            }
        }
    }
    let mut r = [[[0.0f32; LANES]; 4]; B];
    for (b, r) in r.iter_mut().enumerate() {
        for (dst, v) in r.iter_mut().zip([val[b], g0[b], g1[b], g2[b]]) {
            // SAFETY: sixteen writable floats.
            unsafe { _mm512_storeu_ps(dst.as_mut_ptr(), v) };
        }
    }
    r
}
