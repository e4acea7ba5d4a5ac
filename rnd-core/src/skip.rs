//! Empty-space skipping for `over`: grids of blocks that record where the LUT opacity
//! is zero for every value the convolution can reach, so the ray can skip the
//! convolution there. Exact: a skipped sample would have had opacity 0, which adds
//! nothing under `over` (its "inside" status, which decides outsideValue, is kept).
//! Fine blocks (4 support starts per axis) decide single samples; coarse blocks
//! (8 per axis, every fine block inside empty) carry the distance map that long jumps
//! use.

use alloc::vec::Vec;

use crate::kernel::KernelName;
use crate::txf::Lut;
use crate::volume::Volume;
use crate::voxel::Voxel;

/// Coarse block edge length in support starts.
const B: usize = 8;
/// Fine block edge length in support starts (divides [`B`]).
const F: usize = 4;
const _: () = assert!(B.is_multiple_of(F));
/// Fine blocks per coarse block along each axis.
const R: usize = B / F;

/// Which blocks of support-base indices give zero opacity everywhere, and how far each
/// empty block is from the nearest block that is not.
#[derive(Debug, Clone, PartialEq)]
pub struct SkipGrid {
    /// Fine blocks per axis and their flags ([`FINE_EMPTY`], [`COARSE_EMPTY`] for the
    /// coarse block holding it).
    nf: [usize; 3],
    fine: Vec<u8>,
    /// Coarse blocks per axis and which of them are empty (every fine block in it is).
    nb: [usize; 3],
    empty: Vec<bool>,
    /// Chebyshev distance, in blocks, from each block to the nearest non-empty one
    /// (0 for a non-empty block; saturates at 255; blocks beyond the grid do not count).
    dist: Vec<u8>,
}

/// Flag of a fine block: every sample whose support starts in it is transparent.
pub const FINE_EMPTY: u8 = 1;
/// Flag of a fine block: so is every sample of the coarse block that holds it.
pub const COARSE_EMPTY: u8 = 2;

/// Largest Σ|w| of one axis's weights over all fractional positions (sampled finely,
/// plus a margin).
fn abs_weight_sum(k: KernelName) -> f64 {
    let s = k.support() as i32;
    let lo = k.lo();
    let mut best: f64 = 1.0;
    for j in 0..=1000 {
        let a = j as f64 / 1000.0 - if s % 2 == 1 { 0.5 } else { 0.0 };
        let sum: f64 = (0..s).map(|i| k.eval(a - (lo + i) as f64, 0).abs()).sum();
        best = best.max(sum);
    }
    best * 1.001
}

/// What building a [`SkipGrid`] needs, split so that slabs of coarse blocks can be
/// built independently (e.g. on several threads): [`SkipPlan::outputs`] gives the
/// grids, [`SkipPlan::split`] cuts them into parts of whole coarse slabs,
/// [`SkipPlan::build_slabs`] fills one part, and [`SkipPlan::finish`] adds the distance
/// map. [`SkipGrid::new`] does all of it on one thread; the result is the same however
/// the slabs are shared out.
#[derive(Debug, Clone)]
pub struct SkipPlan<'l> {
    kernel: KernelName,
    lut: &'l Lut,
    sizes: [usize; 3],
    nf: [usize; 3],
    nb: [usize; 3],
    /// Prefix counts of non-zero-opacity LUT entries.
    nz: Vec<u32>,
    /// Widening of a voxel range by negative kernel lobes (see [`SkipPlan::new`]).
    wneg: f64,
}

impl<'l> SkipPlan<'l> {
    /// The plan for `vol` reconstructed with `kernel` and opacities from `lut`.
    pub fn new<V: Voxel>(vol: &Volume<'_, V>, kernel: KernelName, lut: &'l Lut) -> Self {
        let sizes = vol.sizes();
        let nf: [usize; 3] = core::array::from_fn(|a| sizes[a].div_ceil(F));
        let nb: [usize; 3] = core::array::from_fn(|a| sizes[a].div_ceil(B));
        // Reachable values: v = Σ w_i v_i with Σ w_i = 1 and Σ |w_i| ≤ C (3-D product),
        // so v ∈ [m − W(M − m), M + W(M − m)] with W = (C − 1)/2.
        let c = abs_weight_sum(kernel);
        let wneg = (c * c * c - 1.0) / 2.0;
        // Prefix counts of non-zero-opacity LUT entries.
        let e = lut.entries();
        let mut nz = Vec::with_capacity(e.len() + 1);
        nz.push(0u32);
        for x in e {
            let last = *nz.last().unwrap_or(&0);
            nz.push(last + u32::from(x[3] != 0.0));
        }
        SkipPlan {
            kernel,
            lut,
            sizes,
            nf,
            nb,
            nz,
            wneg,
        }
    }

