//! Skipping what cannot change a ray's result, exactly. Grids of blocks record, for
//! each block of support starts, what the convolution can reach from the voxels it
//! reads, so the ray can pass over samples without convolving them:
//!
//! - `over` of a colour probe: blocks where the LUT opacity is zero for every value the
//!   convolution can reach (a skipped sample would add nothing; its "inside" status,
//!   which decides outsideValue, is kept); for a LUT over two quantities, for every
//!   pair it can reach: the reachable values × [0, the block's gradient-magnitude bound]
//!   (the bound `max` renders of `gm` use), any curvature. Fine blocks (4 support
//!   starts per axis) decide samples, and the ray's walk through them whole stretches;
//!   coarse blocks (8 per axis, every fine block inside empty) speed up the build.
//!   Inside a fine block that is not empty, one bit per support start says whether the
//!   voxels that start's convolution reads, alone, make it transparent (tested
//!   against voxel bounds found once per block from the LUT's runs of transparent
//!   values).
//! - `max` of the value or the gradient magnitude: an upper bound on the quantity per
//!   block, with a proven margin for f32 rounding, so a sample whose block's bound is
//!   at most the ray's running maximum is counted without convolving it (the maximum
//!   keeps its bits). Coarse bounds let a ray pass a whole coarse block.

use alloc::vec::Vec;

use crate::classify::Quantity;
use crate::kernel::KernelName;
use crate::simd::Simd;
use crate::txf::Lut;
use crate::volume::Volume;
use crate::voxel::Voxel;

/// Coarse block edge length in support starts.
const B: usize = 8;
/// Fine block edge length in support starts (divides [`B`]).
const F: usize = 4;
/// [`F`], for walks through the fine blocks.
pub(crate) const FINE: usize = F;
const _: () = assert!(B.is_multiple_of(F));
/// Least kernel support whose fine blocks get a bit per support start
/// ([`SkipGrid::empty_at`]). Measured (callgrind, CT lit `over`, 256², tests profile):
/// tent 301 M → 283 M instructions (build +28 M, render −47 M); bspln3 617 M → 542 M
/// against bits tested entry by entry.
const STARTS_MIN: usize = 2;
/// Fine blocks per coarse block along each axis.
const R: usize = B / F;

/// What a [`SkipGrid`] records.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SkipKind {
    /// Where the LUT opacity is zero (`over` of a colour probe).
    Opacity,
    /// Upper bounds of the value (`max` of `v`).
    MaxValue,
    /// Upper bounds of the world gradient magnitude (`max` of `gm`).
    MaxGradMag,
}

/// Which blocks of support-base indices give zero opacity everywhere, and how far each
/// empty block is from the nearest block that is not; or, for `max` renders, an upper
/// bound of the maximized quantity per block.
#[derive(Debug, Clone, PartialEq)]
pub struct SkipGrid {
    kind: SkipKind,
    kernel: KernelName,
    sizes: [usize; 3],
    /// Fine blocks per axis and their flags ([`FINE_EMPTY`], [`COARSE_EMPTY`] for the
    /// coarse block holding it; [`SkipKind::Opacity`] only).
    nf: [usize; 3],
    fine: Vec<u8>,
    /// Per fine block, one bit per support start in it (bit `x + F·(y + F·z)` of its
    /// offsets in the block): set when that start's convolution is transparent, by the
    /// voxels it reads alone; every bit of an empty block ([`SkipKind::Opacity`] only).
    starts: Vec<u64>,
    /// Coarse blocks per axis and which of them are empty (every fine block in it is).
    nb: [usize; 3],
    empty: Vec<bool>,
    /// Upper bounds per fine and per coarse block (the `max` kinds only).
    hi: Vec<f32>,
    coarse_hi: Vec<f32>,
    /// Per pixel of the last render it was aimed for, the samples that can reach a
    /// block that is not empty ([`crate::render::RenderSpec::aim`]).
    aim: Option<crate::march::Aim>,
    /// What decides the grid besides the voxels, kind, kernel and sizes: the LUT (an
    /// opacity grid's) and the bound's coefficients (a `max` grid's, or an opacity
    /// grid's gradient-magnitude axis): see [`SkipPlan::builds`].
    made: Made,
}

/// What a grid was built from, besides its kind, kernel, sizes and voxels.
#[derive(Debug, Clone, PartialEq)]
struct Made {
    lut: Option<Lut>,
    /// [`Linear`]'s coefficients, as bits (the same bits, the same bounds).
    bound: Option<[u64; 3]>,
}

/// Flag of a fine block: every sample whose support starts in it is transparent.
pub const FINE_EMPTY: u8 = 1;
/// Flag of a fine block: so is every sample of the coarse block that holds it.
pub const COARSE_EMPTY: u8 = 2;

/// Relative margin for f32 rounding in a bound: the convolution's sums (at most 6³
/// products, summed separably), the kernels' f32 weights, the gradient's world
/// transform and square root each err by far less than 1e-5 of the sum of the terms'
/// magnitudes, which the bounds' `A`-terms bound.
const ROUNDING: f64 = 1e-4;

/// Relative margin for f32 rounding in the values a convolution reaches from a voxel
/// range `[m, M]` (LUT tests): `VALUE_MARGIN·(|m| + |M| + 1)`.
const VALUE_MARGIN: f64 = 1e-5;

/// Largest Σ|w| of one axis's weights (derivative `d`: 0 or 1) over all fractional
/// positions: sampled at 4097 positions plus a 1% margin, which exceeds what lies
/// between samples (Σ|w| changes by at most Σ|w'| · 1/8192 there, below 0.002 for
/// every kernel; checked at 60× finer steps by a test).
pub(crate) fn abs_weight_sum(k: KernelName, d: u32) -> f64 {
    let (best, _) = weight_sums(k, d, 4096);
    best * 1.01 + 1e-3
}

/// Largest Σ|w| and largest |Σw − 1| over `n + 1` fractional positions.
fn weight_sums(k: KernelName, d: u32, n: u32) -> (f64, f64) {
    let s = k.support() as i32;
    let lo = k.lo();
    let (mut best, mut off): (f64, f64) = (0.0, 0.0);
    for j in 0..=n {
        let a = f64::from(j) / f64::from(n) - if s % 2 == 1 { 0.5 } else { 0.0 };
        let w = (0..s).map(|i| k.eval(a - f64::from(lo + i), d));
        let (abs, sum) = w.fold((0.0, 0.0), |(a, s), x| (a + x.abs(), s + x));
        best = best.max(abs);
        off = off.max((sum - 1.0).abs());
    }
    (best, off)
}

/// A block's bound `a·M + b·(M − m) + c·max(|m|, |M|)` for voxels in `[m, M]`, rounded
/// up to f32; +∞ when the range is not finite (a NaN or infinite voxel).
#[derive(Debug, Clone, Copy)]
struct Linear([f64; 3]);

impl Linear {
    /// The bound of `kind` for `kernel` on a volume whose world-to-index 3×3 is `w`.
    fn new(kind: SkipKind, kernel: KernelName, w: &crate::affine::Affine4) -> Self {
        let c = abs_weight_sum(kernel, 0);
        // Kernels whose weights sum to 1 (all but zero): the value is an affine mix.
        let unity = weight_sums(kernel, 0, 64).1 < 1e-9;
        let c3 = c * c * c;
        match kind {
            // v − M = Σ w_i (v_i − M) ≤ Σ_{w_i<0} |w_i| (M − m) = (C³ − 1)/2 · (M − m).
            SkipKind::MaxValue if unity => Linear([1.0, (c3 - 1.0) / 2.0, ROUNDING * c3]),
            SkipKind::MaxValue | SkipKind::Opacity => Linear([0.0, 0.0, c3 * (1.0 + ROUNDING)]),
            SkipKind::MaxGradMag => {
                // Index gradient: ∂x = Σ w'_x w_y w_z v, and Σ w' = 0 for such kernels,
                // so |∂x| ≤ D C² (M − m)/2 (v_i less the range's middle); else D C² A.
                // World: g_w = Σ_c ∂c · (row c of WtoI), so |g_w| ≤ Σ_c |row c| · max|∂c|.
                let rows: f64 = (0..3)
                    .map(|r| libm::sqrt((0..3).map(|c| w.at(r, c) * w.at(r, c)).sum()))
                    .sum();
                let g = rows * abs_weight_sum(kernel, 1) * c * c * (1.0 + ROUNDING);
                if unity {
                    Linear([0.0, g / 2.0, ROUNDING * g])
                } else {
                    Linear([0.0, 0.0, g * (1.0 + ROUNDING)])
                }
            }
        }
    }

    /// The coefficients' bits.
    fn bits(&self) -> [u64; 3] {
        self.0.map(f64::to_bits)
    }

    fn bound(&self, m: f32, mx: f32) -> f32 {
        if !(m <= mx) || !m.is_finite() || !mx.is_finite() {
            return f32::INFINITY;
        }
        let (m, mx) = (f64::from(m), f64::from(mx));
        let [a, b, c] = self.0;
        let x = a * mx + b * (mx - m) + c * m.abs().max(mx.abs());
        let f = x as f32;
        if f64::from(f) < x {
            f.next_up()
        } else {
            f
        }
    }
}

/// What building a [`SkipGrid`] needs, split so that runs of coarse slabs can be built
/// independently (e.g. on several threads, in any order): [`SkipPlan::build_run`]
/// fills the grids of one run, and [`SkipPlan::finish`] puts the runs together.
/// [`SkipPlan::build`] does all of it at once; the result is the same however the slabs
/// are shared out. An opacity plan aimed at a render's camera
/// ([`crate::render::RenderSpec::aim_plan`]) builds its grid aimed, each run placing
/// its own blocks (the aim [`crate::render::RenderSpec::aim`] gives).
#[derive(Debug, Clone)]
pub struct SkipPlan<'l> {
    kind: SkipKind,
    kernel: KernelName,
    sizes: [usize; 3],
    nf: [usize; 3],
    nb: [usize; 3],
    test: Test<'l>,
    simd: Simd,
    /// The model the grid is aimed with as it is built (opacity plans only).
    aim: Option<crate::march::Aim>,
}

