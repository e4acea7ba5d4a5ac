//! The two arithmetics the one ray-marching loop ([`crate::march`]) runs in. A strategy
//! owns only what must differ for its bits: the scalar type and order of the geometry
//! (ray start and step, view → world → index), the placement of a sample's kernel
//! support, the convolution sums, opacity correction and the `over` formula. Everything
//! else (span, batching, skipping, probing, shading, blending order, early termination,
//! the trace) is the loop's.
//!
//! * [`F64`] (`-ref false`): f64 geometry with the index-space ray precomputed, the
//!   separable SIMD sums of [`Convo`], opacity correction by `exp`/`ln`, `over` on the
//!   accumulated opacity.
//! * [`Reference`] (`-ref true`, the default): the course reference program's f32
//!   operation sequence ([`crate::refarith`]), its running sums run [`LANES`] samples
//!   side by side, opacity correction by `powf`, `over` on the transparency.

use crate::blend::{Accum, Blend, MAX_CHANNELS};
use crate::camera::Camera;
use crate::convo::{
    grad_to_world, locate, place, second_order_at, world_gmags, Convo, Place, SecondOrder,
};
use crate::kernel::Kernel;
use crate::math;
use crate::refarith::{self, Lanes, RefCamera, RefIndex, RefRay, ViewIndex, LANES};
use crate::simd::LaneBatch;
use crate::simd::Simd;
use crate::volume::Volume;
use crate::voxel::Voxel;

/// An index-space line `s + k d` within `err` (per axis) of every sample position a
/// strategy computes for k up to the ray's end, for provable jumps over empty boxes.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Line {
    pub s: [f64; 3],
    pub d: [f64; 3],
    pub err: [f64; 3],
}

/// The last opacity corrected on a ray (its bits) and the result.
pub(crate) type Memo = Option<(u32, f32)>;

/// The f64 engine's placements of consecutive samples (see [`Arith::place_block`]).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Placed<const N: usize> {
    /// First support index per axis (where inside).
    n: [[i64; 3]; N],
    /// Fractional offsets (where inside).
    f: [[f64; 3]; N],
    /// Whether the support is inside the volume.
    inside: [bool; N],
    /// Whether the sample is past the far plane.
    past: [bool; N],
}

/// Work to run with a strategy's batch size (see [`Arith::batched`]).
pub(crate) trait BatchTask {
    /// What the task returns.
    type Output;
    /// Runs with batches of `N` samples.
    fn run<const N: usize>(self) -> Self::Output;
}

/// One arithmetic: what the loop asks of the geometry, the convolution and the
/// compositing of a sample.
pub(crate) trait Arith {
    /// One ray's geometry.
    type Ray: Copy;
    /// Fractional offsets of a placed sample.
    type Frac: Copy + Default;
    /// Runs `task` with the number of samples the batched loop convolves together in
    /// this strategy (8 or 16), so that only that batch size is compiled.
    fn batched<T: BatchTask>(task: T) -> T::Output;