    /// Number of coarse slabs (along the slowest axis), the units of work.
    pub fn slabs(&self) -> usize {
        self.nb[2]
    }

    /// The fine and coarse grids to fill, all clear.
    pub fn outputs(&self) -> (Vec<u8>, Vec<bool>) {
        let (nf, nb) = (self.nf, self.nb);
        (
            alloc::vec![0; nf[0] * nf[1] * nf[2]],
            alloc::vec![false; nb[0] * nb[1] * nb[2]],
        )
    }

    /// The parts of `fine` and `empty` (from [`SkipPlan::outputs`]) that hold coarse
    /// slabs `slabs.start` up to `slabs.end`, for [`SkipPlan::build_slabs`]; `slabs`
    /// must be consecutive ranges from 0 covering all [`SkipPlan::slabs`], in order.
    ///
    /// # Panics
    /// When the ranges ask for more slabs than the grids hold.
    pub fn split<'o>(
        &self,
        mut fine: &'o mut [u8],
        mut empty: &'o mut [bool],
        slabs: &[core::ops::Range<usize>],
    ) -> Vec<(&'o mut [u8], &'o mut [bool])> {
        let (nf, nb) = (self.nf, self.nb);
        let mut parts = Vec::with_capacity(slabs.len());
        for r in slabs {
            let nfine = ((r.end * R).min(nf[2]) - (r.start * R).min(nf[2])) * nf[0] * nf[1];
            let (f, rest) = core::mem::take(&mut fine).split_at_mut(nfine);
            fine = rest;
            let (e, rest) = core::mem::take(&mut empty).split_at_mut(r.len() * nb[0] * nb[1]);
            empty = rest;
            parts.push((f, e));
        }
        parts
    }

    /// Fills coarse slabs `slabs` of the grids: `fine` and `empty` are exactly those
    /// slabs' parts (see [`SkipPlan::split`]).
    pub fn build_slabs<V: Voxel>(
        &self,
        vol: &Volume<'_, V>,
        slabs: core::ops::Range<usize>,
        fine: &mut [u8],
        empty: &mut [bool],
    ) {
        let (sizes, nf, nb, nz, wneg, kernel) = (
            self.sizes,
            self.nf,
            self.nb,
            &self.nz,
            self.wneg,
            self.kernel,
        );
        let s = kernel.support();
        let lut = self.lut;
        // The LUT test of one support range: true when every value the convolution can
        // reach from voxels in [m, mx] has zero opacity. NaN bounds (a NaN voxel) or
        // infinite ones are never empty.
        let zero_opacity = |m: f32, mx: f32| -> bool {
            if !(m <= mx) || !m.is_finite() || !mx.is_finite() {
                return false;
            }
            let (m, mx) = (m as f64, mx as f64);
            let margin = 1e-5 * (m.abs() + mx.abs() + 1.0);
            let (lo, hi) = if kernel == KernelName::Zero {
                // Every weight is 0: the value is 0 whatever the voxels are.
                (0.0, 0.0)
            } else {
                (m - wneg * (mx - m) - margin, mx + wneg * (mx - m) + margin)
            };
            let (i0, i1) = (lut.index(lo), lut.index(hi));
            nz[i1 + 1] == nz[i0]
        };
        // Min and max over each fine block's support range (the block's bases plus
        // S − 1 more voxels per axis), separably and one fine slab at a time: along z
        // for every voxel of the slab's planes (element by element over whole planes,
        // which the compiler vectorizes), then along y for every row, then along x. A
        // NaN voxel makes its range (−∞, ∞), so its blocks are never empty. A coarse
        // block's range is the union of its fine blocks' ranges, so the LUT is tested
        // once for a coarse block and only when that fails for each of its fine blocks
        // (a zero-opacity range has zero-opacity parts).
        let range = |b: usize, a: usize| (b * F)..((b + 1) * F + s - 1).min(sizes[a]);
        let data = vol.data();
        let (s0, s1) = (sizes[0], sizes[1]);
        let plane = s0 * s1;
        let mut zlo = alloc::vec![V::TOP; plane];
        let mut zhi = alloc::vec![V::BOTTOM; plane];
        let mut ylo = alloc::vec![V::TOP; s0];
        let mut yhi = alloc::vec![V::BOTTOM; s0];
        // Fine ranges of the R fine slabs of one coarse slab.
        let slab = nf[0] * nf[1];
        let mut fmin = alloc::vec![f32::INFINITY; R * slab];
        let mut fmax = alloc::vec![f32::NEG_INFINITY; R * slab];
        // Offsets of this part in the whole grids.
        let (f0, e0) = (slabs.start * R * nf[0] * nf[1], slabs.start * nb[0] * nb[1]);
        for ck in slabs.clone() {
            let fks = (ck * R)..((ck + 1) * R).min(nf[2]);
            fmin.fill(f32::INFINITY);
            fmax.fill(f32::NEG_INFINITY);
            for fk in fks.clone() {
                zlo.fill(V::TOP);
                zhi.fill(V::BOTTOM);
                for k in range(fk, 2) {
                    V::widen_bounds(&mut zlo, &mut zhi, &data[k * plane..(k + 1) * plane]);
                }
                for fj in 0..nf[1] {
                    ylo.fill(V::TOP);
                    yhi.fill(V::BOTTOM);
                    for j in range(fj, 1) {
                        let rows = j * s0..(j + 1) * s0;
                        V::merge_bounds(&mut ylo, &mut yhi, &zlo[rows.clone()], &zhi[rows]);
                    }
                    let at = (fk - ck * R) * slab + nf[0] * fj;
                    for fi in 0..nf[0] {
                        let r = range(fi, 0);
                        (fmin[at + fi], fmax[at + fi]) = V::bounds_f32(&ylo[r.clone()], &yhi[r]);
                    }
                }
            }
            for cj in 0..nb[1] {
                for ci in 0..nb[0] {
                    // The fine blocks of this coarse block (local and global indices).
                    let mut cells = [(0usize, 0usize); R * R * R];
                    let mut n = 0;
                    for fk in fks.clone() {
                        for fj in (cj * R)..((cj + 1) * R).min(nf[1]) {
                            for fi in (ci * R)..((ci + 1) * R).min(nf[0]) {
                                cells[n] = (
                                    (fk - ck * R) * slab + nf[0] * fj + fi,
                                    fi + nf[0] * (fj + nf[1] * fk) - f0,
                                );
                                n += 1;
                            }
                        }
                    }
                    let cells = &cells[..n];
                    let (m, mx) = cells
                        .iter()
                        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &(l, _)| {
                            (a.min(fmin[l]), b.max(fmax[l]))
                        });
                    let all = zero_opacity(m, mx)
                        || cells.iter().fold(true, |all, &(l, g)| {
                            let e = zero_opacity(fmin[l], fmax[l]);
                            fine[g] = if e { FINE_EMPTY } else { 0 };
                            all & e
                        });
                    // A coarse block is empty when every fine block in it is.
                    empty[ci + nb[0] * (cj + nb[1] * ck) - e0] = all;
                    if all {
                        for &(_, g) in cells {
                            fine[g] = FINE_EMPTY | COARSE_EMPTY;
                        }
                    }
                }
            }
        }
    }

    /// The whole grid, built on this thread.
    pub fn build<V: Voxel>(self, vol: &Volume<'_, V>) -> SkipGrid {
        let (mut fine, mut empty) = self.outputs();
        self.build_slabs(vol, 0..self.slabs(), &mut fine, &mut empty);
        self.finish(fine, empty)
    }

    /// The grid from the filled `fine` and `empty` grids.
    pub fn finish(self, fine: Vec<u8>, empty: Vec<bool>) -> SkipGrid {
        let dist = chessboard_distance(self.nb, &empty);
        SkipGrid {
            nf: self.nf,
            fine,
            nb: self.nb,
            empty,
            dist,
        }
    }
}