/// How a block's voxel range is judged.
#[derive(Debug, Clone)]
enum Test<'l> {
    /// Zero opacity: the LUT, counts of its non-zero-opacity entries (a summed-area
    /// table: entry i + (N + 1)·j counts those before i along the first axis and before
    /// j along the second), the widening of a voxel range by negative kernel lobes, and
    /// the gradient magnitude's bound when an axis classifies by it.
    Opacity {
        lut: &'l Lut,
        nz: Vec<usize>,
        wneg: f64,
        gm: Option<Linear>,
        runs: Vec<(f64, f64)>,
    },
    /// An upper bound.
    Bound(Linear),
}

/// Summed-area counts of `lut`'s entries with non-zero opacity (see [`Test::Opacity`]).
fn nonzero_counts(lut: &Lut) -> Vec<usize> {
    let e = lut.entries();
    let n0 = lut.axes()[0].len;
    let n1 = e.len() / n0;
    let mut nz = alloc::vec![0usize; (n0 + 1) * (n1 + 1)];
    for j in 0..n1 {
        for i in 0..n0 {
            let here = usize::from(e[i + n0 * j][3] != 0.0);
            nz[(i + 1) + (n0 + 1) * (j + 1)] =
                here + nz[i + (n0 + 1) * (j + 1)] + nz[(i + 1) + (n0 + 1) * j]
                    - nz[i + (n0 + 1) * j];
        }
    }
    nz
}

/// The maximal runs of first-axis entries of `lut` that are transparent in every row of
/// the second axis (`nz` as in [`Test::Opacity`]), each as the values `[a, b)` whose
/// [`crate::classify::LutAxis::index`] falls in it (−∞ and +∞ at the axis's ends);
/// none unless the first axis is the value.
fn value_runs(lut: &Lut, nz: &[usize]) -> Vec<(f64, f64)> {
    let a = &lut.axes()[0];
    if a.quantity != Quantity::Value {
        return Vec::new();
    }
    // Entries before i of every row of the second axis.
    let all = &nz[nz.len() - (a.len + 1)..];
    let clear = |i: usize| all[i + 1] == all[i];
    let mut runs = Vec::new();
    let mut i = 0;
    while i < a.len {
        if !clear(i) {
            i += 1;
            continue;
        }
        let first = i;
        while i < a.len && clear(i) {
            i += 1;
        }
        let lo = if first == 0 {
            f64::NEG_INFINITY
        } else {
            first_at(a, first)
        };
        let hi = if i == a.len {
            f64::INFINITY
        } else {
            first_at(a, i)
        };
        runs.push((lo, hi));
    }
    runs
}