    /// The ray through pixel (hi, vi).
    fn ray(&self, hi: u32, vi: u32) -> Self::Ray;
    /// Opacity-correction exponent of the ray (step length over the unit step).
    fn alpha_exp(ray: &Self::Ray) -> f32;
    /// Unit world direction from the ray's samples towards the eye.
    fn to_eye(ray: &Self::Ray) -> [f32; 3];
    /// Whether sample k (> 0) is past the far plane.
    fn past(&self, ray: &Self::Ray, k: u32) -> bool;
    /// First support index per axis and fractions of sample k, when its kernel support
    /// is inside the volume (the inside rule).
    fn place(&self, ray: &Self::Ray, k: u32) -> Option<([i64; 3], Self::Frac)>;
    /// Placements of `N` consecutive samples, in the strategy's own layout (read
    /// lane by lane with [`Arith::block_past`] and [`Arith::block_at`]).
    type Block<const N: usize>: Copy;
    /// [`Arith::place`] and [`Arith::past`] for the `N` consecutive samples from `k0`
    /// (strategies may compute them side by side; the same results). With `exact`,
    /// every one of them is known to be inside and before the far plane (from an exact
    /// [`Arith::span`]), and the tests may be left out.
    fn place_block<const N: usize>(&self, ray: &Self::Ray, k0: u32, exact: bool) -> Self::Block<N>;
    /// Whether sample `l` of a block is past the far plane.
    fn block_past<const N: usize>(b: &Self::Block<N>, l: usize) -> bool;
    /// [`Arith::place`] of sample `l` of a block.
    fn block_at<const N: usize>(b: &Self::Block<N>, l: usize) -> Option<([i64; 3], Self::Frac)>;
    /// View, world and index position of sample k (for position probes and the trace).
    fn positions(&self, ray: &Self::Ray, k: u32) -> [[f64; 3]; 3];
    /// Depth-cue position of sample k: 0 on the near plane, 1 on the far plane.
    fn tau(&self, ray: &Self::Ray, k: u32) -> f32;
    /// Sample numbers `[lo, hi)` within `[0, kend)` outside which no sample is inside,
    /// and whether every sample in it is inside and before the far plane (an exact
    /// span); None when no sample is inside. With it, [`Arith::line`] over `0 .. kend`
    /// (found along the way).
    fn span(&self, ray: &Self::Ray, kend: u32) -> (Option<(u32, u32, bool)>, Option<Line>);
    /// The ray's index-space line with its error bound (None: no jumps on this ray).
    fn line(&self, ray: &Self::Ray, kend: u32) -> Option<Line>;
    /// Index-space sums [value, ∂x, ∂y, ∂z] (gradient only with `G`) of the first `m`
    /// of the placed samples.
    fn convolve<const G: bool, const N: usize>(
        &self,
        n: &[[i64; 3]; N],
        f: &[Self::Frac; N],
        m: usize,
        out: &mut [[f32; 4]; N],
    );
    /// The sums of the `N` consecutive samples from k, with positions computed
    /// alongside, when all of them are inside and before the far plane (`exact`: the
    /// ray's span says so); false when they are not, or the strategy has no such path
    /// (then nothing was done).
    fn convolve_run<const G: bool, const N: usize>(
        &self,
        _ray: &Self::Ray,
        _k: u32,
        _exact: bool,
        _out: &mut [[f32; 4]; N],
    ) -> bool {
        false
    }
    /// [`Arith::convolve_run`]'s samples reduced to the one-channel probe: the values,
    /// or with `gm` (and `G`) the world gradient magnitudes ([`Arith::gmags`]); false
    /// as there.
    #[inline(always)]
    fn convolve_run_scalars<const G: bool, const N: usize>(
        &self,
        ray: &Self::Ray,
        k: u32,
        exact: bool,
        gm: bool,
        out: &mut [f32; N],
    ) -> bool {
        let mut res = [[0.0f32; 4]; N];
        if !self.convolve_run::<G, N>(ray, k, exact, &mut res) {
            return false;
        }
        *out = if gm {
            self.gmags(&res)
        } else {
            res.map(|r| r[0])
        };
        true
    }
    /// Whether [`Arith::convolve_run_pair`] can sum two runs together here (the loop
    /// asks nothing of the second run otherwise).
    #[inline(always)]
    fn pairs_runs(&self) -> bool {
        false
    }
    /// [`Arith::convolve_run_scalars`] of the `2N` consecutive samples from k, as two
    /// runs (`out[0]` from k, `out[1]` from k + N), where the strategy sums two runs
    /// together quicker than one after the other; false when not all are inside and
    /// before the far plane, or it has no such path (then nothing was done).
    #[inline(always)]
    fn convolve_run_pair<const G: bool, const N: usize>(
        &self,
        _ray: &Self::Ray,
        _k: u32,
        _gm: bool,
        _out: &mut [[f32; N]; 2],
    ) -> bool {
        false
    }
    /// World-space gradient from an index-space one.
    fn grad_world(&self, gi: [f32; 3]) -> [f32; 3];
    /// Value, world gradient and world Hessian in f64 for a sample placed at (`n`, `f`)
    /// by [`Arith::place`] (neither arithmetic has second derivatives of its own: both
    /// sum the kernels' f64 formulas from their own placement, so the inside rule and
    /// the sample's position are the arithmetic's).
    fn second(&self, n: [i64; 3], f: Self::Frac) -> SecondOrder;
    /// World gradient magnitudes of sums `r`.
    #[inline(always)]
    fn gmags<const N: usize>(&self, r: &[[f32; 4]; N]) -> [f32; N] {
        let mut out = [0.0f32; N];
        for (o, x) in out.iter_mut().zip(r) {
            *o = gmag(self.grad_world([x[1], x[2], x[3]]));
        }
        out
    }
    /// Opacity `a` corrected for the ray's step; `entry` is the LUT entry whose own
    /// opacity `a` is, when it is one (for per-entry tables).
    fn correct(&self, ray: &Self::Ray, a: f32, entry: Option<usize>, memo: &mut Memo) -> f32;
    /// Blends a counted probe (`over`: rgb and corrected α; `transp` is the running
    /// transparency, kept by strategies that composite on it).
    fn blend(acc: &mut Accum, transp: &mut f32, pr: &[f32; MAX_CHANNELS]);
}

/// |g| in f32, the one formula of both arithmetics.
#[inline(always)]
pub(crate) fn gmag(g: [f32; 3]) -> f32 {
    math::sqrtf(sq_len(g))
}

/// |g|² in f32, as [`gmag`] sums it.
#[inline(always)]
fn sq_len(g: [f32; 3]) -> f32 {
    g[0] * g[0] + g[1] * g[1] + g[2] * g[2]
}

/// Geometry of one ray in the f64 arithmetic.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayGeom {
    /// View-space start on the near plane.
    pub start_v: [f64; 3],
    /// View-space step between planes.
    pub step_v: [f64; 3],
    /// World-space start.
    pub start_w: [f64; 3],
    /// World-space step.
    pub step_w: [f64; 3],
    /// Length of one step (world units).
    pub step_len: f64,
    /// Opacity-correction exponent: step length over the unit step (`-us`).
    pub alpha_exp: f32,
    /// Unit direction from a sample towards the eye (world).
    pub to_eye: [f32; 3],
}

impl RayGeom {
    /// The ray through pixel (hi, vi) of `cam`, planes `plane_sep` apart (0: one
    /// sample), opacity unit step `unit_step`.
    pub fn new(cam: &Camera, hi: u32, vi: u32, plane_sep: f64, unit_step: f64) -> RayGeom {
        let (start_v, step_v) = cam.ray(hi, vi, plane_sep);
        // Direction to the eye from a unit-separation step (valid also when ps = 0).
        let (_, dir_v) = cam.ray(hi, vi, 1.0);
        let dir_w = cam.vtow.vector(dir_v);
        let dl = math::v3::len(dir_w);
        let step_w = cam.vtow.vector(step_v);
        let step_len = math::v3::len(step_w);
        RayGeom {
            start_v,
            step_v,
            start_w: cam.vtow.point(start_v),
            step_w,
            step_len,
            alpha_exp: (step_len / unit_step) as f32,
            to_eye: dir_w.map(|x| (-x / dl) as f32),
        }
    }
}

/// An f64 ray: its geometry, index-space line and sample count before the far plane.
#[derive(Debug, Clone, Copy)]
pub(crate) struct F64Ray {
    g: RayGeom,
    start_i: [f64; 3],
    step_i: [f64; 3],
}

#[inline(always)]
fn at(s: &[f64; 3], d: &[f64; 3], k: u32) -> [f64; 3] {
    let kf = k as f64;
    [s[0] + kf * d[0], s[1] + kf * d[1], s[2] + kf * d[2]]
}

/// The f64 arithmetic over one volume.
pub(crate) struct F64<'r, 'v, V: Voxel, K: Kernel<S>, const S: usize> {
    pub convo: Convo<'v, V, K, S>,
    pub cam: &'r Camera,
    pub plane_sep: f64,
    pub unit_step: f64,
    /// ln(1 − α) of each LUT entry's clamped opacity.
    pub ln_transparency: &'r [f64],
    /// Sizes of the samples held and the grid index of the first ([`Volume::region`]).
    sizes: [i64; 3],
    org: [i64; 3],
}