impl SkipGrid {
    /// Builds the grid for `vol` reconstructed with `kernel` and opacities from `lut`
    /// (on this thread; see [`SkipPlan`] for building it in parts).
    pub fn new<V: Voxel>(vol: &Volume<'_, V>, kernel: KernelName, lut: &Lut) -> SkipGrid {
        SkipPlan::new(vol, kernel, lut).build(vol)
    }

    /// The flags ([`FINE_EMPTY`], [`COARSE_EMPTY`]) of the fine block of support start
    /// `lo` (all three axes inside the volume).
    #[inline(always)]
    pub fn flags_at(&self, lo: [i64; 3]) -> u8 {
        let b = [lo[0] as usize / F, lo[1] as usize / F, lo[2] as usize / F];
        self.fine[b[0] + self.nf[0] * (b[1] + self.nf[1] * b[2])]
    }

    /// True when the convolution whose support starts at index `lo` (all three axes
    /// inside the volume) has zero LUT opacity, as far as the fine grid tells.
    #[inline(always)]
    pub fn empty_at(&self, lo: [i64; 3]) -> bool {
        self.flags_at(lo) & FINE_EMPTY != 0
    }

    /// True when every convolution whose support starts in the coarse block of `lo`
    /// (all three axes inside the volume) has zero LUT opacity; then
    /// [`SkipGrid::empty_box`] applies.
    #[inline(always)]
    pub fn coarse_empty_at(&self, lo: [i64; 3]) -> bool {
        let b = [lo[0] as usize / B, lo[1] as usize / B, lo[2] as usize / B];
        self.empty[b[0] + self.nb[0] * (b[1] + self.nb[1] * b[2])]
    }