/// The least value whose entry along `a` is `i` or later (`1 ≤ i < a.len`): bisection
/// over the ordered f64s of [min, max], as `index` is monotone there.
fn first_at(a: &crate::classify::LutAxis, i: usize) -> f64 {
    // f64s in order as integers (−0 and +0 alike).
    let key = |x: f64| {
        let b = x.to_bits() as i64;
        i128::from(if b < 0 { i64::MIN - b } else { b })
    };
    let value = |k: i128| {
        let k = k as i64;
        f64::from_bits(if k < 0 {
            (i64::MIN - k) as u64
        } else {
            k as u64
        })
    };
    // index(min) = 0 < i ≤ len − 1 = index(max).
    let (mut lo, mut hi) = (key(a.min), key(a.max));
    while hi - lo > 1 {
        let mid = lo + (hi - lo) / 2;
        if a.index(value(mid)) >= i {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    value(hi)
}

/// Tests of one fine block's support starts, from the `runs` of transparent values
/// ([`value_runs`]), for a kernel whose negative lobes widen a voxel range by `wneg`
/// times its width ([`Test::Opacity`]) and a block whose starts read voxels in `[m, mx]`:
/// up to two pairs `(l0, h0)` such that a start whose voxels lie in `[l, h]` with
/// `l ≥ l0` and `h ≤ h0` reaches only values of one run. A start's reachable values
/// are `[l − wneg·(h − l) − e, h + wneg·(h − l) + e]` with the rounding margin
/// `e = VALUE_MARGIN·(|l| + |h| + 1)` of [`SkipPlan::fill_slabs`]; inside the block both widths
/// are at most `d = wneg·(mx − m) + VALUE_MARGIN·(2·max(|m|, |mx|) + 1)`, so `l − d ≥ a` and
/// `h + d < b` put them in the run `[a, b)` (the f64 rounding of these sums is far
/// below the margin). Runs no start of the block can meet are left out; unused pairs
/// are (+∞, −∞), which nothing meets. None for a block whose range is not finite (a
/// NaN voxel).
fn start_tests(runs: &[(f64, f64)], wneg: f64, m: f32, mx: f32) -> Option<[(f32, f32); 2]> {
    if !(m.is_finite() && mx.is_finite() && m <= mx) {
        return None;
    }
    let (m, mx) = (f64::from(m), f64::from(mx));
    let d = wneg * (mx - m) + VALUE_MARGIN * (2.0 * m.abs().max(mx.abs()) + 1.0);
    let mut tests = [(f32::INFINITY, f32::NEG_INFINITY); 2];
    let mut n = 0;
    for &(a, b) in runs {
        // The least f32 l with l − d ≥ a, the greatest h with h + d < b.
        let mut l0 = (a + d) as f32;
        if f64::from(l0) - d < a {
            l0 = l0.next_up();
        }
        let mut h0 = (b - d) as f32;
        if f64::from(h0) + d >= b {
            h0 = h0.next_down();
        }
        if l0 <= h0 && f64::from(l0) <= mx && f64::from(h0) >= m && n < tests.len() {
            tests[n] = (l0, h0);
            n += 1;
        }
    }
    (n > 0).then_some(tests)
}

/// The grids a [`SkipPlan`] fills: fine flags and coarse emptiness ([`SkipKind::Opacity`])
/// or fine and coarse bounds (the `max` kinds); the other pair is empty.
#[derive(Debug, Clone, Default)]
struct SkipCells {
    fine: Vec<u8>,
    starts: Vec<u64>,
    empty: Vec<bool>,
    hi: Vec<f32>,
    coarse_hi: Vec<f32>,
}

impl SkipCells {
    /// The lengths of the five grids.
    fn lens(&self) -> [usize; 5] {
        [
            self.fine.len(),
            self.starts.len(),
            self.empty.len(),
            self.hi.len(),
            self.coarse_hi.len(),
        ]
    }
}

/// The grids of one run of coarse slabs ([`SkipPlan::build_run`]), for
/// [`SkipPlan::put`] or [`SkipPlan::finish`].
#[derive(Debug, Clone)]
pub struct SkipRun {
    slabs: core::ops::Range<usize>,
    cells: SkipCells,
    /// Under an aimed plan, the run's fine blocks that reach a pixel with the first
    /// image row each reaches, and the run's span ([`crate::march::Aim::firsts`]); None
    /// when that failed.
    firsts: Option<(Vec<(u32, u32)>, u32)>,
}

/// A run's first slab and its blocks that reach a pixel, with the first row each
/// reaches ([`crate::march::Aim::firsts`]).
type Placed = (usize, Vec<(u32, u32)>);

/// A plan's whole grids, filled run by run in any order ([`SkipPlan::assembly`],
/// [`SkipPlan::put`]): each run is copied into place when it is put (by the thread that
/// built it, say, while others still build theirs), and the grid is had at the end
/// without a copy ([`SkipPlan::assemble`]).
#[derive(Debug, Clone, Default)]
pub struct SkipAssembly {
    cells: SkipCells,
    /// Which coarse slabs were put.
    put: Vec<bool>,
    /// Under an aimed plan, the runs' [`SkipRun::firsts`] (by their first slab) and the
    /// largest span, while every run put had them.
    firsts: Option<(Vec<Placed>, u32)>,
}

impl<'l> SkipPlan<'l> {
    /// The plan for `vol` reconstructed with `kernel` and opacities from `lut`
    /// ([`SkipKind::Opacity`]). A block is empty when every entry its samples can reach
    /// has opacity 0: along a value axis, the entries of the values the convolution can
    /// reach; along a gradient-magnitude axis, those of [0, the block's bound of it]
    /// (as `max` renders of `gm` bound it); along a curvature axis, every entry.
    pub fn new<V: Voxel>(vol: &Volume<'_, V>, kernel: KernelName, lut: &'l Lut) -> Self {
        // Reachable values: v = Σ w_i v_i with Σ w_i = 1 and Σ |w_i| ≤ C (3-D product),
        // so v ∈ [m − W(M − m), M + W(M − m)] with W = (C − 1)/2.
        let c = abs_weight_sum(kernel, 0);
        let wneg = (c * c * c - 1.0) / 2.0;
        let nz = nonzero_counts(lut);
        let gm = lut
            .axes()
            .iter()
            .any(|a| a.quantity == Quantity::GradMag)
            .then(|| Linear::new(SkipKind::MaxGradMag, kernel, vol.wtoi()));
        let runs = value_runs(lut, &nz);
        Self::with(
            vol,
            kernel,
            SkipKind::Opacity,
            Test::Opacity {
                lut,
                nz,
                wneg,
                gm,
                runs,
            },
        )
    }

    /// The plan for a `max` render of the value ([`SkipKind::MaxValue`]) or the
    /// gradient magnitude ([`SkipKind::MaxGradMag`]) of `vol` with `kernel`; `None`
    /// for [`SkipKind::Opacity`] (see [`SkipPlan::new`]).
    pub fn for_max<V: Voxel>(
        vol: &Volume<'_, V>,
        kernel: KernelName,
        kind: SkipKind,
    ) -> Option<Self> {
        if kind == SkipKind::Opacity {
            return None;
        }
        let lin = Linear::new(kind, kernel, vol.wtoi());
        Some(Self::with(vol, kernel, kind, Test::Bound(lin)))
    }

    fn with<V: Voxel>(
        vol: &Volume<'_, V>,
        kernel: KernelName,
        kind: SkipKind,
        test: Test<'l>,
    ) -> Self {
        let sizes = vol.sizes();
        SkipPlan {
            kind,
            kernel,
            sizes,
            nf: sizes.map(|n| n.div_ceil(F)),
            nb: sizes.map(|n| n.div_ceil(B)),
            test,
            simd: Simd::detect(),
            aim: None,
        }
    }

    /// The plan building at vector level `simd` (at most; the best the processor has
    /// unless set). The grid is the same at every level: its minima and maxima are exact.
    pub fn with_simd(mut self, simd: Simd) -> Self {
        self.simd = simd;
        self
    }

    /// The plan building its grid aimed by `aim` (made for this plan's fine blocks; an
    /// opacity plan only, otherwise as before).
    pub(crate) fn aimed(mut self, aim: Option<crate::march::Aim>) -> Self {
        self.aim = aim.filter(|a| self.kind == SkipKind::Opacity && a.fine_blocks() == self.nf);
        self
    }

    /// Fine blocks per axis of the grid.
    pub(crate) fn fine_blocks(&self) -> [usize; 3] {
        self.nf
    }

    /// The bounds of every `step`-th fine block along each axis (from the first, fastest
    /// axis first), as the grid this plan builds records them: a cheap sample (each
    /// block's voxels read directly) of a `max` grid. Empty for an opacity plan.
    pub fn sample_bounds<V: Voxel>(&self, vol: &Volume<'_, V>, step: usize) -> Vec<f32> {
        let Test::Bound(lin) = &self.test else {
            return Vec::new();
        };
        let (sizes, s, step) = (self.sizes, self.kernel.support(), step.max(1));
        let range = |b: usize, a: usize| (b * F)..((b + 1) * F + s - 1).min(sizes[a]);
        let data = vol.data();
        let mut out = Vec::new();
        for fk in (0..self.nf[2]).step_by(step) {
            for fj in (0..self.nf[1]).step_by(step) {
                for fi in (0..self.nf[0]).step_by(step) {
                    let (mut m, mut mx, mut nan) = (f32::INFINITY, f32::NEG_INFINITY, false);
                    for k in range(fk, 2) {
                        for j in range(fj, 1) {
                            let row = (k * sizes[1] + j) * vol.row_stride();
                            let r = range(fi, 0);
                            for v in data.get(row + r.start..row + r.end).unwrap_or(&[]) {
                                let x = v.to_f32();
                                nan |= x.is_nan();
                                m = if x < m { x } else { m };
                                mx = if x > mx { x } else { mx };
                            }
                        }
                    }
                    // A NaN voxel: the range, and so the bound, is unbounded.
                    if nan {
                        (m, mx) = (f32::NEG_INFINITY, f32::INFINITY);
                    }
                    out.push(lin.bound(m, mx));
                }
            }
        }
        out
    }

    /// Number of coarse slabs (along the slowest axis), the units of work.
    pub fn slabs(&self) -> usize {
        self.nb[2]
    }

    /// What the grid records.
    pub fn kind(&self) -> SkipKind {
        self.kind
    }

    /// The grids of coarse slabs `slabs` (at most [`SkipPlan::slabs`]), all clear.
    fn outputs(&self, slabs: &core::ops::Range<usize>) -> SkipCells {
        let (fine, coarse) = self.cell_counts(slabs);
        match self.test {
            Test::Opacity { .. } => SkipCells {
                fine: alloc::vec![0; fine],
                starts: alloc::vec![0; fine],
                empty: alloc::vec![false; coarse],
                ..SkipCells::default()
            },
            Test::Bound(_) => SkipCells {
                hi: alloc::vec![0.0; fine],
                coarse_hi: alloc::vec![0.0; coarse],
                ..SkipCells::default()
            },
        }
    }

    /// How many fine and coarse blocks coarse slabs `slabs` hold.
    fn cell_counts(&self, slabs: &core::ops::Range<usize>) -> (usize, usize) {
        let (nf, nb) = (self.nf, self.nb);
        let fine = ((slabs.end * R).min(nf[2]) - (slabs.start * R).min(nf[2])) * nf[0] * nf[1];
        (fine, slabs.len() * nb[0] * nb[1])
    }

    /// The lengths of the grids (as [`SkipCells::lens`]) of coarse slabs `slabs`.
    fn lens(&self, slabs: &core::ops::Range<usize>) -> [usize; 5] {
        let (f, c) = self.cell_counts(slabs);
        match self.test {
            Test::Opacity { .. } => [f, f, c, 0, 0],
            Test::Bound(_) => [0, 0, 0, f, c],
        }
    }

    /// Whether `run`'s grids have the sizes this plan gives its slabs.
    fn fits(&self, run: &SkipRun) -> bool {
        run.slabs.end <= self.slabs() && run.cells.lens() == self.lens(&run.slabs)
    }

    /// The grids of coarse slabs `slabs` (those of them below [`SkipPlan::slabs`]).
    pub fn build_run<V: Voxel>(
        &self,
        vol: &Volume<'_, V>,
        slabs: core::ops::Range<usize>,
    ) -> SkipRun {
        let slabs = slabs.start.min(self.slabs())..slabs.end.min(self.slabs());
        let mut cells = self.outputs(&slabs);
        // The plane minima and maxima vectorize best with AVX2 (and are exact anyway).
        crate::simd::wide(self.simd, {
            #[inline(always)]
            || self.fill_slabs(vol, slabs.clone(), &mut cells)
        });
        let firsts = self.aim.as_ref().and_then(|a| {
            let (at, _) = self.cell_counts(&(0..slabs.start));
            a.firsts(&cells.fine, at)
        });
        SkipRun {
            slabs,
            cells,
            firsts,
        }
    }

    #[inline(always)]
    fn fill_slabs<V: Voxel>(
        &self,
        vol: &Volume<'_, V>,
        slabs: core::ops::Range<usize>,
        part: &mut SkipCells,
    ) {
        let (sizes, nf, nb, kernel) = (self.sizes, self.nf, self.nb, self.kernel);
        let s = kernel.support();
        // The values a convolution can reach from voxels in [m, mx], with a margin for
        // its rounding; none where the bounds are NaN (a NaN voxel) or infinite.
        let values = |m: f32, mx: f32| -> Option<(f64, f64)> {
            let Test::Opacity { wneg, .. } = &self.test else {
                return None;
            };
            if !(m <= mx) || !m.is_finite() || !mx.is_finite() {
                return None;
            }
            let (m, mx) = (m as f64, mx as f64);
            let margin = VALUE_MARGIN * (m.abs() + mx.abs() + 1.0);
            Some(if kernel == KernelName::Zero {
                // Every weight is 0: the value is 0 whatever the voxels are.
                (0.0, 0.0)
            } else {
                (m - wneg * (mx - m) - margin, mx + wneg * (mx - m) + margin)
            })
        };
        // The LUT test of one support range: true when every value the convolution can
        // reach from voxels in [m, mx] has zero opacity.
        let zero_opacity = |m: f32, mx: f32| -> bool {
            let (Test::Opacity { lut, nz, gm, .. }, Some((lo, hi))) = (&self.test, values(m, mx))
            else {
                return false;
            };
            let gm_hi = gm.map_or(0.0, |g| f64::from(g.bound(m, mx)));
            // The entries each axis can reach, [first, last].
            let reach = |a: &crate::classify::LutAxis| match a.quantity {
                Quantity::Value => (a.index(lo), a.index(hi)),
                Quantity::GradMag => (a.index(0.0), a.index(gm_hi)),
                _ => (0, a.len - 1),
            };
            let axes = lut.axes();
            let (i0, i1) = reach(&axes[0]);
            let (j0, j1) = axes.get(1).map_or((0, 0), reach);
            let w = axes[0].len + 1;
            let at = |i: usize, j: usize| nz[i + w * j];
            at(i1 + 1, j1 + 1) + at(i0, j0) == at(i0, j1 + 1) + at(i1 + 1, j0)
        };
        // The support starts' test, where the first axis is the value: by the value
        // alone (whatever the second axis's entry), so cheaper and no less sound, and
        // by voxel bounds per block ([`start_tests`]).
        let (runs, wneg) = match &self.test {
            Test::Opacity { runs, wneg, .. } if s >= STARTS_MIN => (&runs[..], *wneg),
            _ => (&[][..], 0.0),
        };
        // Min and max over each fine block's support range (the block's bases plus
        // S − 1 more voxels per axis), separably and one fine slab at a time: along z
        // for every voxel of the slab's planes (element by element over whole planes,
        // which the compiler vectorizes), then along y for every row, then along x. A
        // NaN voxel makes its range (−∞, ∞), so its blocks are never empty and their
        // bounds infinite. A coarse block's range is the union of its fine blocks'
        // ranges, so the LUT is tested once for a coarse block and only when that fails
        // for each of its fine blocks (a zero-opacity range has zero-opacity parts).
        let range = |b: usize, a: usize| (b * F)..((b + 1) * F + s - 1).min(sizes[a]);
        let data = vol.data();
        // (Planes as stored: rows `row` samples apart, their padding included.)
        let (s0, s1, row) = (sizes[0], sizes[1], vol.row_stride());
        let plane = row * s1;
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
                        let rows = j * row..j * row + s0;
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
                    // The fine blocks of this coarse block (local and global indices, and
                    // block numbers).
                    let mut cells = [(0usize, 0usize, [0usize; 3]); R * R * R];
                    let mut n = 0;
                    for fk in fks.clone() {
                        for fj in (cj * R)..((cj + 1) * R).min(nf[1]) {
                            for fi in (ci * R)..((ci + 1) * R).min(nf[0]) {
                                cells[n] = (
                                    (fk - ck * R) * slab + nf[0] * fj + fi,
                                    fi + nf[0] * (fj + nf[1] * fk) - f0,
                                    [fi, fj, fk],
                                );
                                n += 1;
                            }
                        }
                    }
                    let cells = &cells[..n];
                    let c = ci + nb[0] * (cj + nb[1] * ck) - e0;
                    if let Test::Bound(lin) = &self.test {
                        // A coarse block's bound is its fine blocks' largest.
                        part.coarse_hi[c] =
                            cells.iter().fold(f32::NEG_INFINITY, |b, &(l, g, _)| {
                                part.hi[g] = lin.bound(fmin[l], fmax[l]);
                                b.max(part.hi[g])
                            });
                        continue;
                    }
                    let (m, mx) = cells
                        .iter()
                        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &(l, _, _)| {
                            (a.min(fmin[l]), b.max(fmax[l]))
                        });
                    let all = zero_opacity(m, mx)
                        || cells.iter().fold(true, |all, &(l, g, fb)| {
                            let e = zero_opacity(fmin[l], fmax[l]);
                            part.fine[g] = if e { FINE_EMPTY } else { 0 };
                            // A block that is not empty may still hold transparent starts.
                            part.starts[g] = if e {
                                !0
                            } else {
                                start_tests(runs, wneg, fmin[l], fmax[l]).map_or(0, |t| {
                                    start_bits(self.simd, data, sizes, row, s, fb, &t)
                                })
                            };
                            all & e
                        });
                    // A coarse block is empty when every fine block in it is.
                    part.empty[c] = all;
                    if all {
                        for &(_, g, _) in cells {
                            part.fine[g] = FINE_EMPTY | COARSE_EMPTY;
                            part.starts[g] = !0;
                        }
                    }
                }
            }
        }
    }

    /// The whole grid, built on this thread.
    pub fn build<V: Voxel>(self, vol: &Volume<'_, V>) -> SkipGrid {
        let whole = self.build_run(vol, 0..self.slabs());
        let firsts = whole.firsts.map(|(f, span)| (alloc::vec![(0, f)], span));
        self.grid(whole.cells, firsts)
    }

    /// The grid from runs of this plan (built from the same volume) in any order; None
    /// unless they hold every coarse slab once, with this plan's grid sizes. (As
    /// [`SkipPlan::put`] of each into an [`SkipPlan::assembly`], then
    /// [`SkipPlan::assemble`].)
    pub fn finish(&self, runs: Vec<SkipRun>) -> Option<SkipGrid> {
        let mut whole = self.assembly();
        for r in runs {
            if !self.put(&mut whole, r) {
                return None;
            }
        }
        self.assemble(whole)
    }

    /// The whole grids of this plan, none of their slabs put yet. Their memory is
    /// handed over cleared (untouched until runs are put in it).
    pub fn assembly(&self) -> SkipAssembly {
        SkipAssembly {
            cells: self.outputs(&(0..self.slabs())),
            put: alloc::vec![false; self.slabs()],
            firsts: self.aim.as_ref().map(|_| (Vec::new(), 0)),
        }
    }

    /// Copies `run`'s grids into their place in `whole`; false, copying nothing, when
    /// `run` has grid sizes other than this plan gives its slabs, `whole` is not this
    /// plan's, or one of the run's slabs was put before. A run of no slabs puts nothing.
    pub fn put(&self, whole: &mut SkipAssembly, run: SkipRun) -> bool {
        let s = run.slabs.clone();
        if !self.fits(&run)
            || whole.cells.lens() != self.lens(&(0..self.slabs()))
            || whole.put.get(s.clone()).is_none_or(|p| p.contains(&true))
        {
            return false;
        }
        // Where the run's cells start in the whole grids (as `cell_counts` counts them).
        let (f0, _) = self.cell_counts(&(0..s.start));
        let c0 = s.start * self.nb[0] * self.nb[1];
        fn copy<T: Copy>(to: &mut [T], at: usize, from: &[T]) {
            if let Some(to) = to.get_mut(at..at + from.len()) {
                to.copy_from_slice(from);
            }
        }
        let (w, r) = (&mut whole.cells, &run.cells);
        copy(&mut w.fine, f0, &r.fine);
        copy(&mut w.starts, f0, &r.starts);
        copy(&mut w.hi, f0, &r.hi);
        copy(&mut w.empty, c0, &r.empty);
        copy(&mut w.coarse_hi, c0, &r.coarse_hi);
        // (A run without its blocks' rows leaves the grid unaimed.)
        whole.firsts = match (whole.firsts.take(), run.firsts) {
            (Some((mut parts, span)), Some((part, sp))) => parts.try_reserve(1).ok().map(|()| {
                parts.push((s.start, part));
                (parts, span.max(sp))
            }),
            _ => None,
        };
        whole.put[s].fill(true);
        true
    }

    /// The grid of `whole` when every coarse slab was put in it once; None otherwise.
    pub fn assemble(&self, whole: SkipAssembly) -> Option<SkipGrid> {
        (whole.put.len() == self.slabs()
            && !whole.put.contains(&false)
            && whole.cells.lens() == self.lens(&(0..self.slabs())))
        .then(|| {
            let firsts = whole.firsts.map(|(mut parts, span)| {
                parts.sort_unstable_by_key(|p| p.0);
                (parts, span)
            });
            self.grid(whole.cells, firsts)
        })
    }

    /// The grid of `cells`, all slabs' grids, aimed by this plan's aim with `firsts`,
    /// every block's first row ([`crate::march::Aim::sorted`]).
    fn grid(&self, cells: SkipCells, firsts: Option<(Vec<Placed>, u32)>) -> SkipGrid {
        let aim = match (&self.aim, firsts) {
            (Some(a), Some((parts, span))) => {
                let parts: Vec<&[(u32, u32)]> = parts.iter().map(|p| &p.1[..]).collect();
                a.clone().sorted(&parts, span)
            }
            _ => None,
        };
        SkipGrid {
            kind: self.kind,
            kernel: self.kernel,
            sizes: self.sizes,
            nf: self.nf,
            fine: cells.fine,
            starts: cells.starts,
            nb: self.nb,
            empty: cells.empty,
            hi: cells.hi,
            coarse_hi: cells.coarse_hi,
            aim,
            made: self.made(),
        }
    }

    /// What the grid is built from besides the voxels, kind, kernel and sizes.
    fn made(&self) -> Made {
        match &self.test {
            Test::Opacity { lut, gm, .. } => Made {
                lut: Some((*lut).clone()),
                bound: gm.as_ref().map(Linear::bits),
            },
            Test::Bound(lin) => Made {
                lut: None,
                bound: Some(lin.bits()),
            },
        }
    }

    /// Whether `grid` is the grid this plan builds, given the same voxels (which the
    /// caller vouches for: a grid does not keep them): the same kind, kernel, volume
    /// sizes, LUT and bounds (the world-to-index map's part in them). A renderer that
    /// keeps a volume's grid between frames (see `rnd_std::volume_io::VolumeBuf`)
    /// builds it again only when this fails; the grid's windows are aimed anew each
    /// render.
    pub fn builds(&self, grid: &SkipGrid) -> bool {
        (grid.kind, grid.kernel, grid.sizes) == (self.kind, self.kernel, self.sizes)
            && grid.made == self.made()
    }
}