impl<'r, 'v, V: Voxel, K: Kernel<S>, const S: usize> F64<'r, 'v, V, K, S> {
    pub fn new(
        vol: Volume<'v, V>,
        simd: Simd,
        cam: &'r Camera,
        plane_sep: f64,
        unit_step: f64,
        ln_transparency: &'r [f64],
    ) -> Self {
        let s = vol.sizes();
        F64 {
            convo: Convo::with_simd(vol, simd),
            cam,
            plane_sep,
            unit_step,
            ln_transparency,
            sizes: s.map(|x| x as i64),
            org: vol.origin().map(|x| x as i64),
        }
    }
}

impl<V: Voxel, K: Kernel<S>, const S: usize> Arith for F64<'_, '_, V, K, S> {
    type Ray = F64Ray;
    type Frac = [f64; 3];
    type Block<const N: usize> = Placed<N>;
    #[inline(always)]
    fn batched<T: BatchTask>(task: T) -> T::Output {
        task.run::<8>()
    }

    #[inline]
    fn ray(&self, hi: u32, vi: u32) -> F64Ray {
        let g = RayGeom::new(self.cam, hi, vi, self.plane_sep, self.unit_step);
        let wtoi = self.convo.volume().wtoi();
        F64Ray {
            start_i: wtoi.point(g.start_w),
            step_i: wtoi.vector(g.step_w),
            g,
        }
    }
    #[inline(always)]
    fn alpha_exp(ray: &F64Ray) -> f32 {
        ray.g.alpha_exp
    }
    #[inline(always)]
    fn to_eye(ray: &F64Ray) -> [f32; 3] {
        ray.g.to_eye
    }
    #[inline(always)]
    fn past(&self, ray: &F64Ray, k: u32) -> bool {
        -(ray.g.start_v[2] + k as f64 * ray.g.step_v[2]) > self.cam.fcv
    }
    #[inline(always)]
    fn place(&self, ray: &F64Ray, k: u32) -> Option<([i64; 3], [f64; 3])> {
        let p = at(&ray.start_i, &ray.step_i, k);
        let (mut n, mut f) = ([0i64; 3], [0.0f64; 3]);
        for a in 0..3 {
            let Place::Inside(b, al) = place::<K, S>(p[a], self.org[a], self.sizes[a]) else {
                return None;
            };
            (n[a], f[a]) = (b, al);
        }
        Some((n, f))
    }
    /// With `exact`, the placements without the inside tests ([`locate`]: the same
    /// arithmetic as [`place`]).
    #[inline(always)]
    fn place_block<const N: usize>(&self, ray: &F64Ray, k0: u32, exact: bool) -> Placed<N> {
        let mut out = Placed {
            n: [[0; 3]; N],
            f: [[0.0; 3]; N],
            inside: [exact; N],
            past: [false; N],
        };
        for l in 0..N {
            let k = k0 + l as u32;
            if exact {
                let (n, f) = locate::<K, S>(at(&ray.start_i, &ray.step_i, k));
                // Support starts count from the samples held.
                out.n[l] = core::array::from_fn(|a| n[a] - self.org[a]);
                out.f[l] = f;
                continue;
            }
            out.past[l] = self.past(ray, k);
            if let Some((n, f)) = self.place(ray, k) {
                (out.inside[l], out.n[l], out.f[l]) = (true, n, f);
            }
        }
        out
    }
    #[inline(always)]
    fn block_past<const N: usize>(b: &Placed<N>, l: usize) -> bool {
        b.past[l]
    }
    #[inline(always)]
    fn block_at<const N: usize>(b: &Placed<N>, l: usize) -> Option<([i64; 3], [f64; 3])> {
        b.inside[l].then(|| (b.n[l], b.f[l]))
    }
    fn positions(&self, ray: &F64Ray, k: u32) -> [[f64; 3]; 3] {
        [
            at(&ray.g.start_v, &ray.g.step_v, k),
            at(&ray.g.start_w, &ray.g.step_w, k),
            at(&ray.start_i, &ray.step_i, k),
        ]
    }
    #[inline(always)]
    fn tau(&self, ray: &F64Ray, k: u32) -> f32 {
        let z = ray.g.start_v[2] + k as f64 * ray.g.step_v[2];
        ((-z - self.cam.ncv) / (self.cam.fcv - self.cam.ncv)) as f32
    }
    fn span(&self, ray: &F64Ray, kmax1: u32) -> (Option<(u32, u32, bool)>, Option<Line>) {
        // The samples before the far plane: -z(k) never decreases (the step points away
        // from the eye), so the stopping condition is false … false true … true.
        let (s, d) = (ray.g.start_v[2], ray.g.step_v[2]);
        let fcv = self.cam.fcv;
        let guess = ceil_estimate((-fcv - s) / d);
        let kend = first_true_near(1, kmax1, guess, |k| -(s + k as f64 * d) > fcv);
        let (lo, hi, exact) =
            match inside_span_f64::<K, S>(self.org, self.sizes, &ray.start_i, &ray.step_i, kend) {
                Some((lo, hi)) => (lo, hi, true),
                None => (0, kend, false),
            };
        ((lo < hi).then_some((lo, hi, exact)), self.line(ray, kmax1))
    }
    fn line(&self, ray: &F64Ray, kend: u32) -> Option<Line> {
        // s + k d rounded twice: within 2^-52 (|s| + k |d|), and a generous margin.
        let err = core::array::from_fn(|a| {
            1e-12 * (ray.start_i[a].abs() + kend as f64 * ray.step_i[a].abs() + 1.0)
        });
        Some(Line {
            s: ray.start_i,
            d: ray.step_i,
            err,
        })
    }
    #[inline(always)]
    fn convolve<const G: bool, const N: usize>(
        &self,
        n: &[[i64; 3]; N],
        f: &[[f64; 3]; N],
        m: usize,
        out: &mut [[f32; 4]; N],
    ) {
        self.convo.sums_first::<G, N>(n, f, m, out);
    }
    #[inline(always)]
    fn convolve_run<const G: bool, const N: usize>(
        &self,
        ray: &F64Ray,
        k: u32,
        exact: bool,
        out: &mut [[f32; 4]; N],
    ) -> bool {
        // The runs place their samples in the grid's indices (whole volumes only) and
        // need an exact span.
        if !exact || self.org != [0; 3] {
            return false;
        }
        self.convo
            .sums_run::<G, N>(&ray.start_i, &ray.step_i, k, out);
        true
    }
    #[inline(always)]
    fn grad_world(&self, gi: [f32; 3]) -> [f32; 3] {
        grad_to_world(&self.convo.grad_matrix(), gi)
    }
    fn second(&self, n: [i64; 3], f: [f64; 3]) -> SecondOrder {
        second_order_at::<V, K, S>(self.convo.volume(), n, f)
    }
    #[inline(always)]
    fn gmags<const N: usize>(&self, r: &[[f32; 4]; N]) -> [f32; N] {
        world_gmags(&self.convo.grad_matrix(), r)
    }
    #[inline(always)]
    fn correct(&self, ray: &F64Ray, a: f32, entry: Option<usize>, memo: &mut Memo) -> f32 {
        let ex = ray.g.alpha_exp;
        match entry {
            Some(i) if i < self.ln_transparency.len() => {
                correct_alpha_ln(a, self.ln_transparency[i], ex)
            }
            _ => memoized(memo, a, |a| correct_alpha(a, ex)),
        }
    }
    #[inline(always)]
    fn blend(acc: &mut Accum, _transp: &mut f32, pr: &[f32; MAX_CHANNELS]) {
        acc.add(pr);
    }
}