    /// For support start `lo` in an empty coarse block: the box of support starts, `[first,
    /// last]` per axis, whose blocks are all empty (`lo`'s block widened on every side by
    /// its distance to the nearest non-empty block, less one). Parts of the box beyond
    /// the volume hold no support start of an inside sample.
    #[inline(always)]
    pub fn empty_box(&self, lo: [i64; 3]) -> [[i64; 2]; 3] {
        let b = lo.map(|x| x.div_euclid(B as i64));
        let i = b[0] as usize + self.nb[0] * (b[1] as usize + self.nb[1] * b[2] as usize);
        let r = i64::from(self.dist[i]) - 1;
        b.map(|x| [(x - r) * B as i64, (x + r + 1) * B as i64 - 1])
    }

    /// The coarse blocks and their Chebyshev distance map (for tests).
    #[doc(hidden)]
    pub fn distances(&self) -> (&[usize; 3], &[bool], &[u8]) {
        (&self.nb, &self.empty, &self.dist)
    }

    /// Fraction of fine blocks marked empty.
    pub fn empty_fraction(&self) -> f64 {
        let n = self.fine.iter().filter(|&&e| e & FINE_EMPTY != 0).count();
        n as f64 / self.fine.len().max(1) as f64
    }
}

/// Chebyshev (chessboard) distance from every cell of an `nb` grid to the nearest cell
/// with `empty` false, saturating at 255 (also when there is none): a forward and a
/// backward raster pass, each taking 1 + the least distance of the 13 neighbours (of 26)
/// already visited, which is exact for this metric. The grid is padded with a layer of
/// saturated cells so that every cell has all its neighbours.
pub fn chessboard_distance(nb: [usize; 3], empty: &[bool]) -> Vec<u8> {
    let p = nb.map(|n| n + 2);
    let at = |x: usize, y: usize, z: usize| x + p[0] * (y + p[1] * z);
    let mut d = alloc::vec![u8::MAX; p[0] * p[1] * p[2]];
    for z in 0..nb[2] {
        for y in 0..nb[1] {
            for x in 0..nb[0] {
                if !empty[x + nb[0] * (y + nb[1] * z)] {
                    d[at(x + 1, y + 1, z + 1)] = 0;
                }
            }
        }
    }
    // Offsets of the 13 neighbours before a cell in raster order.
    let (sy, sz) = (p[0] as isize, (p[0] * p[1]) as isize);
    let mut before = Vec::with_capacity(13);
    for dz in -1isize..=1 {
        for dy in -1isize..=1 {
            for dx in -1isize..=1 {
                if (dz, dy, dx) < (0, 0, 0) {
                    before.push(dx + sy * dy + sz * dz);
                }
            }
        }
    }
    let mut relax = |i: usize, sign: isize| {
        if d[i] != 0 {
            let m = before
                .iter()
                .map(|&o| d[i.wrapping_add_signed(sign * o)])
                .min()
                .unwrap_or(u8::MAX);
            d[i] = d[i].min(m.saturating_add(1));
        }
    };
    for z in 1..=nb[2] {
        for y in 1..=nb[1] {
            for x in 1..=nb[0] {
                relax(at(x, y, z), 1);
            }
        }
    }
    for z in (1..=nb[2]).rev() {
        for y in (1..=nb[1]).rev() {
            for x in (1..=nb[0]).rev() {
                relax(at(x, y, z), -1);
            }
        }
    }
    let mut out = Vec::with_capacity(empty.len());
    for z in 1..=nb[2] {
        for y in 1..=nb[1] {
            out.extend_from_slice(&d[at(1, y, z)..at(nb[0] + 1, y, z)]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::{chessboard_distance, SkipGrid};
    use alloc::vec::Vec;
    use proptest::prelude::*;
    use proptest::test_runner::TestCaseError;

    /// A NaN voxel keeps every block whose support reaches it from being empty; the
    /// same volume without it, all in a zero-opacity range, is empty throughout; i16
    /// bounds give what their f32 values give.
    #[test]
    fn nan_voxels_are_never_skipped() {
        use crate::affine::Affine4;
        use crate::kernel::KernelName;
        use crate::txf::Lut;
        use crate::volume::Volume;
        let sizes = [20, 18, 17];
        let n = sizes[0] * sizes[1] * sizes[2];
        let itow = Affine4::from_columns([1., 0., 0.], [0., 1., 0.], [0., 0., 1.], [0.; 3]);
        // Opacity only for values above 50.
        let mut e = alloc::vec![[1.0f32, 1.0, 1.0, 0.0]; 100];
        for x in &mut e[50..] {
            x[3] = 0.5;
        }
        let lut = Lut::new(0.0, 100.0, e).unwrap();
        let mut f: Vec<f32> = (0..n).map(|i| (i % 7) as f32).collect();
        let s: Vec<i16> = f.iter().map(|&x| x as i16).collect();
        for k in [KernelName::Tent, KernelName::Bspln3] {
            let g = SkipGrid::new(&Volume::new(&f, sizes, itow).unwrap(), k, &lut);
            assert_eq!(g.empty_fraction(), 1.0);
            let g16 = SkipGrid::new(&Volume::new(&s, sizes, itow).unwrap(), k, &lut);
            assert_eq!((&g16.fine, &g16.empty), (&g.fine, &g.empty));
        }
        let at = 13 + sizes[0] * (9 + sizes[1] * 4);
        f[at] = f32::NAN;
        let g = SkipGrid::new(
            &Volume::new(&f, sizes, itow).unwrap(),
            KernelName::Tent,
            &lut,
        );
        // Support starts (12 or 13, 8 or 9, 3 or 4) reach the NaN voxel: blocks 1, 1, 0.
        assert!(!g.empty_at([12, 8, 3]) && !g.empty_at([13, 9, 4]));
        assert!(g.empty_fraction() < 1.0 && g.empty_at([0, 0, 8]) && g.coarse_empty_at([0, 0, 8]));
        assert!(!g.coarse_empty_at([8, 8, 0]));
    }

    /// Checks `g` built for kernel K on `vol`: each coarse block is empty exactly when
    /// all its fine blocks are, and every convolution at `pts` (fractions of the
    /// volume) whose support starts in an empty fine block has zero LUT opacity.
    fn check_grid<K: crate::kernel::Kernel<S>, const S: usize>(
        g: &SkipGrid,
        vol: crate::volume::Volume<'_, f32>,
        lut: &crate::txf::Lut,
        pts: &[[f64; 3]],
    ) -> Result<(), TestCaseError> {
        use super::{B, F};
        let (nf, nb) = (g.nf, g.nb);
        for bk in 0..nb[2] {
            for bj in 0..nb[1] {
                for bi in 0..nb[0] {
                    let mut all = true;
                    for fk in (bk * B / F..(bk + 1) * B / F).filter(|&x| x < nf[2]) {
                        for fj in (bj * B / F..(bj + 1) * B / F).filter(|&x| x < nf[1]) {
                            for fi in (bi * B / F..(bi + 1) * B / F).filter(|&x| x < nf[0]) {
                                let f = g.fine[fi + nf[0] * (fj + nf[1] * fk)];
                                all &= f & super::FINE_EMPTY != 0;
                                // The coarse flag on every fine block says the same.
                                prop_assert_eq!(
                                    f & super::COARSE_EMPTY != 0,
                                    g.empty[bi + nb[0] * (bj + nb[1] * bk)]
                                );
                            }
                        }
                    }
                    prop_assert_eq!(g.empty[bi + nb[0] * (bj + nb[1] * bk)], all);
                }
            }
        }
        let sizes = vol.sizes();
        let mut c = crate::convo::Convo::<f32, K, S>::new(vol);
        for p in pts {
            let x = core::array::from_fn(|a| p[a] * (sizes[a] as f64 - 1.0));
            let (Some(lo), cs) = (c.support_start(x), c.eval_index(x, false)) else {
                continue;
            };
            if cs.inside && g.empty_at(lo) {
                prop_assert_eq!(
                    lut.entries()[lut.index(cs.value as f64)][3],
                    0.0,
                    "at {:?}",
                    x
                );
            }
            if cs.inside && g.coarse_empty_at(lo) {
                prop_assert!(g.empty_at(lo));
            }
        }
        Ok(())
    }

    proptest! {
        /// Fine and coarse blocks agree, and an empty fine block really is transparent,
        /// for tent and bspln3 on small volumes of a few levels (in patches) with an
        /// opacity step.
        #[test]
        fn fine_blocks_are_transparent(
            sizes in prop::array::uniform3(3usize..20),
            vals in prop::collection::vec(prop::sample::select(&[0.0f32, 0.0, 0.0, 1.0, 2.0, 3.0][..]), 343),
            step in 1usize..16,
            pts in prop::collection::vec(prop::array::uniform3(0.0f64..1.0), 200),
        ) {
            use crate::affine::Affine4;
            use crate::kernel::{Bspln3, KernelName, Tent};
            use crate::txf::Lut;
            use crate::volume::Volume;
            let n = sizes[0] * sizes[1] * sizes[2];
            let itow = Affine4::from_columns([1., 0., 0.], [0., 1., 0.], [0., 0., 1.], [0.; 3]);
            // 16 entries over [0, 4]: transparent below entry `step`.
            let e: Vec<[f32; 4]> = (0..16).map(|i| [1.0, 1.0, 1.0, if i < step { 0.0 } else { 0.5 }]).collect();
            let lut = Lut::new(0.0, 4.0, e).unwrap();
            // Patches of 3 × 3 × 3 equal voxels, so values reach the levels exactly.
            let data: Vec<f32> = (0..n)
                .map(|i| {
                    let (x, y, z) = (i % sizes[0], (i / sizes[0]) % sizes[1], i / (sizes[0] * sizes[1]));
                    vals[x / 3 + 7 * (y / 3 + 7 * (z / 3))]
                })
                .collect();
            let vol = Volume::new(&data, sizes, itow).unwrap();
            check_grid::<Tent, 2>(&SkipGrid::new(&vol, KernelName::Tent, &lut), vol, &lut, &pts)?;
            check_grid::<Bspln3, 4>(&SkipGrid::new(&vol, KernelName::Bspln3, &lut), vol, &lut, &pts)?;
        }

        /// The two-pass transform equals the brute-force Chebyshev distance to the
        /// nearest non-empty cell (255 when there is none or it is farther).
        #[test]
        fn chessboard_distance_is_exact(
            nb in prop::array::uniform3(1usize..7),
            bits in prop::collection::vec(0u8..10, 216),
        ) {
            let n = nb[0] * nb[1] * nb[2];
            // Mostly empty grids, so distances above 1 occur.
            let empty: Vec<bool> = bits[..n].iter().map(|&b| b != 0).collect();
            let d = chessboard_distance(nb, &empty);
            let at = |i: usize| [i % nb[0], (i / nb[0]) % nb[1], i / (nb[0] * nb[1])];
            for i in 0..n {
                let p = at(i);
                let want = (0..n)
                    .filter(|&j| !empty[j])
                    .map(|j| {
                        let q = at(j);
                        (0..3).map(|a| p[a].abs_diff(q[a])).max().unwrap_or(0)
                    })
                    .min()
                    .map_or(255, |m| m.min(255)) as u8;
                prop_assert_eq!(d[i], want, "cell {:?} of {:?}", p, nb);
            }
        }
    }
}