/// A grid's aim made anew for another render's camera in parts, e.g. by several threads
/// ([`crate::render::RenderSpec::re_aim`]): [`ReAim::part`] of runs of its fine blocks,
/// in any order and on any thread, then [`ReAim::finish`]; the same aim as
/// [`crate::render::RenderSpec::aim`] makes on one thread.
#[doc(hidden)]
#[derive(Debug)]
pub struct ReAim {
    /// The aim's model for the camera, None when the grid takes no aim (not an opacity
    /// grid, a view the aim does not serve, or no memory).
    model: Option<crate::march::Aim>,
    /// The grid's fine-block flags (a copy: the parts read them while the grid waits to
    /// be aimed).
    fine: Vec<u8>,
}

/// One run of a [`ReAim`]'s fine blocks: its range, and its blocks that reach a pixel
/// with the first row each reaches (None when the arithmetic failed).
#[doc(hidden)]
#[derive(Debug)]
pub struct AimPart {
    blocks: core::ops::Range<usize>,
    firsts: Option<(Vec<(u32, u32)>, u32)>,
}

impl ReAim {
    pub(crate) fn new(model: Option<crate::march::Aim>, grid: &SkipGrid) -> ReAim {
        let mut fine = Vec::new();
        let model = model.filter(|m| {
            m.fine_blocks() == grid.nf && fine.try_reserve_exact(grid.fine.len()).is_ok()
        });
        if model.is_some() {
            fine.extend_from_slice(&grid.fine);
        }
        ReAim { model, fine }
    }

    /// The fine blocks to place: parts cover `0 .. blocks()` (0: no aim to make; then
    /// [`ReAim::finish`] with no parts leaves the grid unaimed).
    pub fn blocks(&self) -> usize {
        if self.model.is_some() {
            self.fine.len()
        } else {
            0
        }
    }

    /// The part of fine blocks `blocks` (a range within `0 .. self.blocks()`).
    pub fn part(&self, blocks: core::ops::Range<usize>) -> AimPart {
        let firsts = self
            .model
            .as_ref()
            .zip(self.fine.get(blocks.clone()))
            .and_then(|(m, fine)| m.firsts(fine, blocks.start));
        AimPart { blocks, firsts }
    }

    /// Aims `grid` (the grid this was made for) with `parts`, in any order: the aim
    /// [`crate::render::RenderSpec::aim`] gives when they cover every block once; else
    /// none (the images are the same bits either way, made more slowly).
    pub fn finish(&self, grid: &mut SkipGrid, mut parts: Vec<AimPart>) {
        parts.sort_unstable_by_key(|p| p.blocks.start);
        let aim = (|| {
            let model = self.model.clone().filter(|m| m.fine_blocks() == grid.nf)?;
            let mut end = 0;
            let mut span = 0;
            let mut lists = Vec::new();
            lists.try_reserve_exact(parts.len()).ok()?;
            for p in &parts {
                let (firsts, sp) = p.firsts.as_ref().filter(|_| p.blocks.start == end)?;
                end = p.blocks.end;
                span = span.max(*sp);
                lists.push(&firsts[..]);
            }
            (end == self.fine.len() && end == grid.fine.len())
                .then(|| model.sorted(&lists, span))?
        })();
        grid.set_aim(aim);
    }
}

/// [`SkipGrid::starts`] of fine block `fb` (block numbers per axis) of a volume of
/// `sizes` voxels `data` (rows `row` samples apart) reconstructed with a kernel of
/// support `s`: set for each support start in the block whose whole support is inside
/// and whose voxels, least `l` and greatest `h`, meet one of the `tests` (`l ≥ l0`
/// and `h ≤ h0`, [`start_tests`]). None below [`STARTS_MIN`] and above 6 (the bits'
/// layout, [`starts_of`]).
fn start_bits<V: Voxel>(
    simd: Simd,
    data: &[V],
    sizes: [usize; 3],
    row: usize,
    s: usize,
    fb: [usize; 3],
    tests: &[(f32, f32); 2],
) -> u64 {
    const _: () = assert!(STARTS_MIN == 2);
    // Compiled for the vector level here: the callers' loop over a coarse block's fine
    // blocks is a function of its own, built for the baseline, where the row tests'
    // vector instructions would each become a call.
    crate::simd::wide(simd, {
        #[inline(always)]
        || match s {
            2 => starts_of::<V, 2>(simd, data, sizes, row, fb, tests),
            3 => starts_of::<V, 3>(simd, data, sizes, row, fb, tests),
            4 => starts_of::<V, 4>(simd, data, sizes, row, fb, tests),
            5 => starts_of::<V, 5>(simd, data, sizes, row, fb, tests),
            6 => starts_of::<V, 6>(simd, data, sizes, row, fb, tests),
            // (Every support the bits' layout holds is above: a kernel added to the
            // table gets its start bits with nothing more.)
            _ => 0,
        }
    })
}