/// `f(a)`, or the last result when `a` has the same bits as last time.
#[inline(always)]
fn memoized(memo: &mut Memo, a: f32, f: impl FnOnce(f32) -> f32) -> f32 {
    match *memo {
        Some((bits, r)) if bits == a.to_bits() => r,
        _ => {
            let r = f(a);
            *memo = Some((a.to_bits(), r));
            r
        }
    }
}

/// The reference arithmetic over one volume.
pub(crate) struct Reference<'r, 'v, V: Voxel, K: Kernel<S>, const S: usize> {
    pub vol: Volume<'v, V>,
    pub simd: Simd,
    pub cam: &'r RefCamera,
    pub wtoi: RefIndex,
    vix: ViewIndex,
    pub plane_sep: f32,
    pub unit_step: f32,
    /// Per axis: the kernel's first support offset less the grid index of the first
    /// sample held (LO − origin: a support start relative to the samples held is
    /// floor + this), and the last index held relative to it (size − 1), in f32 (exact:
    /// integers below 2^24).
    lo_off: [f32; 3],
    top: [f32; 3],
    /// Whether the batched runs compute the value where they compute the gradient
    /// (true unless the probe is the gradient alone and no trace sees the sums).
    pub value: bool,
    _k: core::marker::PhantomData<K>,
}

impl<'r, 'v, V: Voxel, K: Kernel<S>, const S: usize> Reference<'r, 'v, V, K, S> {
    pub fn new(
        vol: Volume<'v, V>,
        simd: Simd,
        cam: &'r RefCamera,
        plane_sep: f32,
        unit_step: f32,
    ) -> Self {
        let (o, sz) = (vol.origin(), vol.sizes());
        let wtoi = RefIndex::new(vol.itow());
        Reference {
            lo_off: o.map(|o| K::LO as f32 - o as f32),
            top: sz.map(|n| n as f32 - 1.0),
            wtoi,
            vix: ViewIndex::new(cam, &wtoi),
            vol,
            simd,
            cam,
            plane_sep,
            unit_step,
            value: true,
            _k: core::marker::PhantomData,
        }
    }

    #[inline(always)]
    fn view(ray: &RefRay, k: u32) -> [f32; 3] {
        let kf = k as f32;
        core::array::from_fn(|a| ray.start[a] + kf * ray.step[a])
    }

    /// The sums of the [`LANES`] consecutive samples from k (lane-major, as
    /// [`crate::simd::lane_sums_soa`] gives them) when all are inside and before the
    /// far plane: the placement in lanes, each support's first voxel as a flat index
    /// straight from it, and the lane sums, with no per-sample copies.
    #[inline(always)]
    fn run_sums<const G: bool>(&self, ray: &RefRay, k: u32) -> Option<[[f32; LANES]; 4]> {
        let p = self.place_lanes::<LANES>(ray, k);
        let base = self.run_bases(&p)?;
        let batch = LaneBatch {
            vol: &self.vol,
            base: &base,
            al: &p.frac,
            len: LANES,
            value: self.value,
        };
        Some(crate::simd::lane_sums_soa::<V, K, S, G>(self.simd, batch))
    }

    /// [`Reference::run_sums`] of the runs from k and from k + [`LANES`], summed side by
    /// side (None also where the vector level or the kernel has no such path: AVX-512,
    /// support 4).
    #[inline(always)]
    fn run_pair_sums<const G: bool>(&self, ray: &RefRay, k: u32) -> Option<[[[f32; LANES]; 4]; 2]> {
        if !self.pairs_runs() {
            return None;
        }
        let (pa, pb) = (
            self.place_lanes::<LANES>(ray, k),
            self.place_lanes::<LANES>(ray, k + LANES as u32),
        );
        let (ba, bb) = (self.run_bases(&pa)?, self.run_bases(&pb)?);
        let vol = &self.vol;
        let batches = [(&ba, &pa), (&bb, &pb)].map(|(base, p)| LaneBatch {
            vol,
            base,
            al: &p.frac,
            len: LANES,
            value: self.value,
        });
        crate::simd::lane_sums_pair::<V, K, S, G>(self.simd, batches)
    }

    /// The flat index of each lane's first support voxel in a run's placement, when
    /// every sample is inside and before the far plane.
    #[inline(always)]
    fn run_bases(&self, p: &Lanes3<LANES>) -> Option<[usize; LANES]> {
        let mut all = 1;
        for l in 0..LANES {
            all &= p.inside[l] & (p.past[l] ^ 1);
        }
        if all == 0 {
            return None;
        }
        // first0 + row (first1 + s1 first2): integers below 2^53 (the sizes of data held
        // in memory), exact in f64.
        // (Loops over whole lanes, so that they vectorize.)
        let sz = self.vol.sizes().map(|n| n as f64);
        let row = self.vol.row_stride() as f64;
        let mut flat = [0.0f64; LANES];
        for (l, x) in flat.iter_mut().enumerate() {
            *x = f64::from(p.first[1][l]) + sz[1] * f64::from(p.first[2][l]);
        }
        for (l, x) in flat.iter_mut().enumerate() {
            *x = f64::from(p.first[0][l]) + row * *x;
        }
        let mut base = [0usize; LANES];
        for (b, &x) in base.iter_mut().zip(&flat) {
            *b = index(x) as usize;
        }
        Some(base)
    }

    /// A run's lane-major sums reduced to the one-channel probe: the values, or with `gm`
    /// (and `G`) the world gradient magnitudes.
    #[inline(always)]
    fn run_scalars<const G: bool>(&self, s: &[[f32; LANES]; 4], gm: bool) -> [f32; LANES] {
        if gm && G {
            self.world_gmags([&s[1], &s[2], &s[3]])
        } else {
            s[0]
        }
    }

    /// [`gmag`]'s operations on index gradients given component by component (`g[c][l]`):
    /// the squared world lengths of all lanes first (side by side), then their square
    /// roots (one vector instruction per eight at AVX2; correctly rounded either way,
    /// so the same bits).
    #[inline(always)]
    fn world_gmags<const N: usize>(&self, g: [&[f32; N]; 3]) -> [f32; N] {
        let mut out = [0.0f32; N];
        for (l, o) in out.iter_mut().enumerate() {
            *o = sq_len(self.wtoi.gradient([g[0][l], g[1][l], g[2][l]]));
        }
        crate::simd::sqrt_lanes(self.simd, &mut out);
        out
    }

    /// [`Arith::place`] of the `N` samples from `k0`, lane by lane and axis by axis
    /// (so that it vectorizes).
    #[inline(always)]
    fn place_lanes<const N: usize>(&self, ray: &RefRay, k0: u32) -> Lanes3<N> {
        let cam = self.cam;
        let mut kf = [0.0f32; N];
        for (l, v) in kf.iter_mut().enumerate() {
            *v = (k0 + l as u32) as f32;
        }
        let mut pv = [[0.0f32; N]; 3];
        for a in 0..3 {
            for l in 0..N {
                pv[a][l] = ray.start[a] + kf[l] * ray.step[a];
            }
        }
        let (u, v, n, fr) = (cam.u, cam.v, cam.n, cam.fr);
        let mut pw = [[0.0f32; N]; 3];
        for r in 0..3 {
            for l in 0..N {
                pw[r][l] = u[r] * pv[0][l] + v[r] * pv[1][l] + n[r] * pv[2][l] + fr[r] * 1.0;
            }
        }
        let (m, t) = (&self.wtoi.m, &self.wtoi.t);
        let mut out = Lanes3 {
            first: [[0.0; N]; 3],
            frac: [[0.0; N]; 3],
            inside: [1; N],
            past: [0; N],
        };
        for a in 0..3 {
            let (top, lo_off) = (self.top[a], self.lo_off[a]);
            // `refarith::place`, lane by lane.
            // (Plain loops: `array::from_fn` may stay out of line, compiled without the
            // vector level.)
            let mut x = [0.0f32; N];
            for l in 0..N {
                x[l] = m[a][0] * pw[0][l] + m[a][1] * pw[1][l] + m[a][2] * pw[2][l] + t[a];
            }
            // (base + (LO − origin) in one add: the same value as the two adds
            // (base + LO) − origin wherever the support can be inside, |base| < 2^24.)
            crate::simd::place_axis_lanes(
                self.simd,
                &x,
                !S.is_multiple_of(2),
                (lo_off, S as f32 - 1.0, top),
                &mut out.first[a],
                &mut out.frac[a],
                &mut out.inside,
            );
        }
        for l in 0..N {
            out.past[l] = u32::from(-pv[2][l] > cam.fcv);
        }
        out
    }
}

/// The reference placement of `N` samples in lanes: per axis the first support index
/// relative to the samples held (an integer in f32, exact where inside) and the
/// fractional offset; whether the support is inside on every axis and whether the
/// sample is past the far plane (1 or 0: whole lanes, which stay vectors, where bools
/// would be packed to bytes).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Lanes3<const N: usize> {
    first: [[f32; N]; 3],
    frac: [[f32; N]; 3],
    inside: [u32; N],
    past: [u32; N],
}

/// An integer 0 ≤ c < 2^52 held in an f64, as i64: c + 2^52 holds c in its low
/// mantissa bits, a conversion that vectorizes (for other values the result is
/// meaningless, and not read).
#[inline(always)]
fn index(c: f64) -> i64 {
    ((c + 4_503_599_627_370_496.0).to_bits() as i64).wrapping_sub(0x4330_0000_0000_0000)
}

impl<V: Voxel, K: Kernel<S>, const S: usize> Arith for Reference<'_, '_, V, K, S> {
    type Ray = RefRay;
    type Frac = [f32; 3];
    type Block<const N: usize> = Lanes3<N>;
    #[inline(always)]
    fn batched<T: BatchTask>(task: T) -> T::Output {
        task.run::<LANES>()
    }