/// [`start_bits`] for support `S`, by voxels rather than ranges: a start's voxels lie
/// in `[l0, h0]` exactly when each of them does (none is NaN: the block's range is
/// finite), so each voxel the block's supports read is tested once, as a bit per test
/// and row of voxels (a row's voxels at once at AVX2, [`crate::simd::in_range_bits`]),
/// and a start's bit is the AND of its voxels' bits, by shifts along x and row by row
/// along y and z. Reads past the volume's end repeat its last voxel;
/// only the starts whose support is inside, which never read them, keep their bits.
#[inline(always)]
fn starts_of<V: Voxel, const S: usize>(
    simd: Simd,
    data: &[V],
    sizes: [usize; 3],
    row: usize,
    fb: [usize; 3],
    tests: &[(f32, f32); 2],
) -> u64 {
    // Where the second test's bits start in a row's word: above the first test's, of
    // which there are as many as voxels per axis the block's supports read (F + S − 1).
    const SECOND: usize = 16;
    const { assert!(S >= 1 && S <= 6 && F + 5 <= SECOND) };
    let w = F + S - 1;
    // The bits of a row's word that its voxels set: w per test.
    let word: u32 = ((1 << w) - 1) * (1 | 1 << SECOND);
    let o = fb.map(|b| b * F);
    // Starts per axis whose support is inside.
    let n = [0, 1, 2].map(|a| (sizes[a] + 1).saturating_sub(o[a] + S).min(F));
    if n.contains(&0) {
        return 0;
    }
    let at =
        |a: usize| -> [usize; F + 5] { core::array::from_fn(|t| (o[a] + t).min(sizes[a] - 1)) };
    let (xs, ys, zs) = (at(0), at(1), at(2));
    let [(l0, h0), (l1, h1)] = *tests;
    // Per voxel row (y, z): bit i (test 0) and bit SECOND + i (test 1) set when the S voxels
    // from x = i on all pass that test; then ANDed over the S rows from y = j on.
    let mut cols = [[0u32; F]; F + 5];
    for (z, col) in cols.iter_mut().enumerate().take(w) {
        let mut rows = [0u32; F + 5];
        for (y, r) in rows.iter_mut().enumerate().take(w) {
            let base = (zs[z] * sizes[1] + ys[y]) * row;
            let Some(row) = data.get(base..base + sizes[0]) else {
                return 0;
            };
            // Eight or sixteen voxels from x = o[0] at once where the row holds the w
            // read and the data the rest (their bits cleared), else voxel by voxel.
            let fast = match data.get(base + o[0]..).filter(|_| o[0] + w <= sizes[0]) {
                Some(r) if w <= 8 => crate::simd::in_range_bits::<V, 1>(simd, r, tests),
                Some(r) => crate::simd::in_range_bits::<V, 2>(simd, r, tests),
                None => None,
            };
            let p = match fast {
                Some(p) => p & word,
                None => {
                    let mut p = 0u32;
                    for (t, &x) in xs.iter().enumerate().take(w) {
                        let v = row.get(x).map_or(f32::NAN, |v| v.to_f32());
                        p |= u32::from((v >= l0) & (v <= h0)) << t;
                        p |= u32::from((v >= l1) & (v <= h1)) << (SECOND + t);
                    }
                    p
                }
            };
            let mut q = p;
            for t in 1..S {
                q &= p >> t;
            }
            *r = q;
        }
        for (j, c) in col.iter_mut().enumerate() {
            *c = rows[j..j + S].iter().fold(!0, |c, &r| c & r);
        }
    }
    let mut bits = 0u64;
    for k in 0..n[2] {
        for j in 0..n[1] {
            let c = cols[k..k + S].iter().fold(!0u32, |c, col| c & col[j]);
            let hit = (c | c >> SECOND) & ((1 << n[0]) - 1);
            bits |= u64::from(hit) << (F * (j + F * k));
        }
    }
    bits
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
    #[cfg(test)]
    pub(crate) fn flags_at(&self, lo: [i64; 3]) -> u8 {
        self.fine[self.fine_index(lo)]
    }

    /// The index in the fine grids of the block of support start `lo`.
    #[inline(always)]
    fn fine_index(&self, lo: [i64; 3]) -> usize {
        let b = lo.map(|x| x as usize / F);
        b[0] + self.nf[0] * (b[1] + self.nf[1] * b[2])
    }

    /// The flags of fine block `b` (block numbers per axis, inside the grid).
    #[inline(always)]
    pub(crate) fn fine_flags(&self, b: [usize; 3]) -> u8 {
        self.fine[b[0] + self.nf[0] * (b[1] + self.nf[1] * b[2])]
    }

    /// True when the convolution whose support starts at index `lo` (all three axes
    /// inside the volume) has zero LUT opacity, as far as the grid tells: its fine block
    /// is empty, or the voxels this convolution reads are enough to tell.
    #[inline(always)]
    pub(crate) fn empty_at(&self, lo: [i64; 3]) -> bool {
        let [x, y, z] = lo.map(|x| x as usize % F);
        let bit = x + F * (y + F * z);
        self.starts
            .get(self.fine_index(lo))
            .is_some_and(|w| w >> bit & 1 != 0)
    }

    /// True when every convolution whose support starts in the coarse block of `lo`
    /// (all three axes inside the volume) has zero LUT opacity.
    #[inline(always)]
    #[cfg(test)]
    pub(crate) fn coarse_empty_at(&self, lo: [i64; 3]) -> bool {
        let b = [lo[0] as usize / B, lo[1] as usize / B, lo[2] as usize / B];
        self.empty[b[0] + self.nb[0] * (b[1] + self.nb[1] * b[2])]
    }

    /// What the grid records.
    pub fn kind(&self) -> SkipKind {
        self.kind
    }

    /// Fine blocks per axis, and their flags ([`FINE_EMPTY`], [`COARSE_EMPTY`]), first
    /// axis fastest.
    pub(crate) fn fine_blocks(&self) -> ([usize; 3], &[u8]) {
        (self.nf, &self.fine)
    }

    /// What the grid was last aimed with (each band's windows are made from it).
    pub(crate) fn aim(&self) -> Option<&crate::march::Aim> {
        self.aim.as_ref()
    }

    /// Keeps `a` as what the grid is aimed with.
    pub(crate) fn set_aim(&mut self, a: Option<crate::march::Aim>) {
        self.aim = a;
    }

    /// Whether the grid was built as `kind` for `kernel` on a volume of `sizes` (a
    /// render uses a grid only then).
    pub fn fits(&self, kind: SkipKind, kernel: KernelName, sizes: [usize; 3]) -> bool {
        (self.kind, self.kernel, self.sizes) == (kind, kernel, sizes)
    }

    /// The upper bound of the maximized quantity for a convolution whose support starts
    /// at `lo` (all three axes inside the volume; the `max` kinds).
    #[inline(always)]
    pub(crate) fn bound_at(&self, lo: [i64; 3]) -> f32 {
        self.hi[self.fine_index(lo)]
    }

    /// The upper bound of [`SkipGrid::bound_at`] over every support start in the box
    /// from `lo` to `hi` (`lo ≤ hi` on each axis, all inside the volume; +∞ for a box
    /// beyond the grid).
    #[cfg(test)]
    pub(crate) fn bound_over(&self, lo: [i64; 3], hi: [i64; 3]) -> f32 {
        let mut m = f32::NEG_INFINITY;
        let inside = self.every_bound(lo, hi, |b| {
            m = m.max(b);
            true
        });
        if inside {
            m
        } else {
            f32::INFINITY
        }
    }

    /// Whether `under` holds for [`SkipGrid::bound_at`] of every support start in the
    /// box from `lo` to `hi` (as [`SkipGrid::bound_over`]), asked block by block until
    /// it fails: for a test that holds for any bound below one it holds for, the same
    /// answer as `under(bound_over(lo, hi))`, most often sooner. False for a box
    /// beyond the grid, or whose last block comes before its first on an axis (`lo >
    /// hi` within one block reads that block: its bound covers the empty box too).
    #[inline(always)]
    pub(crate) fn every_bound(
        &self,
        lo: [i64; 3],
        hi: [i64; 3],
        mut under: impl FnMut(f32) -> bool,
    ) -> bool {
        let (a, b) = (lo.map(|x| x as usize / F), hi.map(|x| x as usize / F));
        // (A negative start is a large usize: beyond the grid too.)
        let nf = self.nf;
        if (a[0] > b[0])
            | (a[1] > b[1])
            | (a[2] > b[2])
            | (b[0] >= nf[0])
            | (b[1] >= nf[1])
            | (b[2] >= nf[2])
        {
            return false;
        }
        for z in a[2]..=b[2] {
            for y in a[1]..=b[1] {
                let row = self.nf[0] * (y + self.nf[1] * z);
                let Some(bounds) = self.hi.get(row + a[0]..=row + b[0]) else {
                    return false;
                };
                for &x in bounds {
                    if !under(x) {
                        return false;
                    }
                }
            }
        }
        true
    }

    /// The upper bound of [`SkipGrid::bound_at`] over the whole coarse block of `lo`.
    #[inline(always)]
    pub(crate) fn coarse_bound_at(&self, lo: [i64; 3]) -> f32 {
        let c = lo.map(|x| x as usize / B);
        self.coarse_hi[c[0] + self.nb[0] * (c[1] + self.nb[1] * c[2])]
    }

    /// The support starts, `[first, last]` per axis, of the coarse block of `lo`.
    #[inline(always)]
    pub(crate) fn coarse_box(lo: [i64; 3]) -> [[i64; 2]; 3] {
        lo.map(|x| {
            let b = x.div_euclid(B as i64) * B as i64;
            [b, b + B as i64 - 1]
        })
    }

    /// Fraction of fine blocks marked empty.
    pub fn empty_fraction(&self) -> f64 {
        let n = self.fine.iter().filter(|&&e| e & FINE_EMPTY != 0).count();
        n as f64 / self.fine.len().max(1) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::SkipGrid;
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

    /// A plan says that a grid is its own exactly when the grid was built with the same
    /// kind, kernel, sizes, LUT and bounds (the world-to-index map's part in them):
    /// what a renderer keeping a volume's grid between frames relies on.
    #[test]
    fn plans_know_their_grids() {
        use super::{SkipKind, SkipPlan};
        use crate::affine::Affine4;
        use crate::kernel::KernelName;
        use crate::txf::Lut;
        use crate::volume::Volume;
        let sizes = [12, 10, 9];
        let d: Vec<i16> = (0..sizes.iter().product::<usize>())
            .map(|i| (i % 11) as i16)
            .collect();
        let itow = Affine4::from_columns([1., 0., 0.], [0., 1., 0.], [0., 0., 1.], [0.; 3]);
        let wide = Affine4::from_columns([2., 0., 0.], [0., 1., 0.], [0., 0., 1.], [0.; 3]);
        let vol = Volume::new(&d, sizes, itow).unwrap();
        let (v2, small) = (
            Volume::new(&d, sizes, wide).unwrap(),
            Volume::new(&d[..sizes[0] * sizes[1] * 8], [12, 10, 8], itow).unwrap(),
        );
        let lut = |a: f32| Lut::new(0.0, 10.0, alloc::vec![[1.0, 1.0, 1.0, a]; 10]).unwrap();
        let (l1, l2) = (lut(0.5), lut(0.25));
        let t = KernelName::Tent;
        let g = SkipPlan::new(&vol, t, &l1).build(&vol);
        assert!(SkipPlan::new(&vol, t, &l1).builds(&g));
        assert!(SkipPlan::new(&vol, t, &l1.clone()).builds(&g));
        assert!(!SkipPlan::new(&vol, t, &l2).builds(&g));
        assert!(!SkipPlan::new(&vol, KernelName::Bspln3, &l1).builds(&g));
        assert!(!SkipPlan::new(&small, t, &l1).builds(&g));
        let max = |v: &Volume<'_, i16>, k| SkipPlan::for_max(v, t, k).unwrap();
        assert!(!max(&vol, SkipKind::MaxValue).builds(&g));
        let gm = max(&vol, SkipKind::MaxGradMag).build(&vol);
        assert!(max(&vol, SkipKind::MaxGradMag).builds(&gm));
        assert!(!max(&vol, SkipKind::MaxValue).builds(&gm));
        // The gradient's bound depends on the world-to-index map; the value's does not.
        assert!(!max(&v2, SkipKind::MaxGradMag).builds(&gm));
        let v = max(&vol, SkipKind::MaxValue).build(&vol);
        assert!(max(&v2, SkipKind::MaxValue).builds(&v));
    }

    /// Runs of coarse slabs built apart and put together in any order make the grid
    /// built at once, for both kinds of grid; runs that miss a slab, hold one twice or
    /// have another plan's grid sizes make none.
    #[test]
    fn runs_make_the_whole_grid() {
        use super::{SkipKind, SkipPlan};
        use crate::affine::Affine4;
        use crate::kernel::KernelName;
        use crate::txf::Lut;
        use crate::volume::Volume;
        let sizes = [21, 13, 75];
        let d: Vec<f32> = (0..sizes.iter().product::<usize>())
            .map(|i| ((i * 7919) % 31) as f32 * if i / (21 * 13) < 30 { 0.0 } else { 1.0 })
            .collect();
        let itow = Affine4::from_columns([1., 0., 0.], [0., 1., 0.], [0., 0., 1.], [0.; 3]);
        let vol = Volume::new(&d, sizes, itow).unwrap();
        let other = Volume::new(&d[..30 * 13 * 40], [30, 13, 40], itow).unwrap();
        let e: Vec<[f32; 4]> = (0..32)
            .map(|i| [1.0, 1.0, 1.0, if i < 12 { 0.0 } else { 0.5 }])
            .collect();
        let lut = Lut::new(0.0, 31.0, e).unwrap();
        let k = KernelName::Bspln3;
        let plans = [
            SkipPlan::new(&vol, k, &lut),
            SkipPlan::for_max(&vol, k, SkipKind::MaxGradMag).unwrap(),
        ];
        for plan in &plans {
            let n = plan.slabs();
            assert!(n >= 5, "{n}");
            let whole = plan.clone().build(&vol);
            assert!(whole.empty_fraction() > 0.0 || plan.kind() != SkipKind::Opacity);
            let runs = |cuts: &[usize]| -> Vec<_> {
                cuts.windows(2)
                    .map(|c| plan.build_run(&vol, c[0]..c[1]))
                    .collect()
            };
            let mut r = runs(&[0, 2, 3, n]);
            assert!(plan.finish(r.clone()) == Some(whole.clone()));
            r.reverse();
            assert!(plan.finish(r.clone()) == Some(whole.clone()));
            // Past the last slab: clamped; a run of no slabs changes nothing.
            assert!(plan.finish(runs(&[0, 1, n + 3])) == Some(whole.clone()));
            assert!(plan.finish(runs(&[0, 2, 2, n])) == Some(whole.clone()));
            assert!(plan.finish(runs(&[0, 2, 3])).is_none(), "a slab missing");
            let mut twice = runs(&[0, 2, n]);
            twice.push(plan.build_run(&vol, 1..2));
            assert!(plan.finish(twice).is_none(), "a slab twice");
            // Another kind's run, or one of another volume's rows, has other grid sizes.
            let other_kind = &plans[if plan.kind() == SkipKind::Opacity {
                1
            } else {
                0
            }];
            let theirs = SkipPlan::new(&other, k, &lut);
            for foreign in [
                other_kind.build_run(&vol, 0..2),
                theirs.build_run(&other, 0..2),
            ] {
                let mut mixed = runs(&[2, n]);
                mixed.push(foreign);
                assert!(plan.finish(mixed).is_none(), "a run of another plan");
            }
        }
    }

    /// The bound on Σ|w| (values and derivatives) holds between its samples too: no
    /// kernel exceeds it at 60 times finer steps.
    #[test]
    fn weight_sum_bounds_hold_between_samples() {
        use crate::kernel::KernelName;
        for k in KernelName::ALL {
            for d in [0, 1] {
                let fine = super::weight_sums(k, d, 4096 * 60).0;
                let b = super::abs_weight_sum(k, d);
                assert!(fine <= b, "{k} d{d}: {fine} > {b}");
                assert!(
                    b <= fine * 1.02 + 2e-3,
                    "{k} d{d}: {b} too loose for {fine}"
                );
            }
        }
    }

    /// A render consults the `max` grid: a grid whose bounds lie (−∞) changes the image
    /// (everything after a ray's first sample is skipped), the true one does not.
    #[test]
    fn max_renders_use_their_bounds() {
        use crate::affine::Affine4;
        use crate::blend::Blend;
        use crate::camera::CameraSpec;
        use crate::kernel::KernelName;
        use crate::probe::Probe;
        use crate::render::{RenderParams, RenderSpec};
        use crate::volume::Volume;
        let sizes = [16, 17, 18];
        let data: Vec<f32> = (0..sizes[0] * sizes[1] * sizes[2])
            .map(|i| ((i * 7919) % 101) as f32 / 100.0)
            .collect();
        let itow = Affine4::from_columns([1., 0., 0.], [0., 1., 0.], [0., 0., 1.], [-8.0; 3]);
        let vol = Volume::new(&data, sizes, itow).unwrap();
        let mut p = RenderParams::new(CameraSpec {
            from: [30.0, 4.0, 2.0],
            at: [0.0; 3],
            up: [0.0, 0.0, 1.0],
            near: -12.0,
            far: 12.0,
            fov: 30.0,
            size: [8, 6],
            orthographic: true,
        });
        p.plane_sep = 0.25;
        p.blend = Blend::Max;
        for probe in [Probe::Value, Probe::GradMag] {
            p.probe = probe;
            let spec = RenderSpec::new(p.clone(), None, None, &[]).unwrap();
            let mut g = spec.skip_grid(&vol, KernelName::Bspln3).unwrap();
            let img = |g: Option<&SkipGrid>| {
                let mut out = alloc::vec![0.0f32; 8 * 6 * spec.channels()];
                spec.rows_in::<f32, crate::kernel::Bspln3, 4>(vol, g, 0..6, &mut out, None);
                out
            };
            let (plain, skip) = (img(None), img(Some(&g)));
            assert!(plain
                .iter()
                .zip(&skip)
                .all(|(a, b)| a.to_bits() == b.to_bits()));
            g.hi.fill(f32::NEG_INFINITY);
            g.coarse_hi.fill(f32::NEG_INFINITY);
            assert_ne!(img(Some(&g)), plain, "{probe:?}");
        }
    }

    /// The pilot builds a `max` grid where rays can skip (for the value a bright blob in
    /// a dim field, for the gradient magnitude a sharp step across the view: most
    /// blocks lie below the rays' maxima) and not where they can skip too little (noise
    /// of the same range everywhere, as the 256³ bench volume; for the gradient, the
    /// blob too), and below [`PILOT_VOXELS`](crate::render::PILOT_VOXELS) only the
    /// gradient grid asks it.
    #[test]
    fn pilot_builds_grids_that_skip() {
        use crate::affine::Affine4;
        use crate::blend::Blend;
        use crate::camera::CameraSpec;
        use crate::kernel::Bspln3;
        use crate::probe::Probe;
        use crate::render::{RenderParams, RenderSpec};
        use crate::skip::SkipKind;
        use crate::volume::Volume;
        let sizes = [48, 48, 48];
        let at = |i: usize| [i % 48, (i / 48) % 48, i / 2304].map(|c| c as f32 - 23.5);
        let n = sizes[0] * sizes[1] * sizes[2];
        let blob: Vec<f32> = (0..n)
            .map(|i| {
                let p = at(i);
                let r2 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
                libm::expf(-r2 / 100.0) + ((i * 7919) % 101) as f32 / 20000.0
            })
            .collect();
        // A sharp step across the view axis: every ray's steepest gradient is at the
        // step, and most blocks, away from it, bound a far smaller one.
        let step: Vec<f32> = (0..n)
            .map(|i| {
                let y = at(i)[1];
                1.0 / (1.0 + libm::expf(-y)) + ((i * 7919) % 101) as f32 / 20000.0
            })
            .collect();
        let noise: Vec<f32> = (0..n).map(|i| ((i * 7919) % 101) as f32 / 100.0).collect();
        let itow = Affine4::from_columns([1., 0., 0.], [0., 1., 0.], [0., 0., 1.], [-23.5; 3]);
        let mut p = RenderParams::new(CameraSpec {
            from: [0.0, -100.0, 0.0],
            at: [0.0; 3],
            up: [0.0, 0.0, 1.0],
            near: -30.0,
            far: 30.0,
            fov: 30.0,
            size: [32, 32],
            orthographic: true,
        });
        p.blend = Blend::Max;
        // (The blob's gradient grid would skip too little: its pilot finds fewer than
        // half the sampled blocks below the rays' maxima.)
        let (v, g) = (
            (Probe::Value, SkipKind::MaxValue),
            (Probe::GradMag, SkipKind::MaxGradMag),
        );
        for ((probe, kind), cases) in [
            (v, &[("blob", &blob, true), ("noise", &noise, false)][..]),
            (
                g,
                &[
                    ("step", &step, true),
                    ("blob", &blob, false),
                    ("noise", &noise, false),
                ][..],
            ),
        ] {
            p.probe = probe;
            let spec = RenderSpec::new(p.clone(), None, None, &[]).unwrap();
            for &(name, data, builds) in cases {
                let vol = Volume::new(data, sizes, itow).unwrap();
                let says = spec.pilot_says::<f32, Bspln3, 4>(vol, kind, &|rays| rays(0, 1));
                assert_eq!(says, builds, "{probe:?} {name}");
                // Under PILOT_VOXELS a value grid is built without a pilot; a gradient
                // grid's pilot decides as on a large volume.
                let pays = spec.pilot::<f32, Bspln3, 4>(vol, &|rays| rays(0, 1));
                assert_eq!(
                    pays,
                    builds || kind == SkipKind::MaxValue,
                    "{probe:?} {name}"
                );
                // Cast in parts (as on several threads), in any order: the same rays'
                // results, and the same verdict.
                let whole = core::cell::RefCell::new(Vec::new());
                let split = core::cell::RefCell::new(Vec::new());
                let says3 = spec.pilot_says::<f32, Bspln3, 4>(vol, kind, &|rays| {
                    *whole.borrow_mut() = rays(0, 1);
                    let parts: Vec<f32> = (0..3).rev().flat_map(|i| rays(i, 3)).collect();
                    split.borrow_mut().clone_from(&parts);
                    parts
                });
                assert_eq!(says3, builds, "{probe:?} {name}");
                let (mut whole, mut split) = (whole.into_inner(), split.into_inner());
                whole.sort_by(f32::total_cmp);
                split.sort_by(f32::total_cmp);
                assert!(!whole.is_empty() && whole == split);
            }
        }
    }

    /// `sample_bounds` gives the sampled fine blocks' bounds of the built grid, bit for
    /// bit (NaN and infinite voxels included), for several steps.
    #[test]
    fn sampled_bounds_are_the_grids() {
        use crate::affine::Affine4;
        use crate::kernel::KernelName;
        use crate::skip::{SkipKind, SkipPlan};
        use crate::volume::Volume;
        let sizes = [37, 29, 45];
        let mut data: Vec<f32> = (0..sizes[0] * sizes[1] * sizes[2])
            .map(|i| {
                let (x, z) = ((i % 37) as f32, (i / (37 * 29)) as f32);
                (x * 0.1).sin() * z + ((i * 7919) % 101) as f32 / 50.0
            })
            .collect();
        data[1000] = f32::NAN;
        data[20000] = f32::INFINITY;
        let itow = Affine4::from_columns([1., 0., 0.], [0., 1., 0.], [0.2, 0., 1.], [0.; 3]);
        let vol = Volume::new(&data, sizes, itow).unwrap();
        for kernel in [KernelName::Bspln3, KernelName::Ctmr, KernelName::Tent] {
            for kind in [SkipKind::MaxValue, SkipKind::MaxGradMag] {
                let plan = || SkipPlan::for_max(&vol, kernel, kind).unwrap();
                let g = plan().build(&vol);
                for step in [1, 2, 4] {
                    let mut want = Vec::new();
                    for fk in (0..g.nf[2]).step_by(step) {
                        for fj in (0..g.nf[1]).step_by(step) {
                            for fi in (0..g.nf[0]).step_by(step) {
                                want.push(g.hi[fi + g.nf[0] * (fj + g.nf[1] * fk)].to_bits());
                            }
                        }
                    }
                    let got: Vec<u32> = plan()
                        .sample_bounds(&vol, step)
                        .iter()
                        .map(|b| b.to_bits())
                        .collect();
                    assert_eq!(got, want, "{kernel} {kind:?} step {step}");
                    if step == 1 {
                        assert!(got.contains(&f32::INFINITY.to_bits()));
                        assert!(got.iter().any(|&b| f32::from_bits(b) < 20.0));
                    }
                }
            }
        }
    }

    /// `bound_over` is the largest fine bound of the box's blocks (by a direct loop over
    /// the grid), and `every_bound` with a threshold test gives that test of it, for
    /// boxes of every shape up to whole volume (an infinite bound, from a NaN voxel,
    /// included).
    #[test]
    fn box_bounds_visit_every_block() {
        use crate::affine::Affine4;
        use crate::kernel::KernelName;
        use crate::skip::{SkipKind, SkipPlan, F};
        use crate::volume::Volume;
        let sizes = [23, 19, 30];
        let mut data: Vec<f32> = (0..sizes[0] * sizes[1] * sizes[2])
            .map(|i| ((i * 7919) % 211) as f32 / 7.0)
            .collect();
        data[3000] = f32::NAN;
        let itow = Affine4::from_columns([1., 0., 0.], [0., 1., 0.], [0., 0., 1.], [0.; 3]);
        let vol = Volume::new(&data, sizes, itow).unwrap();
        let g = SkipPlan::for_max(&vol, KernelName::Tent, SkipKind::MaxValue)
            .unwrap()
            .build(&vol);
        let last = sizes.map(|n| n as i64 - 2);
        let mut boxes = 0;
        for (x0, y0, z0) in [(0, 0, 0), (3, 5, 9), (8, 0, 17), (21, 17, 28)] {
            for (dx, dy, dz) in [(0, 0, 0), (5, 0, 2), (1, 9, 0), (40, 40, 40)] {
                let lo = [x0, y0, z0];
                let hi = [x0 + dx, y0 + dy, z0 + dz];
                let hi = [0, 1, 2].map(|a| hi[a].min(last[a]));
                let mut want = f32::NEG_INFINITY;
                for z in lo[2] as usize / F..=hi[2] as usize / F {
                    for y in lo[1] as usize / F..=hi[1] as usize / F {
                        for x in lo[0] as usize / F..=hi[0] as usize / F {
                            want = want.max(g.hi[x + g.nf[0] * (y + g.nf[1] * z)]);
                        }
                    }
                }
                let b = g.bound_over(lo, hi);
                assert_eq!(b.to_bits(), want.to_bits(), "{lo:?} {hi:?}");
                for t in [0.0, 10.0, 20.0, 29.9, 30.0, 31.0, f32::INFINITY] {
                    assert_eq!(g.every_bound(lo, hi, |x| x < t), b < t, "{lo:?} {hi:?} {t}");
                }
                boxes += 1;
            }
        }
        assert_eq!(boxes, 16);
        assert_eq!(g.bound_over([0; 3], last), f32::INFINITY);
        // Beyond the grid: no bound, nothing skipped (and no panic).
        for (lo, hi) in [
            ([0, 0, 0], [200, 0, 0]),
            ([-5, 0, 0], [0, 0, 0]),
            ([0; 3], [0, 0, 99]),
        ] {
            assert_eq!(g.bound_over(lo, hi), f32::INFINITY, "{lo:?} {hi:?}");
            assert!(!g.every_bound(lo, hi, |_| true), "{lo:?} {hi:?}");
        }
    }

    /// The `max` bounds hold: every convolution (value, world gradient magnitude) whose
    /// support starts in a fine block is at most that block's bound, for every kernel
    /// (negative lobes included) on a sheared volume of random voxels.
    #[test]
    fn max_bounds_bound_the_convolution() {
        use crate::affine::Affine4;
        use crate::convo::Convo;
        use crate::kernel::{KernelName, KernelTask};
        use crate::volume::Volume;
        struct Check<'v>(Volume<'v, f32>);
        impl KernelTask for Check<'_> {
            type Output = ();
            fn run<K: crate::kernel::Kernel<S>, const S: usize>(self) {
                let vol = self.0;
                let sizes = vol.sizes();
                let gv = super::SkipPlan::for_max(&vol, K::NAME, super::SkipKind::MaxValue)
                    .unwrap()
                    .build(&vol);
                let gg = super::SkipPlan::for_max(&vol, K::NAME, super::SkipKind::MaxGradMag)
                    .unwrap()
                    .build(&vol);
                let mut c = Convo::<f32, K, S>::new(vol);
                let (mut vmax, mut bmax) = (f32::NEG_INFINITY, f32::NEG_INFINITY);
                for i in 0..4000u64 {
                    // A low-discrepancy walk over the volume.
                    let x: [f64; 3] = core::array::from_fn(|a| {
                        let r = [0.754877666, 0.569840291, 0.430159709][a];
                        ((i as f64 + 0.5) * r).fract() * (sizes[a] as f64 - 1.0)
                    });
                    let (Some(lo), cs) = (c.support_start(x), c.eval_index(x, true)) else {
                        continue;
                    };
                    if !cs.inside {
                        continue;
                    }
                    let gm = crate::arith::gmag(cs.grad_w);
                    let bv = gv.bound_at(lo);
                    let (bg, cg) = (gg.bound_at(lo), gg.coarse_bound_at(lo));
                    assert!(
                        cs.value <= bv,
                        "{}: v {} > {bv} at {x:?}",
                        K::NAME,
                        cs.value
                    );
                    assert!(gm <= bg && bg <= cg, "{}: gm {gm} > {bg} at {x:?}", K::NAME);
                    (vmax, bmax) = (vmax.max(cs.value), bmax.max(bv));
                }
                // Not vacuous: the bounds are of the size of the values (within the
                // widening by negative lobes).
                let zero = K::NAME == KernelName::Zero;
                assert!(zero || vmax >= 0.4 * bmax, "{}: {vmax} vs {bmax}", K::NAME);
            }
        }
        let sizes = [13, 11, 12];
        // Smooth, with a little noise.
        let data: Vec<f32> = (0..sizes[0] * sizes[1] * sizes[2])
            .map(|i| {
                let (x, y, z) = (i % 13, (i / 13) % 11, i / 143);
                let noise = ((i * 7919) % 211) as f32 / 2000.0;
                libm::sinf(x as f32 * 0.5) + libm::cosf(y as f32 * 0.37) + 0.1 * z as f32 + noise
            })
            .collect();
        let itow =
            Affine4::from_columns([0.9, 0.1, 0.0], [0.0, 1.3, 0.2], [0.1, 0.0, 0.7], [0.0; 3]);
        let vol = Volume::new(&data, sizes, itow).unwrap();
        for k in KernelName::ALL {
            k.with(Check(vol));
        }
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
                                // An empty block's starts are all transparent.
                                if f & super::FINE_EMPTY != 0 {
                                    prop_assert_eq!(g.starts[fi + nf[0] * (fj + nf[1] * fk)], !0);
                                }
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

    /// A fine block holding one opaque voxel is not empty, but the support starts whose
    /// voxels miss it are marked transparent, and only those (supports of
    /// [`super::STARTS_MIN`] or more).
    #[test]
    fn starts_beside_an_opaque_voxel_are_transparent() {
        use super::FINE_EMPTY;
        use crate::affine::Affine4;
        use crate::kernel::KernelName;
        use crate::txf::Lut;
        use crate::volume::Volume;
        let itow = Affine4::from_columns([1., 0., 0.], [0., 1., 0.], [0., 0., 1.], [0.; 3]);
        let lut = Lut::new(
            0.0,
            4.0,
            (0..8).map(|i| [1.0, 1.0, 1.0, (i / 4) as f32]).collect(),
        )
        .unwrap();
        let mut data = alloc::vec![0.0f32; 12 * 12 * 12];
        data[6 + 12 * (6 + 12 * 6)] = 3.0;
        let vol = Volume::new(&data, [12; 3], itow).unwrap();
        for (k, s) in [
            (KernelName::Tent, 2),
            (KernelName::Bspln2, 3),
            (KernelName::Bspln3, 4),
        ] {
            let g = SkipGrid::new(&vol, k, &lut);
            let b = 1 + g.nf[0] * (1 + g.nf[1]);
            assert_eq!(g.fine[b] & FINE_EMPTY, 0, "{k:?}");
            // Starts 4..8 per axis; the support of x reads x .. x + s − 1.
            for z in 4..8i64 {
                for y in 4..8i64 {
                    for x in 4..8i64 {
                        // (Supports below STARTS_MIN have no start bits.)
                        let reads = [x, y, z].iter().all(|&c| c <= 6 && 6 < c + s);
                        let bits = s as usize >= super::STARTS_MIN;
                        assert_eq!(g.empty_at([x, y, z]), !reads && bits, "{k:?} {x} {y} {z}");
                    }
                }
            }
        }
    }

    proptest! {
        /// The runs of transparent values hold exactly the values whose entry is
        /// transparent in every row (also at and next to each run's ends), for 1-D LUTs
        /// and 2-D ones; a block's start tests pass only starts whose every reachable
        /// value (by the margins of `SkipPlan::fill_slabs`) is in such an entry, and
        /// pass the voxel ranges well inside a run.
        #[test]
        fn value_runs_are_the_entries_test(
            min in -1e3f64..1e3,
            width in 1e-3f64..1e4,
            rows in 1usize..3,
            wneg in prop::sample::select(&[0.0f64, 0.0, 0.3][..]),
            alpha in prop::collection::vec(prop::sample::select(&[0.0f32, 0.0, 0.5][..]), 1..80),
            pts in prop::collection::vec((0.0f64..1.0, 0.0f64..0.2), 50),
        ) {
            use crate::classify::{LutAxis, Quantity};
            use crate::txf::Lut;
            let n0 = alpha.len() / rows;
            prop_assume!(n0 >= 1);
            let e: Vec<[f32; 4]> = (0..n0 * rows).map(|i| [1.0, 1.0, 1.0, alpha[i]]).collect();
            let max = min + width;
            let mut axes = alloc::vec![LutAxis::new(Quantity::Value, min, max, n0)];
            if rows > 1 {
                axes.push(LutAxis::new(Quantity::GradMag, 0.0, 1.0, rows));
            }
            let lut = Lut::with_axes(&axes, e.clone()).unwrap();
            let a = lut.axes()[0];
            let clear = |i: usize| (0..rows).all(|j| e[i + n0 * j][3] == 0.0);
            let runs = super::value_runs(&lut, &super::nonzero_counts(&lut));
            // Points: spread over the domain and beyond, and each run's ends.
            let mut xs: Vec<f64> = pts.iter().map(|&(u, _)| min - width + 3.0 * width * u).collect();
            for &(lo, hi) in &runs {
                for t in [lo, hi] {
                    if t.is_finite() {
                        xs.extend([t, t.next_down(), t.next_up()]);
                    }
                }
            }
            for &x in &xs {
                let got = runs.iter().any(|&(lo, hi)| lo <= x && x < hi);
                prop_assert_eq!(got, clear(a.index(x)), "{} {:?}", x, runs);
            }
            // Start tests of blocks spanning [m, mx], against the entries test.
            for (k, &m) in xs.iter().enumerate() {
                let mx = m + width * pts[k % pts.len()].1;
                let (m, mx) = (m as f32, mx as f32);
                let Some(t) = super::start_tests(&runs, wneg, m, mx) else {
                    continue;
                };
                for q in 0..=8 {
                    for r in q..=8 {
                        let at = |q: i32| m + (mx - m) * q as f32 / 8.0;
                        let (l, h) = (at(q).min(mx), at(r).min(mx));
                        if !t.iter().any(|&(l0, h0)| l >= l0 && h <= h0) {
                            continue;
                        }
                        let (l, h) = (f64::from(l), f64::from(h));
                        let e = super::VALUE_MARGIN * (l.abs() + h.abs() + 1.0);
                        let (lo, hi) = (l - wneg * (h - l) - e, h + wneg * (h - l) + e);
                        prop_assert!((a.index(lo)..=a.index(hi)).all(clear), "[{}, {}] {:?} {:?}", l, h, t, runs);
                    }
                }
            }
            // A run of at least 3 entries passes a narrow block in its middle.
            for &(lo, hi) in &runs {
                let (lo, hi) = (lo.max(min - width), hi.min(max + width));
                if super::VALUE_MARGIN * (2.0 * lo.abs().max(hi.abs()) + 1.0) < (hi - lo) / 4.0 {
                    let c = ((lo + hi) / 2.0) as f32;
                    prop_assert!(super::start_tests(&runs, wneg, c, c).is_some(), "{} {:?}", c, runs);
                }
            }
        }

        /// A block's start bits are, start by start, whether the start's support is
        /// inside and its least and greatest voxel meet one of the tests (the
        /// definition, read voxel by voxel here), for every support with bits, i16 and
        /// f32 voxels, blocks at the volume's ends and tests that cut through the values.
        #[test]
        fn start_bits_are_the_supports_ranges(
            sizes in (1usize..22, 1usize..14, 1usize..14).prop_map(|(x, y, z)| [x, y, z]),
            vals in prop::collection::vec(-4i16..5, 22 * 14 * 14),
            cuts in prop::array::uniform4(-5.0f32..6.0),
        ) {
            use super::{start_bits, F};
            use crate::simd::{Simd, SimdLevel};
            let n = sizes[0] * sizes[1] * sizes[2];
            let ints = &vals[..n];
            let floats: Vec<f32> = ints.iter().map(|&v| f32::from(v) * 0.5).collect();
            let tests = [(cuts[0], cuts[1]), (cuts[2], cuts[3])];
            let halves = tests.map(|(l0, h0)| (l0 * 0.5, h0 * 0.5));
            // The definition: bit (x, y, z) of block fb.
            let want = |s: usize, fb: [usize; 3], tests: &[(f32, f32); 2], at: &dyn Fn(usize) -> f32| {
                let mut bits = 0u64;
                for b in 0..F * F * F {
                    let st = [b % F + F * fb[0], b / F % F + F * fb[1], b / (F * F) + F * fb[2]];
                    if (0..3).any(|a| st[a] + s > sizes[a]) {
                        continue;
                    }
                    let (mut l, mut h) = (f32::INFINITY, f32::NEG_INFINITY);
                    for c in 0..s * s * s {
                        let q = [st[0] + c % s, st[1] + c / s % s, st[2] + c / (s * s)];
                        let v = at(q[0] + sizes[0] * (q[1] + sizes[1] * q[2]));
                        (l, h) = (l.min(v), h.max(v));
                    }
                    if tests.iter().any(|&(l0, h0)| l >= l0 && h <= h0) {
                        bits |= 1 << b;
                    }
                }
                bits
            };
            for s in 2usize..=6 {
                let nb = sizes.map(|z| z.div_ceil(F));
                for b in 0..nb[0] * nb[1] * nb[2] {
                    let fb = [b % nb[0], b / nb[0] % nb[1], b / (nb[0] * nb[1])];
                    // Both the vector rows (where the processor has them) and the portable.
                    for simd in [Simd::detect(), Simd::at_most(SimdLevel::Baseline)] {
                        prop_assert_eq!(
                            start_bits(simd, ints, sizes, sizes[0], s, fb, &tests),
                            want(s, fb, &tests, &|i| f32::from(ints[i])),
                            "i16, support {}, block {:?}, {:?}", s, fb, simd
                        );
                        prop_assert_eq!(
                            start_bits(simd, &floats, sizes, sizes[0], s, fb, &halves),
                            want(s, fb, &halves, &|i| floats[i]),
                            "f32, support {}, block {:?}, {:?}", s, fb, simd
                        );
                    }
                }
            }
        }

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

    }
}