    #[inline]
    fn ray(&self, hi: u32, vi: u32) -> RefRay {
        self.cam.ray(hi, vi, self.plane_sep, self.unit_step)
    }
    #[inline(always)]
    fn alpha_exp(ray: &RefRay) -> f32 {
        ray.alpha_exp
    }
    #[inline(always)]
    fn to_eye(ray: &RefRay) -> [f32; 3] {
        ray.to_eye
    }
    #[inline(always)]
    fn past(&self, ray: &RefRay, k: u32) -> bool {
        -Self::view(ray, k)[2] > self.cam.fcv
    }
    #[inline(always)]
    fn place(&self, ray: &RefRay, k: u32) -> Option<([i64; 3], [f32; 3])> {
        let pi = self.wtoi.point(self.cam.to_world(Self::view(ray, k), 1.0));
        refarith::place3::<K, S>(pi, self.vol.origin(), self.vol.sizes())
    }
    /// Each lane does exactly what [`Arith::place`] does for its sample, side by side.
    #[inline(always)]
    fn place_block<const N: usize>(&self, ray: &RefRay, k0: u32, _exact: bool) -> Lanes3<N> {
        self.place_lanes::<N>(ray, k0)
    }
    #[inline(always)]
    fn block_past<const N: usize>(b: &Lanes3<N>, l: usize) -> bool {
        b.past[l] != 0
    }
    #[inline(always)]
    fn block_at<const N: usize>(b: &Lanes3<N>, l: usize) -> Option<([i64; 3], [f32; 3])> {
        (b.inside[l] != 0).then(|| {
            let n = [b.first[0][l], b.first[1][l], b.first[2][l]].map(|x| index(f64::from(x)));
            (n, [b.frac[0][l], b.frac[1][l], b.frac[2][l]])
        })
    }
    fn positions(&self, ray: &RefRay, k: u32) -> [[f64; 3]; 3] {
        let pv = Self::view(ray, k);
        let pw = self.cam.to_world(pv, 1.0);
        let pi = self.wtoi.point(pw);
        [pv, pw, pi].map(|p| p.map(f64::from))
    }
    #[inline(always)]
    fn tau(&self, ray: &RefRay, k: u32) -> f32 {
        let cam = self.cam;
        (-Self::view(ray, k)[2] - cam.ncv) / (cam.fcv - cam.ncv)
    }
    fn span(&self, ray: &RefRay, kend: u32) -> (Option<(u32, u32, bool)>, Option<Line>) {
        let kmax = kend.saturating_sub(1);
        let line = self.vix.line(ray, kmax);
        let span = refarith::inside_span::<V, K, S>(line.as_ref(), &self.vol, kmax);
        (span.map(|(a, b)| (a, b + 1, false)), line)
    }
    fn line(&self, ray: &RefRay, kend: u32) -> Option<Line> {
        self.vix.line(ray, kend.saturating_sub(1))
    }
    #[inline(always)]
    fn convolve<const G: bool, const N: usize>(
        &self,
        n: &[[i64; 3]; N],
        f: &[[f32; 3]; N],
        m: usize,
        out: &mut [[f32; 4]; N],
    ) {
        // One sample alone (e.g. a `max` floor) costs a whole batch in lanes: in scalars,
        // the same bits.
        if m == 1 {
            let (v, g) = refarith::convolve_placed::<V, K, S>(&self.vol, n[0], f[0], G);
            out[0] = [v, g[0], g[1], g[2]];
            return;
        }
        // LANES samples at a time (a whole batch straight into `out`).
        let mut lanes = Lanes::<S>::default();
        if let Ok(o) = <&mut [[f32; 4]; LANES]>::try_from(&mut out[..]) {
            for j in 0..m.min(LANES) {
                lanes.put(&self.vol, n[j], f[j]);
            }
            return lanes.sums::<V, K, G>(&self.vol, self.simd, o);
        }
        let mut res = [[0.0f32; 4]; LANES];
        let mut i = 0;
        while i < m {
            let take = (m - i).min(LANES);
            for j in i..i + take {
                lanes.put(&self.vol, n[j], f[j]);
            }
            lanes.sums::<V, K, G>(&self.vol, self.simd, &mut res);
            out[i..i + take].copy_from_slice(&res[..take]);
            lanes.clear();
            i += take;
        }
    }
    /// [`Reference::run_sums`], stored sample by sample.
    #[inline(always)]
    fn convolve_run<const G: bool, const N: usize>(
        &self,
        ray: &RefRay,
        k: u32,
        _exact: bool,
        out: &mut [[f32; 4]; N],
    ) -> bool {
        let Ok(out) = <&mut [[f32; 4]; LANES]>::try_from(&mut out[..]) else {
            return false;
        };
        let Some(sums) = self.run_sums::<G>(ray, k) else {
            return false;
        };
        crate::simd::store_lanes::<G>(&sums, out);
        true
    }
    /// [`Reference::run_sums`] reduced in lanes: no per-sample layout in between.
    #[inline(always)]
    fn convolve_run_scalars<const G: bool, const N: usize>(
        &self,
        ray: &RefRay,
        k: u32,
        _exact: bool,
        gm: bool,
        out: &mut [f32; N],
    ) -> bool {
        let Ok(out) = <&mut [f32; LANES]>::try_from(&mut out[..]) else {
            return false;
        };
        let Some(s) = self.run_sums::<G>(ray, k) else {
            return false;
        };
        *out = self.run_scalars::<G>(&s, gm);
        true
    }
    #[inline(always)]
    fn pairs_runs(&self) -> bool {
        S == 4 && self.simd.avx512()
    }
    /// [`Reference::run_pair_sums`] reduced in lanes.
    #[inline(always)]
    fn convolve_run_pair<const G: bool, const N: usize>(
        &self,
        ray: &RefRay,
        k: u32,
        gm: bool,
        out: &mut [[f32; N]; 2],
    ) -> bool {
        if N != LANES {
            return false;
        }
        let Some(s) = self.run_pair_sums::<G>(ray, k) else {
            return false;
        };
        for (o, s) in out.iter_mut().zip(&s) {
            // (N is LANES: every lane is written.)
            for (o, x) in o.iter_mut().zip(self.run_scalars::<G>(s, gm)) {
                *o = x;
            }
        }
        true
    }
    #[inline(always)]
    fn grad_world(&self, gi: [f32; 3]) -> [f32; 3] {
        self.wtoi.gradient(gi)
    }
    /// [`Reference::world_gmags`] of the sums' gradients.
    #[inline(always)]
    fn gmags<const N: usize>(&self, r: &[[f32; 4]; N]) -> [f32; N] {
        // The gradients' components side by side first.
        let mut g = [[0.0f32; N]; 3];
        for (l, x) in r.iter().enumerate() {
            for c in 0..3 {
                g[c][l] = x[c + 1];
            }
        }
        self.world_gmags([&g[0], &g[1], &g[2]])
    }
    fn second(&self, n: [i64; 3], f: [f32; 3]) -> SecondOrder {
        second_order_at::<V, K, S>(&self.vol, n, f.map(f64::from))
    }
    #[inline(always)]
    fn correct(&self, ray: &RefRay, a: f32, _entry: Option<usize>, memo: &mut Memo) -> f32 {
        // The ray's exponent is fixed, so the last result serves equal opacities.
        memoized(memo, a, |a| refarith::correct_alpha(a, ray.alpha_exp))
    }
    #[inline(always)]
    fn blend(acc: &mut Accum, transp: &mut f32, pr: &[f32; MAX_CHANNELS]) {
        // `over` keeps the transparency T: C += T·α·rgb, T ·= 1 − α, opacity 1 − T.
        if acc.blend == Blend::Over {
            let a = pr[3];
            for c in 0..3 {
                acc.acc[c] += *transp * a * pr[c];
            }
            *transp *= 1.0 - a;
            acc.acc[3] = 1.0 - *transp;
            acc.count += 1;
        } else {
            acc.add(pr);
        }
    }
}

/// Opacity `a` clamped to [0, 1] and corrected for a step of `ex` unit steps:
/// 1 − (1 − a)^ex (0 and 1 are kept as they are), computed as 1 − exp(ex · ln(1 − a)) in
/// f64 and rounded once to f32.
#[inline]
pub(crate) fn correct_alpha(a: f32, ex: f32) -> f32 {
    correct_alpha_ln(a, ln_transparency(a.clamp(0.0, 1.0)), ex)
}

/// ln(1 − a) for an opacity `a` in [0, 1] (−∞ for a = 1).
#[inline]
pub(crate) fn ln_transparency(a: f32) -> f64 {
    math::ln((1.0 - a) as f64)
}

/// [`correct_alpha`] given `l` = ln(1 − clamp(a)), e.g. from a per-LUT-entry table.
#[inline]
fn correct_alpha_ln(a: f32, l: f64, ex: f32) -> f32 {
    let a = a.clamp(0.0, 1.0);
    if a == 0.0 || a == 1.0 {
        a
    } else if l == 0.0 {
        // 1 − a rounds to 1 in f32: no opacity for any step (also an infinite one, where
        // the product below would be ∞ · 0).
        0.0
    } else {
        (1.0 - math::exp(ex as f64 * l)) as f32
    }
}

/// About ⌈x⌉ (exact for |x| < 2^63; NaN stays NaN), cheaper than a library ceil: for
/// the estimates that [`first_true_near`] starts from, which need not be exact.
#[inline(always)]
fn ceil_estimate(x: f64) -> f64 {
    if !x.is_finite() {
        return x;
    }
    let t = x as i64 as f64;
    if t < x {
        t + 1.0
    } else {
        t
    }
}

/// [`first_true`] starting from `guess`, an estimate of the answer: the predicate is
/// tried at the estimate and next to it (a close estimate settles it in two calls), and
/// bisection covers what that leaves open, so any estimate gives the exact answer.
pub(crate) fn first_true_near(lo: u32, hi: u32, guess: f64, pred: impl Fn(u32) -> bool) -> u32 {
    if !(guess.is_finite() && lo < hi) {
        return first_true(lo, hi, pred);
    }
    let g = guess.clamp(lo as f64, hi as f64) as u32;
    if g == hi {
        // The answer is in [lo, hi]: hi unless pred holds at hi − 1.
        return if pred(hi - 1) {
            first_true(lo, hi - 1, pred)
        } else {
            hi
        };
    }
    if pred(g) {
        // The answer is in [lo, g].
        if g == lo || !pred(g - 1) {
            g
        } else {
            first_true(lo, g - 1, pred)
        }
    } else if g + 1 == hi || pred(g + 1) {
        // The answer is in [g + 1, hi] and holds at g + 1 or there is no more room.
        g + 1
    } else {
        first_true(g + 2, hi, pred)
    }
}

/// The first k in [lo, hi) where `pred` holds, for a predicate that is false then true
/// over the range; `hi` when it never holds.
pub(crate) fn first_true(mut lo: u32, mut hi: u32, pred: impl Fn(u32) -> bool) -> u32 {
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        if pred(mid) {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    lo
}

/// Samples k in [lo, hi) of the index-space ray `start_i + k step_i` (of `kend`
/// samples) are exactly those whose kernel support is inside the volume, or None when
/// the ray's geometry is unusual (non-finite or huge), for per-sample tests.
fn inside_span_f64<K: Kernel<S>, const S: usize>(
    org: [i64; 3],
    sizes: [i64; 3],
    start_i: &[f64; 3],
    step_i: &[f64; 3],
    kend: u32,
) -> Option<(u32, u32)> {
    const BIG: f64 = 1e14;
    let (mut lo, mut hi) = (0u32, kend);
    for a in 0..3 {
        let (s, d) = (start_i[a], step_i[a]);
        if !(s.abs() < BIG && d.abs() < BIG) {
            return None;
        }
        // -1 below the inside range on this axis, 0 in it, +1 above; monotone in k
        // because x(k) = s + k d is (rounding is monotone) and so is the floor.
        let class = |k: u32| -> i32 {
            match place::<K, S>(s + k as f64 * d, org[a], sizes[a]) {
                Place::Below => -1,
                Place::Inside(..) => 0,
                Place::Above => 1,
            }
        };
        // The positions where the class changes: the support start floor(x + off) + LO
        // reaches 0 at x = tlo and passes size − S at x = thi; the samples nearest them
        // are the estimates the searches start from.
        let off = if S.is_multiple_of(2) { 0.0 } else { 0.5 };
        let tlo = (org[a] - K::LO as i64) as f64 - off;
        let thi = (org[a] + sizes[a]) as f64 - S as f64 - K::LO as f64 + 1.0 - off;
        let near = |t: f64| ceil_estimate((t - s) / d);
        let (a0, a1) = if d > 0.0 {
            (
                first_true_near(0, kend, near(tlo), |k| class(k) >= 0),
                first_true_near(0, kend, near(thi), |k| class(k) > 0),
            )
        } else if d < 0.0 {
            (
                first_true_near(0, kend, near(thi), |k| class(k) <= 0),
                first_true_near(0, kend, near(tlo), |k| class(k) < 0),
            )
        } else if class(0) == 0 {
            (0, kend)
        } else {
            (0, 0)
        };
        lo = lo.max(a0);
        hi = hi.min(a1);
    }
    Some((lo, hi.max(lo)))
}

#[cfg(test)]
mod tests {
    use super::{first_true, first_true_near, Arith, Reference, F64};
    use crate::affine::Affine4;
    use crate::camera::{Camera, CameraSpec};
    use crate::kernel::{Bspln2, Kernel, Tent};
    use crate::refarith::RefCamera;
    use crate::simd::{Simd, SimdLevel};
    use crate::volume::Volume;

    /// A strategy's blocks of eight and of one place each sample exactly as
    /// [`Arith::place`] does, and say what [`Arith::past`] says: sheared volumes off
    /// the origin, perspective and orthographic cameras, rays entering, crossing and
    /// leaving, at every vector level.
    #[test]
    fn blocks_place_as_place_does() {
        fn each<A: Arith>(a: &A, hi: u32, vi: u32, kend: u32, seen: &mut [usize; 2])
        where
            A::Frac: core::fmt::Debug,
        {
            let ray = a.ray(hi, vi);
            let bits =
                |p: Option<([i64; 3], A::Frac)>| p.map(|(n, f)| (n, alloc::format!("{f:?}")));
            for k0 in 0..kend {
                let (b8, b1) = (
                    a.place_block::<8>(&ray, k0, false),
                    a.place_block::<1>(&ray, k0, false),
                );
                assert_eq!(bits(A::block_at(&b1, 0)), bits(a.place(&ray, k0)));
                for l in 0..8 {
                    let k = k0 + l as u32;
                    let want = a.place(&ray, k);
                    seen[usize::from(want.is_some())] += 1;
                    assert_eq!(bits(A::block_at(&b8, l)), bits(want), "k {k}");
                    assert_eq!(A::block_past(&b8, l), a.past(&ray, k), "k {k}");
                }
            }
        }
        fn one<K: Kernel<S>, const S: usize>(seed: u64, seen: &mut [usize; 2]) {
            let mut rng = crate::test_rng::Lcg(seed);
            let mut c = |s: f64| rng.centred(s);
            let sz = [7, 9, 6];
            let data = alloc::vec![0.0f32; 7 * 9 * 6];
            let itow = Affine4::from_columns(
                [0.7 + c(0.2), c(0.3), c(0.3)],
                [c(0.3), 0.9 + c(0.2), c(0.3)],
                [c(0.3), c(0.3), 1.1 + c(0.2)],
                [c(400.0), c(400.0), c(4.0)],
            );
            let vol = Volume::new(&data, sz, itow).unwrap();
            let at = itow.point([3.5 + c(6.0), 4.5 + c(6.0), 3.0 + c(6.0)]);
            let from = [at[0] + 12.0 + c(6.0), at[1] + c(20.0), at[2] + c(20.0)];
            let spec = CameraSpec::looking_at(from, at)
                .clip(-8.0 + c(4.0), 3.0 + c(4.0))
                .fov(30.0 + c(20.0))
                .size(5, 4)
                .orthographic(c(1.0) > 0.0);
            let cam = Camera::new(spec).unwrap();
            let (sep, kend) = (0.37 + c(0.5), 40);
            for level in [SimdLevel::Baseline, SimdLevel::Avx2, SimdLevel::Avx512] {
                let simd = Simd::at_most(level);
                let rc = RefCamera::new(&cam.spec);
                let r = Reference::<f32, K, S>::new(vol, simd, &rc, sep as f32, 1.0);
                let f = F64::<f32, K, S>::new(vol, simd, &cam, sep, 1.0, &[]);
                for (hi, vi) in [(0, 0), (2, 1), (4, 3), (1, 3)] {
                    each(&r, hi, vi, kend, seen);
                    each(&f, hi, vi, kend, seen);
                }
            }
        }
        let mut seen = [0usize; 2];
        for seed in 0..12 {
            one::<Tent, 2>(seed, &mut seen);
            one::<Bspln2, 3>(seed, &mut seen);
        }
        // Inside and outside samples both occur often.
        assert!(seen[0] > 10_000 && seen[1] > 10_000, "{seen:?}");
    }

    /// Starting from any estimate (far off, on either side, at the ends, not finite) the
    /// search finds what plain bisection finds, for every threshold of a monotone
    /// predicate.
    #[test]
    fn first_true_near_is_exact_from_any_estimate() {
        for (lo, hi) in [(0u32, 0u32), (0, 1), (0, 7), (1, 40), (3, 300)] {
            for t in lo..=hi + 1 {
                let pred = |k: u32| k >= t;
                let want = first_true(lo, hi, pred);
                let guesses = (0..=hi + 3).map(|g| g as f64 - 1.5).chain([
                    f64::NAN,
                    f64::INFINITY,
                    f64::NEG_INFINITY,
                    -1e300,
                    1e300,
                ]);
                for g in guesses {
                    assert_eq!(
                        first_true_near(lo, hi, g, pred),
                        want,
                        "[{lo}, {hi}) t {t} g {g}"
                    );
                    let g = g.round();
                    assert_eq!(
                        first_true_near(lo, hi, g, pred),
                        want,
                        "[{lo}, {hi}) t {t} g {g}"
                    );
                }
            }
        }
    }
}
