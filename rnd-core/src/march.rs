//! The one ray-marching loop, generic over the arithmetic (`arith`): the
//! ray's span, batching, empty-space skipping, probing, shading, blending in order,
//! early ray termination and the `-db` trace are written here once.
//!
//! Samples go through the convolution one at a time ([`Loop::OneSample`]: every sample
//! from the near plane, outside ones included) or in batches ([`Loop::Batched`]: only
//! the stretch of the ray that can be inside, 8 or 16 samples convolved together).
//! Both give the same bits: a batch is probed and blended in sample order, and what a
//! batch skips changes nothing (outside samples are not counted by the probes that
//! batch; a sample of zero opacity under `over` changes only the count).

use alloc::vec::Vec;
use core::cell::{Cell, RefCell};

use crate::arith::{gmag, Arith, BatchTask, Line, Memo};
use crate::blend::{Accum, Blend, Kept, MAX_CHANNELS};
use crate::brick::{Own, Partial};
use crate::classify::Quantity;
use crate::convo::{ConvoSample, SecondOrder};
use crate::light::{blinn_phong, blinn_phong_lanes};
use crate::probe::Probe;
use crate::render::RenderSpec;
use crate::skip::{SkipGrid, SkipKind, FINE, FINE_EMPTY};

/// Which loop casts a ray (the same bits either way).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Loop {
    /// Every sample from the near plane, one at a time.
    OneSample,
    /// The stretch that can be inside, in batches.
    Batched,
}

/// Everything known about one sample, for `-db` tracing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampleInfo {
    /// Sample number along the ray.
    pub k: u32,
    /// View-space position.
    pub pos_v: [f64; 3],
    /// World-space position.
    pub pos_w: [f64; 3],
    /// The convolution (index position, inside, value, gradients).
    pub convo: ConvoSample,
    /// The probe's value at this sample.
    pub probe: [f32; MAX_CHANNELS],
    /// Whether this sample was blended.
    pub counted: bool,
    /// The running blend after this sample.
    pub accum: Accum,
}

/// A callback that sees every sample of a ray.
pub type Trace<'t> = Option<&'t mut dyn FnMut(&SampleInfo)>;

/// The loop over one volume in arithmetic `A`.
pub(crate) struct March<'s, 'a, A: Arith> {
    pub spec: &'s RenderSpec<'a>,
    pub a: A,
    pub skip: Option<&'s SkipGrid>,
    /// Sizes of the samples held and the grid index of the first (a
    /// [`crate::volume::Volume::region`]), and the kernel's support and first support
    /// offset.
    pub sizes: [usize; 3],
    pub org: [i64; 3],
    pub support: usize,
    pub lo: i32,
    /// Under `max` with bounds: the sample number where the last ray cast found its
    /// maximum (a good first guess for the next ray's; results never depend on it).
    pub hint: Cell<Option<u32>>,
    /// Consecutive rays on which bounds skipped nothing, and the rays left to cast
    /// before the next one looks at them: past [`IDLE`], a ray looks only after a wait
    /// that doubles with each fruitless look, from 16 rays up to [`WAIT_MAX`] (where
    /// they never help, their cost is saved; results never depend on it).
    pub idle: Cell<u32>,
    pub wait: Cell<u32>,
    /// Under `median`: the lists of samples, reused from ray to ray.
    pub kept: Cell<Kept>,
    /// For a brick of a sort-last render: the stretch of each ray it casts; set when a
    /// ray's positions could lie too far from the exact line for its ghost layers.
    pub own: Option<Own>,
    pub imprecise: Cell<bool>,
    /// Pixels `[h0, h1] × [v0, v1]` outside which no ray meets the volume's samples'
    /// supports, in either arithmetic ([`RenderSpec::reach`]); None: any may.
    pub reach: Option<[f64; 4]>,
    /// The windows of the rows being cast ([`March::aim_rows`]).
    pub win: RefCell<Option<Windows<'s>>>,
}

/// Where a ray's result goes: the pixel, or (for a brick) the partial blend and, under
/// `median`, the samples blended (channel by channel).
#[cfg_attr(test, allow(dead_code))] // (bricks render outside the unit tests)
pub(crate) enum Out<'o> {
    Pixel(&'o mut [f32]),
    Part(&'o mut Partial, &'o mut alloc::vec::Vec<f32>),
}

/// Whether the ray through pixel (hi, vi) may meet the volume: inside the rectangle
/// `reach` ([`March::reach`]), or none is known.
#[inline(always)]
pub(crate) fn meets(reach: Option<[f64; 4]>, hi: u32, vi: u32) -> bool {
    reach.is_none_or(|r| {
        let (h, v) = (f64::from(hi), f64::from(vi));
        (h >= r[0]) & (h <= r[1]) & (v >= r[2]) & (v <= r[3])
    })
}

/// Rays without a skip after which bounds are looked at only now and then.
const IDLE: u32 = 8;
/// The longest wait, in rays, between two looks at bounds that skip nothing.
const WAIT_MAX: u32 = 256;

/// One ray's running state.
struct State<'t> {
    acc: Accum,
    transp: f32,
    memo: Memo,
    trace: Trace<'t>,
    /// Under `max` of `v` with bounds: a value that one of the ray's samples reaches,
    /// so a sample bounded strictly below it cannot be the maximum (−∞ under `max` of
    /// `gm`, and without bounds); the number of samples
    /// counted unconvolved (added to the count at the end, so that the first blended
    /// sample still starts the maximum); the sample number of the running maximum.
    floor: f32,
    unseen: u32,
    best: Option<u32>,
    /// Under `median`: the ray's samples.
    kept: Option<Kept>,
    /// For a brick: the stretch of the ray it casts.
    win: (u32, u32),
}

impl State<'_> {
    /// Under `max` with bounds: whether a bound `b` leaves its samples unconvolved (below
    /// the floor, or by the running maximum).
    #[inline(always)]
    fn under(&self, b: f32) -> bool {
        b < self.floor || self.acc.below_max(b)
    }
}

/// A ray's index-space line for jumps over boxes: `s` counts support starts (plus the
/// kernel's first offset and, for odd supports, one half), `rd` is 1/`d`, and `e` bounds
/// how far a sample's count lies from `s + k d`; `h` is `s` counted from the first
/// sample held, and `end` one past the last support start inside the samples held.
#[derive(Clone, Copy)]
struct Jumps {
    s: [f64; 3],
    d: [f64; 3],
    rd: [f64; 3],
    e: [f64; 3],
    h: [f64; 3],
    end: [f64; 3],
}

impl Jumps {
    /// The samples in `0 .. kend` outside which none can have its support start among
    /// the samples held (a few more than do: these are placed and checked); None when
    /// none can.
    #[inline(always)]
    fn may_be_inside(&self, kend: u32) -> Option<(u32, u32)> {
        let (mut k0, mut k1) = (0.0f64, kend as f64);
        for a in 0..3 {
            // A support start's count lies within e of x = h + k d; held: in [0, end).
            let (h, d, e) = (self.h[a], self.d[a], self.e[a]);
            if d == 0.0 {
                if !(h + e >= 0.0 && h - e < self.end[a]) {
                    return None;
                }
                continue;
            }
            let (t0, t1) = ((-e - h) * self.rd[a], (self.end[a] + e - h) * self.rd[a]);
            k0 = k0.max(t0.min(t1) - 1.0);
            k1 = k1.min(t0.max(t1) + 2.0);
        }
        // (NaN bounds, from a line beyond f64, leave every sample.)
        let (k0, k1) = (k0.max(0.0) as u32, k1.min(kend as f64) as u32);
        (k0 < k1).then_some((k0, k1))
    }

    /// Whether sample j's exact position lies within `lim` on every axis.
    #[inline(always)]
    fn member(&self, lim: &[[f64; 2]; 3], j: u32) -> bool {
        let mut ok = true;
        for a in 0..3 {
            let x = self.s[a] + j as f64 * self.d[a];
            ok &= (lim[a][0] <= x) & (x <= lim[a][1]);
        }
        ok
    }
}

/// Per pixel of a band of image rows, the samples outside which none can have its
/// support start in a fine block of an opacity grid that is not empty, as bits (one per
/// `c` samples, `wpp` words a pixel, word i of every pixel of the band in plane i).
/// Made from a model of the rays' lines (pixel (hi, vi): `h + hi ph + vi pv + k d`,
/// which orthographic views follow), each block's corners taken back to pixels and
/// samples ([`Aim::windows`]); a ray uses its window only when its own line lies within
/// [`SLACK`] of the model's.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Windows<'m> {
    /// The model and the bits' layout.
    aim: &'m Aim,
    /// The band's rows, `[first, end)`.
    rows: [u32; 2],
    bits: Vec<u64>,
}

/// What each band of a render makes its [`Windows`] from: the model of the rays' lines,
/// the range of (hi, vi, k) a block's corners span about its first support start, and
/// the opacity grid's fine blocks that are not empty, by the first image row they may
/// reach ([`March::aim`]). Made once a render: the model first ([`March::aim_model`]),
/// then the blocks placed part by part ([`Aim::firsts`], by the runs that build the
/// grid, on their threads) and sorted ([`Aim::sorted`]); the windows band by band, on
/// the band's thread, in a small buffer (a whole image's windows took a millisecond or
/// more of fresh memory on one thread, bench/RESULTS.md run 59).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Aim {
    size: [u32; 2],
    h: [f64; 3],
    ph: [f64; 3],
    pv: [f64; 3],
    d: [f64; 3],
    /// Rows of the inverse of the columns (ph, pv, d): (hi, vi, k) of a point.
    inv: [[f64; 3]; 3],
    /// The (hi, vi, k) range of a block's corners (widened by 2 × SLACK) about those of
    /// its first support start.
    clo: [f64; 3],
    chi: [f64; 3],
    kend: u32,
    c: u32,
    wpp: usize,
    /// Fine blocks per axis of the grid.
    nf: [usize; 3],
    /// The fine blocks that are not empty and reach some pixel (their index in the
    /// grid), ordered by the first image row they reach.
    blocks: Vec<u32>,
    /// For each image row r (and one past the last), where in `blocks` those that
    /// first reach row r or later start.
    starts: Vec<u32>,
    /// The most rows past its first that a block reaches.
    span: u32,
}

/// How far a ray's line, widened by its error, may lie from the model of [`Windows`]
/// (per axis, in support starts); blocks are widened by twice as much.
const SLACK: f64 = 0.25;

/// At most this many words of [`Windows`] bits a pixel, and in all.
const WINDOW_WORDS: usize = 4;
const WINDOWS_MAX: usize = 1 << 23;

impl Windows<'_> {
    /// The window of pixel (hi, vi) (its words), when its line `jl` follows the model.
    #[inline(always)]
    fn of(&self, jl: &Jumps, hi: u32, vi: u32) -> Option<[u64; WINDOW_WORDS]> {
        let ([r0, r1], m) = (self.rows, self.aim);
        if hi >= m.size[0] || !(r0..r1).contains(&vi) || jl.d != m.d {
            return None;
        }
        for a in 0..3 {
            let at = m.h[a] + hi as f64 * m.ph[a] + vi as f64 * m.pv[a];
            if !((jl.h[a] - at).abs() + jl.e[a] <= SLACK) {
                return None;
            }
        }
        let (p, n) = (
            (hi + m.size[0] * (vi - r0)) as usize,
            m.size[0] as usize * (r1 - r0) as usize,
        );
        let mut w = [0; WINDOW_WORDS];
        for (i, x) in w.iter_mut().enumerate().take(m.wpp) {
            *x = *self.bits.get(i * n + p)?;
        }
        Some(w)
    }

    /// The stretches of samples in `ks` that a pixel's words `w` mark, in order.
    #[inline(always)]
    fn runs(&self, w: [u64; WINDOW_WORDS], ks: (u32, u32)) -> impl Iterator<Item = (u32, u32)> {
        let c = self.aim.c;
        let end = ks.1.div_ceil(c).min(self.aim.wpp as u32 * 64);
        let mut b = ks.0 / c;
        core::iter::from_fn(move || {
            let s = next_bit(&w, b, true, end)?;
            let e = next_bit(&w, s, false, end).unwrap_or(end);
            b = e;
            Some(((s * c).max(ks.0), (e * c).min(ks.1)))
        })
    }
}

/// The first bit of `w` from `from` (before `end`) that is `set`.
#[inline(always)]
fn next_bit(w: &[u64], from: u32, set: bool, end: u32) -> Option<u32> {
    let mut i = from;
    while i < end {
        let wi = (i / 64) as usize;
        let x = if set { w[wi] } else { !w[wi] } >> (i % 64);
        if x != 0 {
            let j = i + x.trailing_zeros();
            return (j < end).then_some(j);
        }
        i = (wi as u32 + 1) * 64;
    }
    None
}

/// A walk along a ray's exact line ([`Jumps`]) through the fine blocks of an opacity
/// grid, by sample number: per axis, whether it is known, the block that the support
/// starts of the samples from the last one looked at surely lie in (and its first
/// support start), and the first sample after them whose does not surely.
#[derive(Default)]
struct Walk {
    known: [bool; 3],
    blk: [usize; 3],
    face: [f64; 3],
    next: [u32; 3],
}

impl Walk {
    /// The stretch from sample k (before `k1`) whose support starts surely lie in one
    /// fine block: its end and the block's flags; None when sample k's is not sure.
    #[inline(always)]
    fn step(&mut self, jl: &Jumps, sk: &SkipGrid, k: u32, k1: u32) -> Option<(u32, u8)> {
        for a in 0..3 {
            if !self.known[a] || self.next[a] <= k {
                // Where the line just left a block, the next block along it first.
                let near = self.known[a] && self.next[a] == k;
                self.known[a] = (near && self.cross(jl, a, k, k1)) || self.axis(jl, a, k, k1);
                if !self.known[a] {
                    return None;
                }
            }
        }
        let end = self.next[0].min(self.next[1]).min(self.next[2]);
        Some((end, sk.fine_flags(self.blk)))
    }

    /// On axis `a`: the fine block that sample k's support start surely lies in, and
    /// the first later sample (at most `k1`) whose does not surely; false when sample
    /// k's count lies within the line's error of a block's face or of the ends of the
    /// support starts held.
    #[inline(always)]
    fn axis(&mut self, jl: &Jumps, a: usize, k: u32, k1: u32) -> bool {
        // (The block of the count's lowest value; `sure_to` checks that the whole
        // widened count lies in it and before the end.)
        let x0 = jl.h[a] + k as f64 * jl.d[a] - jl.e[a];
        if !(x0 >= 0.0 && x0 < jl.end[a]) {
            return false;
        }
        let blk = x0 as i64 as usize / FINE;
        self.blk[a] = blk;
        self.face[a] = (blk * FINE) as f64;
        self.sure_to(jl, a, k, k1)
    }

    /// [`Walk::axis`] where sample k is the first after the block of axis `a`: the
    /// next block along the line, when k surely lies in it.
    #[inline(always)]
    fn cross(&mut self, jl: &Jumps, a: usize, k: u32, k1: u32) -> bool {
        let up = jl.d[a] > 0.0;
        if !up && self.blk[a] == 0 {
            return false;
        }
        let f = FINE as f64;
        self.blk[a] = if up { self.blk[a] + 1 } else { self.blk[a] - 1 };
        self.face[a] += if up { f } else { -f };
        self.sure_to(jl, a, k, k1)
    }

    /// Whether sample k surely lies in the block of axis `a` (first support start
    /// `face`), and if so the first later sample that does not surely (into `next`).
    #[inline(always)]
    fn sure_to(&mut self, jl: &Jumps, a: usize, k: u32, k1: u32) -> bool {
        let (h, d, e) = (jl.h[a], jl.d[a], jl.e[a]);
        // Sample j is surely in the block when lo <= x_j < hi.
        let lo = self.face[a] + e;
        let hi = (self.face[a] + FINE as f64).min(jl.end[a]) - e;
        let x = h + k as f64 * d;
        if !(lo <= x && x < hi) {
            return false;
        }
        // Up to t along the line; the first sample past t, checked in the samples' own
        // arithmetic (the line is straight, so if samples k and n − 1 are sure, every
        // one between is).
        let t = if d > 0.0 {
            (hi - h) * jl.rd[a]
        } else if d < 0.0 {
            (lo - h) * jl.rd[a]
        } else {
            f64::INFINITY
        };
        let mut n = if t < k1 as f64 {
            (t as u32).max(k) + 1
        } else {
            k1
        };
        while n > k + 1 && {
            let xn = h + (n - 1) as f64 * d;
            !(lo <= xn && xn < hi)
        } {
            n -= 1;
        }
        self.next[a] = n;
        true
    }
}

/// What the probe of a convolved sample may know besides its sums: the principal
/// curvatures (used by curvature LUT axes only), the LUT entry and opacity, the world
/// gradient, and the lit colour (before depth cueing), when the caller already has them
/// (the same bits as the probe would find).
#[derive(Clone, Copy, Default)]
struct Known {
    curv: [f64; 2],
    hit: Option<(usize, f32)>,
    grad: Option<[f32; 3]>,
    lit: Option<[f32; 3]>,
}

/// Samples placed for the convolution, in ray order (how many are waiting is a local
/// of the ray loop, so that it stays in a register).
struct Batch<F, const N: usize> {
    n: [[i64; 3]; N],
    f: [F; N],
    k: [u32; N],
}

impl<F: Default + Copy, const N: usize> Batch<F, N> {
    /// An empty batch.
    #[inline(always)]
    fn new() -> Self {
        Batch {
            n: [[0; 3]; N],
            f: [F::default(); N],
            k: [0; N],
        }
    }
}

/// A ray for the batched loop, cast with the strategy's batch size.
struct Batched<'m, 's, 'a, 'o, 't, A: Arith> {
    march: &'m March<'s, 'a, A>,
    hi: u32,
    vi: u32,
    out: Out<'o>,
    trace: Trace<'t>,
}

impl<A: Arith> BatchTask for Batched<'_, '_, '_, '_, '_, A> {
    type Output = ();
    #[inline(always)]
    fn run<const N: usize>(self) {
        let Batched {
            march,
            hi,
            vi,
            out,
            trace,
        } = self;
        crate::simd::wide(march.spec.simd, {
            #[inline(always)]
            || {
                if march.spec.need_grad {
                    march.run::<true, N, 8>(hi, vi, out, trace)
                } else {
                    march.run::<false, N, 8>(hi, vi, out, trace)
                }
            }
        })
    }
}

impl<'s, 'a, A: Arith> March<'s, 'a, A> {
    /// Casts the ray through pixel (hi, vi) into `out` (the probe's channels, or the
    /// partial blend of the brick's stretch).
    pub fn cast(&self, hi: u32, vi: u32, out: Out<'_>, mode: Loop, trace: Trace<'_>) {
        match (mode, self.spec.need_grad) {
            (Loop::OneSample, true) => self.run::<true, 1, 1>(hi, vi, out, trace),
            (Loop::OneSample, false) => self.run::<false, 1, 1>(hi, vi, out, trace),
            (Loop::Batched, _) => A::batched(Batched {
                march: self,
                hi,
                vi,
                out,
                trace,
            }),
        }
    }

    /// Casts one ray: gradients with `G`, batches of `N` samples, placed `P` at a time
    /// (a skip or a jump leaves the rest of a placed block unused: smaller blocks than
    /// batches waste less).
    #[inline(always)]
    fn run<const G: bool, const N: usize, const P: usize>(
        &self,
        hi: u32,
        vi: u32,
        mut out: Out<'_>,
        trace: Trace<'_>,
    ) {
        let out = &mut out;
        let sp = self.spec;
        let p = &sp.params;
        let mut st = State {
            acc: Accum::new(p.blend, p.probe.length()),
            transp: 1.0,
            memo: None,
            trace,
            floor: f32::NEG_INFINITY,
            unseen: 0,
            best: None,
            kept: p.blend.keeps_samples().then(|| {
                let mut k = self.kept.take();
                k.clear();
                k
            }),
            win: (0, 0),
        };
        let over = p.blend == Blend::Over;
        let everywhere = p.probe.everywhere();
        // A ray that misses the volume's box has nothing inside: the result of no
        // sample, without the ray's geometry (unless a trace sees its samples outside).
        if st.trace.is_none() && !meets(self.bare_reach(), hi, vi) {
            return self.finish(&mut st, out);
        }
        let ray = self.a.ray(hi, vi);
        let kend = self.kend();
        // A brick casts its stretch of the ray.
        let (w0, w1) = match &self.own {
            Some(own) => {
                st.win = self.window(own, &ray, kend);
                st.win
            }
            None => (0, kend),
        };
        // Under `over` with the opacity grid, untraced and not a brick's, the walk from
        // the samples that the exact line shows may be inside (no span needed).
        // (The kind first: a `max` grid's rays take their line from the span.)
        if let (Some(g), false, true, None) = (
            self.skip.filter(|g| g.kind() == SkipKind::Opacity),
            st.trace.is_some(),
            N > 1 && !everywhere,
            &self.own,
        ) {
            if let Some(l) = self.a.line(&ray, kend) {
                let jl = self.jumps(&l, kend);
                if let Some(ks) = jl.may_be_inside(kend) {
                    // Outside its window a sample is outside or transparent, which only
                    // the count sees, and only whether it is zero: the window first, the
                    // rest only while nothing is counted.
                    let win = self.win.borrow();
                    match win.as_ref().and_then(|w| Some((w, w.of(&jl, hi, vi)?))) {
                        Some((w, px)) => {
                            let b = &mut Batch::<A::Frac, N>::new();
                            let mut m = 0;
                            for run in w.runs(px, ks) {
                                if self.place_run::<G, N, P>(&ray, g, run, &mut st, b, &mut m) {
                                    break;
                                }
                            }
                            // (None wait after early termination; some may when a
                            // sample is past the far plane.)
                            self.flush::<G, N>(&ray, &mut st, b, m);
                            if st.acc.count == 0 {
                                self.walk::<G, N, P>(&ray, g, &jl, ks, &mut st, true);
                            }
                        }
                        None => self.walk::<G, N, P>(&ray, g, &jl, ks, &mut st, false),
                    }
                }
                return self.finish(&mut st, out);
            }
        }
        // With an exact span every sample of [k0, k1) is inside and before the far plane.
        let ((k0, k1, exact), whole_line) = if N > 1 && !everywhere {
            match self.a.span(&ray, kend) {
                (Some(s), l) => (s, l),
                (None, _) => return self.finish(&mut st, out),
            }
        } else {
            ((0, kend, false), None)
        };
        let (k0, k1) = (k0.max(w0), k1.min(w1));
        if k0 >= k1 {
            return self.finish(&mut st, out);
        }
        let tracing = st.trace.is_some();
        let (skip, below) = match self.skip {
            Some(g) if g.kind() == SkipKind::Opacity => (Some(g), None),
            // A trace sees every sample's value.
            Some(g) if !tracing && self.look() => (None, Some(g)),
            _ => (None, None),
        };
        let line = match skip.or(below) {
            // (The line over all samples holds for those before k1.)
            Some(_) if !tracing => whole_line
                .or_else(|| self.a.line(&ray, k1))
                .map(|l| self.jumps(&l, k1)),
            _ => None,
        };
        // Blocks of P samples to add to the batch whole when all are inside and before
        // the far plane (nothing to skip or trace), and runs of N: positions computed
        // alongside the sums (the strategy checks that they are inside).
        let plain = N > 1 && !everywhere && !tracing && skip.is_none();
        let whole = plain && below.is_none();
        // Under `max` with bounds, runs are bounded whole, from the exact line.
        let runs = plain && !over && !sp.second && (below.is_none() || line.is_some());
        // Runs of a one-channel probe are reduced in the strategy's own layout.
        let gm = p.probe == Probe::GradMag;
        let scalar_runs = runs && (p.probe == Probe::Value || (gm && G));
        // (Not for `gm`: its one sample's gradient costs more than the floor saves.
        // Measured, CT 256² bspln3 gradient MIP, render phase: 0.0623 s with it, 0.0607 s
        // without; tent 0.0364 s both.)
        if below.is_some() && !gm {
            st.floor = self.floor::<G>(&ray, self.hint.get(), k0, k1);
        }
        let mut b = Batch::<A::Frac, N>::new();
        if everywhere {
            for kk in k0..k1 {
                if (kk > 0 && self.a.past(&ray, kk)) || self.everywhere(&ray, kk, &mut st) {
                    break;
                }
            }
            return self.finish(&mut st, out);
        }
        // Under `over` with the opacity grid, a walk through its fine blocks.
        if let (Some(sk), Some(l)) = (skip, &line) {
            self.walk::<G, N, P>(&ray, sk, l, (k0, k1), &mut st, false);
            return self.finish(&mut st, out);
        }
        let mut m = 0usize;
        let mut k = k0;
        'ray: while k < k1 {
            if scalar_runs && m == 0 && k1 - k >= N as u32 {
                // Under `max`: a run whose samples are all inside, before the far plane
                // and bounded below the floor or the running maximum is counted
                // unconvolved.
                if let (Some(g), Some(l)) = (below, &line) {
                    let j = k + N as u32 - 1;
                    if self.run_under(g, l, k, j, |b| st.under(b)) && !self.a.past(&ray, j) {
                        st.unseen += N as u32;
                        k += N as u32;
                        continue;
                    }
                }
                // Two runs summed side by side where both need their sums: the next run
                // too, unless the bounds already leave it unconvolved. (Summing a run
                // that the first run's maximum would have left unconvolved changes no
                // bit: its values are all below that maximum, or the floor.)
                if k1 - k >= 2 * N as u32 && self.a.pairs_runs() {
                    let next_under = match (below, &line) {
                        (Some(g), Some(l)) => {
                            let (k, j) = (k + N as u32, k + 2 * N as u32 - 1);
                            self.run_under(g, l, k, j, |b| st.under(b))
                        }
                        _ => false,
                    };
                    let mut xs = [[0.0f32; N]; 2];
                    if !next_under && self.a.convolve_run_pair::<G, N>(&ray, k, gm, &mut xs) {
                        for (r, xs) in xs.iter().enumerate() {
                            let k = k + (r * N) as u32;
                            let ks = core::array::from_fn(|i| k + i as u32);
                            self.blend_scalars::<N>(&mut st, &ks, xs);
                        }
                        k += 2 * N as u32;
                        continue;
                    }
                }
                let mut xs = [0.0f32; N];
                if self
                    .a
                    .convolve_run_scalars::<G, N>(&ray, k, exact, gm, &mut xs)
                {
                    let ks = core::array::from_fn(|i| k + i as u32);
                    self.blend_scalars::<N>(&mut st, &ks, &xs);
                    k += N as u32;
                    continue;
                }
            } else if runs && m == 0 && k1 - k >= N as u32 {
                let mut res = [[0.0f32; 4]; N];
                if self.a.convolve_run::<G, N>(&ray, k, exact, &mut res) {
                    let ks = core::array::from_fn(|i| k + i as u32);
                    if self.blend_run::<G, N>(&ray, &mut st, &ks, &res) {
                        return self.finish(&mut st, out);
                    }
                    k += N as u32;
                    continue;
                }
            }
            // The next samples' placements, then each in order.
            let cnt = (k1 - k).min(P as u32);
            let pb = self.a.place_block::<P>(&ray, k, exact && cnt == P as u32);
            // A whole block inside and before the far plane, with nothing to skip or
            // trace, joins the batch, in order. Leading samples outside (where the ray
            // enters) count for nothing: the block starts again after them.
            if whole && m + P <= N && cnt == P as u32 && !(0..P).any(|l| A::block_past(&pb, l)) {
                let (mut all, mut first) = (true, None);
                for l in 0..P {
                    match A::block_at(&pb, l) {
                        Some((n, f)) => {
                            (b.n[m + l], b.f[m + l], b.k[m + l]) = (n, f, k + l as u32);
                            first = first.or(Some(l as u32));
                        }
                        None => all = false,
                    }
                }
                if all {
                    m += P;
                    if m == N && self.flush::<G, N>(&ray, &mut st, &mut b, core::mem::take(&mut m))
                    {
                        return self.finish(&mut st, out);
                    }
                    k += P as u32;
                    continue;
                }
                if let Some(j @ 1..) = first {
                    k += j;
                    continue;
                }
            }
            for (l, kk) in (k..k + cnt).enumerate() {
                if kk > 0 && A::block_past(&pb, l) {
                    break 'ray;
                }
                let Some((n, f)) = A::block_at(&pb, l) else {
                    if tracing {
                        if self.flush::<G, N>(&ray, &mut st, &mut b, core::mem::take(&mut m)) {
                            return self.finish(&mut st, out);
                        }
                        self.emit(&ray, kk, &mut st, None, [0.0; MAX_CHANNELS], false);
                    }
                    continue;
                };
                if let Some(g) = below {
                    // Under `max`: a sample whose block bounds it below the floor, or by
                    // the running maximum (which only grows while a batch waits), is
                    // counted unconvolved, and with its coarse block's bound, every
                    // sample up to the box's end.
                    if st.under(g.bound_at(n)) {
                        if let (Some(l), true) = (line, st.under(g.coarse_bound_at(n))) {
                            let j = self.box_run_end(&l, SkipGrid::coarse_box(n), kk, k1);
                            if j > kk + 1 && !self.a.past(&ray, j) {
                                st.unseen += j - kk + 1;
                                k = j + 1;
                                continue 'ray;
                            }
                        }
                        st.unseen += 1;
                        continue;
                    }
                }
                if let Some(sk) = skip {
                    if sk.empty_at(n) {
                        // Inside with opacity 0: blending changes only the count (the
                        // walk takes these rays when they have a line).
                        if tracing {
                            if self.flush::<G, N>(&ray, &mut st, &mut b, core::mem::take(&mut m)) {
                                return self.finish(&mut st, out);
                            }
                            A::blend(&mut st.acc, &mut st.transp, &[0.0; MAX_CHANNELS]);
                            self.emit(&ray, kk, &mut st, Some([0.0; 4]), [0.0; MAX_CHANNELS], true);
                            continue;
                        }
                        st.acc.add_transparent(1);
                        continue;
                    }
                }
                if m < N {
                    (b.n[m], b.f[m], b.k[m]) = (n, f, kk);
                }
                m += 1;
                if m == N && self.flush::<G, N>(&ray, &mut st, &mut b, core::mem::take(&mut m)) {
                    return self.finish(&mut st, out);
                }
            }
            k += cnt;
            // Under `max` with bounds, the samples waiting go now, so that the next
            // samples can be a run, bounded whole (where the ray enters, a block of
            // samples one at a time would otherwise go on until a batch is full).
            if runs
                && below.is_some()
                && self.flush::<G, N>(&ray, &mut st, &mut b, core::mem::take(&mut m))
            {
                return self.finish(&mut st, out);
            }
        }
        self.flush::<G, N>(&ray, &mut st, &mut b, core::mem::take(&mut m));
        if below.is_some() {
            self.hint.set(st.best);
            let idle = if st.unseen == 0 {
                self.idle.get() + 1
            } else {
                0
            };
            self.idle.set(idle);
            if idle >= IDLE {
                self.wait.set((16 << (idle - IDLE).min(4)).min(WAIT_MAX));
            }
            st.acc.count += st.unseen;
        }
        self.finish(&mut st, out);
    }

    /// [`March::reach`] where a ray outside it needs no casting: its result is that of
    /// no sample, the same for every such ray (not for a probe that sees samples
    /// outside, nor a brick's stretch); None otherwise.
    pub(crate) fn bare_reach(&self) -> Option<[f64; 4]> {
        self.reach
            .filter(|_| !self.spec.params.probe.everywhere() && self.own.is_none())
    }

    /// One past the last sample a ray casts (sample 0 alone when the spec samples once:
    /// `sample_once`, or near and far planes that meet).
    #[inline(always)]
    fn kend(&self) -> u32 {
        if self.spec.once {
            1
        } else {
            self.spec.kmax + 1
        }
    }

    /// Whether this ray looks at the `max` bounds (see [`March::idle`]).
    #[inline(always)]
    fn look(&self) -> bool {
        if self.idle.get() < IDLE {
            return true;
        }
        let w = self.wait.get();
        self.wait.set(w.saturating_sub(1));
        w == 0
    }

    /// The ray's pixel (or partial) into `out`; the median's lists go back for the next
    /// ray.
    #[inline(always)]
    fn finish(&self, st: &mut State<'_>, out: &mut Out<'_>) {
        match out {
            Out::Pixel(px) => st
                .acc
                .finish(self.spec.params.outside, st.kept.as_mut(), px),
            Out::Part(part, samples) => {
                **part = Partial {
                    acc: st.acc,
                    transp: st.transp,
                    first: st.win.0,
                    end: st.win.1,
                    time: 0.0,
                };
                samples.clear();
                if let Some(kept) = &st.kept {
                    for c in 0..st.acc.len {
                        samples.extend_from_slice(kept.channel(c));
                    }
                }
            }
        }
        if let Some(kept) = st.kept.take() {
            self.kept.set(kept);
        }
    }

    /// The stretch of samples `0 .. kend` of `ray` that `own` casts (see
    /// [`crate::brick`]): from the strategy's exact index-space line; a ray without one,
    /// or whose positions may lie half a voxel or more from it, marks the render
    /// imprecise (its ghost layers might not hold what the samples reach).
    #[inline(never)]
    fn window(&self, own: &Own, ray: &A::Ray, kend: u32) -> (u32, u32) {
        match self.a.line(ray, kend) {
            Some(l) if l.err.iter().all(|&e| e < 0.5) => own.window(l.s, l.d, kend),
            _ => {
                self.imprecise.set(true);
                (0, 0)
            }
        }
    }

    /// Blends one counted sample's probe `pr` (the median also keeps it).
    #[inline(always)]
    fn add(&self, st: &mut State<'_>, pr: &[f32; MAX_CHANNELS]) {
        A::blend(&mut st.acc, &mut st.transp, pr);
        if let Some(kept) = &mut st.kept {
            kept.push(pr, st.acc.len);
        }
    }

    /// The value of the maximized quantity (`v` or `gm`) at sample `k` of the ray, when
    /// it is one of the ray's blended samples in `[k0, k1)` and not NaN; −∞ otherwise.
    /// Convolved as the loop convolves it, so the same bits.
    fn floor<const G: bool>(&self, ray: &A::Ray, k: Option<u32>, k0: u32, k1: u32) -> f32 {
        let Some(k) = k.filter(|&k| k0 <= k && k < k1 && !(k > 0 && self.a.past(ray, k))) else {
            return f32::NEG_INFINITY;
        };
        let Some((n, f)) = self.a.place(ray, k) else {
            return f32::NEG_INFINITY;
        };
        let mut res = [[0.0f32; 4]; 1];
        self.a.convolve::<G, 1>(&[n], &[f], 1, &mut res);
        match self.scalars::<G, 1>(&res) {
            Some([x]) if !x.is_nan() => x,
            _ => f32::NEG_INFINITY,
        }
    }

    /// The one-channel probe (`v`, or `gm` with the gradient) of convolved sums `res`.
    #[inline(always)]
    fn scalars<const G: bool, const N: usize>(&self, res: &[[f32; 4]; N]) -> Option<[f32; N]> {
        match self.spec.params.probe {
            Probe::Value => Some(res.map(|r| r[0])),
            Probe::GradMag if G => Some(self.a.gmags(res)),
            _ => None,
        }
    }

    /// Convolves the batch's first `m` samples, then probes and blends them in order;
    /// true when the ray ends.
    #[inline(always)]
    fn flush<const G: bool, const N: usize>(
        &self,
        ray: &A::Ray,
        st: &mut State<'_>,
        b: &mut Batch<A::Frac, N>,
        m: usize,
    ) -> bool {
        m > 0 && self.flush_batch::<G, N>(ray, st, b, m)
    }

    /// [`March::flush`] of a batch that is not empty. One function, not inlined: a ray
    /// loop flushes from a score of places, and a copy of the convolution, probe and
    /// shading at each made the library's code (and build time) many times larger.
    /// A call per batch costs next to nothing; the batch is convolved, probed and blended
    /// in code compiled for the widest level the render allows (as the batched loop is;
    /// the same bits at every level).
    #[inline(never)]
    fn flush_batch<const G: bool, const N: usize>(
        &self,
        ray: &A::Ray,
        st: &mut State<'_>,
        b: &mut Batch<A::Frac, N>,
        m: usize,
    ) -> bool {
        crate::simd::wide(self.spec.simd, {
            #[inline(always)]
            || self.convolve_blend::<G, N>(ray, st, b, m)
        })
    }

    /// The body of [`March::flush_batch`].
    #[inline(always)]
    fn convolve_blend<const G: bool, const N: usize>(
        &self,
        ray: &A::Ray,
        st: &mut State<'_>,
        b: &mut Batch<A::Frac, N>,
        m: usize,
    ) -> bool {
        let sp = self.spec;
        if sp.second {
            return self.flush_second::<G, N>(ray, st, b, m);
        }
        let mut res = [[0.0f32; 4]; N];
        // Under `over` without Levoy opacity a sample's opacity depends on its value
        // alone, so the gradient is needed only where the opacity is not zero. The value
        // is the same bits with or without the gradient.
        if let (true, Some(lut)) = (G && sp.value_opacity && st.trace.is_none(), sp.lut) {
            self.a.convolve::<false, N>(&b.n, &b.f, m, &mut res);
            // The samples that are not transparent, convolved again with the gradient.
            // (Their LUT entries and opacities are kept for the probe.)
            let (mut keep, mut hit) = ([0usize; N], [(0usize, 0.0f32); N]);
            let mut nk = 0;
            for i in 0..m {
                let e = lut.index(res[i][0] as f64);
                let a = self.lut_alpha(ray, e, &mut st.memo);
                if a != 0.0 {
                    (b.n[nk], b.f[nk], b.k[nk], keep[nk]) = (b.n[i], b.f[i], b.k[i], i);
                    hit[nk] = (e, a);
                    nk += 1;
                }
            }
            if nk == 0 {
                st.acc.add_transparent(m as u32);
                return false;
            }
            self.a.convolve::<true, N>(&b.n, &b.f, nk, &mut res);
            // World gradients, and lit colours side by side.
            let mut gw = [[0.0f32; 3]; N];
            for j in 0..nk {
                gw[j] = self.a.grad_world([res[j][1], res[j][2], res[j][3]]);
            }
            let lit = (sp.params.probe == Probe::RgbaLit).then(|| {
                let (mut mat, mut g) = ([[0.0f32; N]; 3], [[0.0f32; N]; 3]);
                for j in 0..nk {
                    let e = lut.entries()[hit[j].0];
                    for c in 0..3 {
                        (mat[c][j], g[c][j]) = (e[c], gw[j][c]);
                    }
                }
                let (ph, to_eye) = (&sp.params.phong, A::to_eye(ray));
                blinn_phong_lanes(sp.simd, ph, &sp.lights, &mat, &g, to_eye, nk)
            });
            let mut j = 0;
            for i in 0..m {
                if j < nk && keep[j] == i {
                    if self.take::<G>(
                        ray,
                        st,
                        b.k[j],
                        res[j],
                        Known {
                            curv: [0.0; 2],
                            hit: Some(hit[j]),
                            grad: Some(gw[j]),
                            lit: lit.map(|c| [c[0][j], c[1][j], c[2][j]]),
                        },
                    ) {
                        return true;
                    }
                    j += 1;
                } else {
                    st.acc.add_transparent(1);
                }
            }
            return false;
        }
        self.a.convolve::<G, N>(&b.n, &b.f, m, &mut res);
        self.blend_batch::<G, N>(ray, st, &b.k, m, &res)
    }

    /// [`March::flush`] of `m` samples that need second derivatives: a second-order
    /// probe, or a colour probe whose LUT has a curvature axis.
    #[inline(never)]
    fn flush_second<const G: bool, const N: usize>(
        &self,
        ray: &A::Ray,
        st: &mut State<'_>,
        b: &Batch<A::Frac, N>,
        m: usize,
    ) -> bool {
        let sp = self.spec;
        let mut res = [[0.0f32; 4]; N];
        if sp.params.probe.is_colour() {
            // A LUT with a curvature axis: the f32 sums as for any colour probe, and the
            // principal curvatures from the f64 second-order sums.
            self.a.convolve::<G, N>(&b.n, &b.f, m, &mut res);
            for i in 0..m {
                let curv = self
                    .a
                    .second(b.n[i], b.f[i])
                    .curvatures(sp.params.curv_min_grad);
                if self.take::<G>(
                    ray,
                    st,
                    b.k[i],
                    res[i],
                    Known {
                        curv,
                        hit: None,
                        grad: None,
                        lit: None,
                    },
                ) {
                    return true;
                }
            }
            return false;
        }
        // f64 sums of the kernels' formulas at each placement (the trace also sees the
        // f32 sums the other probes use).
        let tracing = st.trace.is_some();
        if tracing {
            self.a.convolve::<G, N>(&b.n, &b.f, m, &mut res);
        }
        for i in 0..m {
            let so = self.a.second(b.n[i], b.f[i]);
            let mut pr = [0.0f32; MAX_CHANNELS];
            self.second_probe(&so, &mut pr);
            self.add(st, &pr);
            if tracing {
                self.emit(ray, b.k[i], st, Some(res[i]), pr, true);
            }
        }
        false
    }

    /// Probes and blends the first `m` convolved samples (numbers `ks`, sums `res`) in
    /// order; true when the ray ends.
    #[inline(always)]
    fn blend_batch<const G: bool, const N: usize>(
        &self,
        ray: &A::Ray,
        st: &mut State<'_>,
        ks: &[u32; N],
        m: usize,
        res: &[[f32; 4]; N],
    ) -> bool {
        let p = &self.spec.params;
        if p.blend != Blend::Over && st.trace.is_none() {
            // One channel under max/sum/mean: no early end, no colour.
            if let Some(xs) = self.scalars::<G, N>(res) {
                self.blend_scalars::<N>(st, ks, &xs[..m]);
                return false;
            }
        }
        (0..m).any(|i| self.take::<G>(ray, st, ks[i], res[i], Known::default()))
    }

    /// [`March::blend_batch`] of a whole run of `N` samples, not inlined (as
    /// [`March::flush_batch`]).
    #[inline(never)]
    fn blend_run<const G: bool, const N: usize>(
        &self,
        ray: &A::Ray,
        st: &mut State<'_>,
        ks: &[u32; N],
        res: &[[f32; 4]; N],
    ) -> bool {
        crate::simd::wide(self.spec.simd, {
            #[inline(always)]
            || self.blend_batch::<G, N>(ray, st, ks, N, res)
        })
    }

    /// Blends the one-channel probe's values `xs` of samples `ks` (max/min/sum/mean...,
    /// no trace) in order.
    #[inline(always)]
    fn blend_scalars<const N: usize>(&self, st: &mut State<'_>, ks: &[u32; N], xs: &[f32]) {
        let (had, before) = (st.acc.count > 0, st.acc.acc[0]);
        st.acc.add_scalars(xs);
        if let Some(kept) = &mut st.kept {
            kept.push_scalars(xs);
        }
        let now = st.acc.acc[0];
        if self.spec.params.blend == Blend::Max && (!had || now.to_bits() != before.to_bits()) {
            if let Some(i) = xs.iter().position(|x| x.to_bits() == now.to_bits()) {
                st.best = Some(ks[i]);
            }
        }
    }

    /// Probes and blends one convolved sample k (sums `r`, and what is `known`); true
    /// when the ray ends.
    #[inline(always)]
    fn take<const G: bool>(
        &self,
        ray: &A::Ray,
        st: &mut State<'_>,
        k: u32,
        r: [f32; 4],
        known: Known,
    ) -> bool {
        let gw = match known.grad {
            Some(g) => g,
            None if G => self.a.grad_world([r[1], r[2], r[3]]),
            None => [0.0; 3],
        };
        let mut pr = [0.0f32; MAX_CHANNELS];
        let counted = self.probe_inside(
            ray,
            k,
            [r[0], gw[0], gw[1], gw[2]],
            known,
            &mut st.memo,
            &mut pr,
        );
        if counted {
            self.add(st, &pr);
        }
        if st.trace.is_some() {
            self.emit(ray, k, st, Some(r), pr, counted);
        }
        self.opaque_end(&mut st.acc)
    }

    /// A position or inside probe at sample k (no convolution); true when the ray ends.
    fn everywhere(&self, ray: &A::Ray, k: u32, st: &mut State<'_>) -> bool {
        let pos = self.a.positions(ray, k);
        let inside = self.a.place(ray, k).is_some();
        let mut pr = [0.0f32; MAX_CHANNELS];
        match self.spec.params.probe {
            Probe::PosView => pr[..3].copy_from_slice(&pos[0].map(|x| x as f32)),
            Probe::PosWorld => pr[..3].copy_from_slice(&pos[1].map(|x| x as f32)),
            Probe::PosIndex => pr[..3].copy_from_slice(&pos[2].map(|x| x as f32)),
            _ => pr[0] = f32::from(u8::from(inside)),
        }
        self.add(st, &pr);
        if st.trace.is_some() {
            self.emit(ray, k, st, inside.then_some([0.0; 4]), pr, true);
        }
        self.opaque_end(&mut st.acc)
    }

    /// Tells the trace about sample k: `sums` are the index-space sums when inside.
    fn emit(
        &self,
        ray: &A::Ray,
        k: u32,
        st: &mut State<'_>,
        sums: Option<[f32; 4]>,
        probe: [f32; MAX_CHANNELS],
        counted: bool,
    ) {
        let [pos_v, pos_w, pos_i] = self.a.positions(ray, k);
        let r = sums.unwrap_or([0.0; 4]);
        let grad_i = [r[1], r[2], r[3]];
        let info = SampleInfo {
            k,
            pos_v,
            pos_w,
            convo: ConvoSample {
                pos_i,
                inside: sums.is_some(),
                value: r[0],
                grad_i,
                grad_w: if self.spec.need_grad && sums.is_some() {
                    self.a.grad_world(grad_i)
                } else {
                    [0.0; 3]
                },
            },
            probe,
            counted,
            accum: st.acc,
        };
        if let Some(t) = st.trace.as_deref_mut() {
            t(&info);
        }
    }

    /// The probes counted only inside (v, gv, gm, rgba, rgbalit) at sample k for value
    /// and world gradient `vg` and what is `known`; whether the sample is blended.
    #[inline(always)]
    fn probe_inside(
        &self,
        ray: &A::Ray,
        k: u32,
        vg: [f32; 4],
        Known { curv, hit, lit, .. }: Known,
        memo: &mut Memo,
        out: &mut [f32; MAX_CHANNELS],
    ) -> bool {
        let sp = self.spec;
        let p = &sp.params;
        let (v, gw) = (vg[0], [vg[1], vg[2], vg[3]]);
        match p.probe {
            Probe::Value => out[0] = v,
            Probe::GradVec => out[..3].copy_from_slice(&gw),
            Probe::GradMag => out[0] = gmag(gw),
            Probe::Rgba | Probe::RgbaLit => {
                let Some(lut) = sp.lut else { return false };
                let i = if let Some((i, _)) = hit {
                    i
                } else if sp.lut_by_value {
                    lut.index(v as f64)
                } else {
                    let gm = f64::from(gmag(gw));
                    let [a0, a1] = [0, 1].map(|a| lut.axes().get(a).map(|x| x.quantity));
                    let q = |a: Option<Quantity>| a.map_or(0.0, |q| q.of(v as f64, gm, curv));
                    lut.entry([q(a0), q(a1)])
                };
                let e = lut.entries()[i];
                let a = match (hit, sp.levoy) {
                    (Some((_, a)), _) => a,
                    (None, None) => self.lut_alpha(ray, i, memo),
                    (None, Some(lev)) => {
                        self.a
                            .correct(ray, e[3] * lev.opacity(v, gmag(gw)), None, memo)
                    }
                };
                let mut rgb = [e[0], e[1], e[2]];
                // A transparent sample is not lit (it adds nothing under `over`).
                if a != 0.0 && p.probe == Probe::RgbaLit {
                    rgb = match lit {
                        Some(c) => c,
                        None => blinn_phong(&p.phong, &sp.lights, rgb, gw, A::to_eye(ray)),
                    };
                    if sp.depth_cue {
                        let tau = self.a.tau(ray, k);
                        for c in 0..3 {
                            rgb[c] *= p.dcn[c] + tau * (p.dcf[c] - p.dcn[c]);
                        }
                    }
                }
                out[..4].copy_from_slice(&[rgb[0], rgb[1], rgb[2], a]);
            }
            _ => return false,
        }
        true
    }

    /// A second-order probe (hess k1 k2 meancurv gausscurv) of `so` into `out`.
    #[inline]
    fn second_probe(&self, so: &SecondOrder, out: &mut [f32; MAX_CHANNELS]) {
        let p = &self.spec.params;
        if p.probe == Probe::Hess {
            for (o, h) in out.iter_mut().zip(so.hessian.iter().flatten()) {
                *o = *h as f32;
            }
            return;
        }
        let [k1, k2] = so.curvatures(p.curv_min_grad);
        out[0] = match p.probe {
            Probe::K1 => k1,
            Probe::K2 => k2,
            Probe::MeanCurv => 0.5 * (k1 + k2),
            _ => k1 * k2,
        } as f32;
    }

    /// The corrected opacity of LUT entry `i` (no Levoy opacity): from the table every
    /// ray shares (orthographic cameras), else the strategy's correction.
    #[inline(always)]
    fn lut_alpha(&self, ray: &A::Ray, i: usize, memo: &mut Memo) -> f32 {
        let sp = self.spec;
        match &sp.alpha_table {
            Some((ex, t)) if *ex == A::alpha_exp(ray) => t[i],
            _ => {
                let a = sp.lut.map_or(0.0, |l| l.entries()[i][3]);
                self.a.correct(ray, a, Some(i), memo)
            }
        }
    }

    /// Early ray termination (`-a1`): under `over`, once the accumulated opacity passes
    /// alphaNear1 it is taken as 1 and the ray ends (true).
    #[inline(always)]
    fn opaque_end(&self, acc: &mut Accum) -> bool {
        let p = &self.spec.params;
        if p.blend == Blend::Over && acc.acc[3] > p.alpha_near1 {
            acc.acc[3] = 1.0;
            true
        } else {
            false
        }
    }

    /// Under `over` with the opacity grid (no trace): the samples `k0 .. k1` of the
    /// ray, in stretches from a [`Walk`] along its exact line: a stretch in an empty
    /// fine block counts at once (when its last sample is before the far plane); the
    /// other samples are placed and go one at a time, as without the walk. With
    /// `until_counted`, only until a sample is counted.
    ///
    /// Not inlined (a ray loop walks from three places); compiled for the widest level
    /// the render allows, as the batched loop is.
    #[inline(never)]
    fn walk<const G: bool, const N: usize, const P: usize>(
        &self,
        ray: &A::Ray,
        sk: &SkipGrid,
        jl: &Jumps,
        ks: (u32, u32),
        st: &mut State<'_>,
        until_counted: bool,
    ) {
        crate::simd::wide(self.spec.simd, {
            #[inline(always)]
            || self.walk_in::<G, N, P>(ray, sk, jl, ks, st, until_counted)
        })
    }

    /// The body of [`March::walk`].
    #[inline(always)]
    fn walk_in<const G: bool, const N: usize, const P: usize>(
        &self,
        ray: &A::Ray,
        sk: &SkipGrid,
        jl: &Jumps,
        (k0, k1): (u32, u32),
        st: &mut State<'_>,
        until_counted: bool,
    ) {
        let b = &mut Batch::<A::Frac, N>::new();
        let mut m = 0usize;
        let mut w = Walk::default();
        // Samples [p0, k) wait to be placed.
        let (mut p0, mut k) = (k0, k0);
        'walk: {
            while k < k1 {
                if until_counted && st.acc.count > 0 {
                    break 'walk;
                }
                let (end, flags) = w.step(jl, sk, k, k1).unwrap_or((k + 1, 0));
                if flags & FINE_EMPTY != 0 && !(end > 1 && self.a.past(ray, end - 1)) {
                    if self.place_run::<G, N, P>(ray, sk, (p0, k), st, b, &mut m) {
                        break 'walk;
                    }
                    st.acc.add_transparent(end - k);
                    p0 = end;
                } else {
                    // Whole blocks of P go at once.
                    let whole = p0 + (end - p0) / P as u32 * P as u32;
                    if self.place_run::<G, N, P>(ray, sk, (p0, whole), st, b, &mut m) {
                        break 'walk;
                    }
                    p0 = whole;
                }
                k = end;
            }
            self.place_run::<G, N, P>(ray, sk, (p0, k1), st, b, &mut m);
        }
        // (None wait after early termination; some may when a sample is past the far
        // plane.)
        self.flush::<G, N>(ray, st, b, m);
    }

    /// Places samples `from .. to`, `P` at a time, and takes them in order: a sample
    /// outside counts for nothing, one the grid marks empty is transparent, the
    /// others join the batch (`m` waiting); true when the ray ends (early termination,
    /// or a sample past the far plane: the samples waiting are then still to go).
    #[inline(always)]
    fn place_run<const G: bool, const N: usize, const P: usize>(
        &self,
        ray: &A::Ray,
        sk: &SkipGrid,
        (from, to): (u32, u32),
        st: &mut State<'_>,
        b: &mut Batch<A::Frac, N>,
        m: &mut usize,
    ) -> bool {
        let mut k = from;
        while k < to {
            let cnt = (to - k).min(P as u32);
            let pb = self.a.place_block::<P>(ray, k, false);
            for i in 0..cnt as usize {
                let kk = k + i as u32;
                if kk > 0 && A::block_past(&pb, i) {
                    return true;
                }
                let Some((n, f)) = A::block_at(&pb, i) else {
                    continue;
                };
                if sk.empty_at(n) {
                    st.acc.add_transparent(1);
                    continue;
                }
                (b.n[*m], b.f[*m], b.k[*m]) = (n, f, kk);
                *m += 1;
                if *m == N && self.flush::<G, N>(ray, st, b, core::mem::take(m)) {
                    return true;
                }
            }
            k += cnt;
        }
        false
    }

    /// A ray's `line` for [`March::box_run_end`] over samples before `k1`.
    fn jumps(&self, line: &Line, k1: u32) -> Jumps {
        let o = if self.support % 2 == 1 { 0.5 } else { 0.0 };
        // Support start floor(x + o) + LO: x + o + LO counts it.
        let s = line.s.map(|s| s + (self.lo as f64 + o));
        Jumps {
            s,
            h: core::array::from_fn(|a| s[a] - self.org[a] as f64),
            end: core::array::from_fn(|a| self.sizes[a] as f64 - self.support as f64 + 1.0),
            d: line.d,
            rd: line.d.map(|d| 1.0 / d),
            // The line's bound, and this f64 arithmetic's rounding, far inside the margin.
            e: core::array::from_fn(|a| {
                let (s, d) = (line.s[a], line.d[a]);
                line.err[a] + 1e-12 * (s.abs() + k1 as f64 * d.abs() + 3.0)
            }),
        }
    }

    /// The box of support starts (`lo`, `hi`, relative to the samples held) that samples
    /// k to j can have, when every one of them provably has its whole support among the
    /// samples held (`None` otherwise): from the exact line, widened by its error.
    #[inline(always)]
    fn run_box(&self, jl: &Jumps, k: u32, j: u32) -> Option<([i64; 3], [i64; 3])> {
        let (mut lo, mut hi) = ([0i64; 3], [0i64; 3]);
        let w = (j - k) as f64;
        for a in 0..3 {
            let (c, dw) = (jl.h[a] + k as f64 * jl.d[a], w * jl.d[a]);
            let (x0, x1) = (c + dw.min(0.0) - jl.e[a], c + dw.max(0.0) + jl.e[a]);
            if !(x0 >= 0.0 && x1 < jl.end[a]) {
                return None;
            }
            (lo[a], hi[a]) = (x0 as i64, x1 as i64);
        }
        Some((lo, hi))
    }

    /// Under `max`: whether `under` holds for the grid's bounds of every block that
    /// samples k to j can reach (see [`March::run_box`]; false when that is not known).
    #[inline(always)]
    fn run_under(
        &self,
        g: &SkipGrid,
        jl: &Jumps,
        k: u32,
        j: u32,
        under: impl FnMut(f32) -> bool,
    ) -> bool {
        self.run_box(jl, k, j)
            .is_some_and(|(lo, hi)| g.every_bound(lo, hi, under))
    }

    /// The last sample in [k, k1) up to which every sample provably has its support
    /// start in box `bx` (`[first, last]` per axis, cut to the volume's support starts),
    /// which sample k's is in; k when that cannot be shown. The strategy's positions lie
    /// within `err` of the exact line, so samples whose exact position is that far
    /// inside the box's position range are members, and the exact line is straight, so
    /// if samples k and j are, every sample between is.
    #[inline(always)]
    fn box_run_end(&self, jl: &Jumps, bx: [[i64; 2]; 3], k: u32, k1: u32) -> u32 {
        let mut lim = [[0.0f64; 2]; 3];
        let mut t_end = (k1 - 1) as f64;
        for a in 0..3 {
            // (Boxes count from the samples held; the line is in the grid's indices.)
            let first = (bx[a][0].max(0) + self.org[a]) as f64;
            let last =
                (bx[a][1].min(self.sizes[a] as i64 - self.support as i64) + self.org[a]) as f64;
            // Support start in [first, last] ⇔ its count in [first, last + 1).
            lim[a] = [first + jl.e[a], last + 1.0 - jl.e[a]];
            // (Where the line leaves the box: a first guess, checked below.)
            if jl.d[a] > 0.0 {
                t_end = t_end.min((lim[a][1] - jl.s[a]) * jl.rd[a]);
            } else if jl.d[a] < 0.0 {
                t_end = t_end.min((lim[a][0] - jl.s[a]) * jl.rd[a]);
            }
        }
        if !(t_end >= k as f64 + 1.0) || !jl.member(&lim, k) {
            return k;
        }
        let j = (t_end as u32).min(k1 - 1);
        if j > k && jl.member(&lim, j) {
            j
        } else if j - 1 > k && jl.member(&lim, j - 1) {
            j - 1
        } else {
            k
        }
    }
}

impl<A: Arith> March<'_, '_, A> {
    /// The [`Aim`] of this render's rays through its opacity grid; None without one,
    /// when the rays' lines do not follow one model (perspective views) or when the
    /// memory is not there.
    pub(crate) fn aim(&self) -> Option<Aim> {
        let aim = self.grid_model()?;
        let (firsts, span) = aim.firsts(self.skip?.fine_blocks().1, 0)?;
        aim.sorted(&[&firsts], span)
    }

    /// The model of [`March::aim`] for this render's opacity grid, before its blocks are
    /// placed (a grid kept from another render, aimed anew in parts: [`crate::skip::ReAim`]);
    /// None as there.
    pub(crate) fn grid_model(&self) -> Option<Aim> {
        let g = self.skip.filter(|g| g.kind() == SkipKind::Opacity)?;
        self.aim_model(g.fine_blocks().0)
    }

    /// The model of [`March::aim`] for an opacity grid of `nf` fine blocks per axis,
    /// before any of its blocks are placed ([`Aim::firsts`], [`Aim::sorted`]): what a
    /// grid's builders need to place their blocks as they build them.
    pub(crate) fn aim_model(&self, nf: [usize; 3]) -> Option<Aim> {
        use crate::math::v3::{cross, dot, sub};
        let sp = self.spec;
        let kend = self.kend();
        let jumps = |hi, vi| Some(self.jumps(&self.a.line(&self.a.ray(hi, vi), kend)?, kend));
        let (o, x, y) = (jumps(0, 0)?, jumps(1, 0)?, jumps(0, 1)?);
        if x.d != o.d || y.d != o.d {
            return None;
        }
        let (ph, pv, d) = (sub(x.h, o.h), sub(y.h, o.h), o.d);
        // (hi, vi, k) of a point: the inverse of the columns (ph, pv, d).
        let det = dot(ph, cross(pv, d));
        let inv = [cross(pv, d), cross(d, ph), cross(ph, pv)].map(|r| r.map(|c| c / det));
        if !inv.iter().flatten().all(|c| c.is_finite()) {
            return None;
        }
        let [w, h] = sp.size();
        let n = w as usize * h as usize;
        let wpp = (WINDOWS_MAX / n.max(1)).min(WINDOW_WORDS);
        if wpp == 0 {
            return None;
        }
        // Samples a bit, then the words a pixel needs.
        let c = kend.div_ceil(64 * wpp as u32);
        let wpp = kend.div_ceil(c).div_ceil(64) as usize;
        // Every block has the same corners about its first support start: their
        // (hi, vi, k) ranges once, widened by 2 × SLACK.
        let (mut clo, mut chi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for c in 0..8 {
            let f: [f64; 3] = core::array::from_fn(|a| {
                if (c >> a) & 1 == 1 {
                    FINE as f64 + 2.0 * SLACK
                } else {
                    -2.0 * SLACK
                }
            });
            for r in 0..3 {
                let t = dot(inv[r], f);
                (clo[r], chi[r]) = (clo[r].min(t), chi[r].max(t));
            }
        }
        Some(Aim {
            size: [w, h],
            h: o.h,
            ph,
            pv,
            d,
            inv,
            clo,
            chi,
            kend,
            c,
            wpp,
            nf,
            blocks: Vec::new(),
            starts: Vec::new(),
            span: 0,
        })
    }

    /// Makes the windows of image rows `rows` from the opacity grid's [`Aim`] (none
    /// without one), for the rays of those rows cast next.
    pub(crate) fn aim_rows(&self, rows: core::ops::Range<u32>) {
        let aim = self
            .skip
            .and_then(|g| g.aim())
            .filter(|_| self.own.is_none());
        *self.win.borrow_mut() = aim.and_then(|a| a.windows(rows));
    }
}

impl Aim {
    /// The fine blocks numbered `at` on (their index in the grid; their flags `fine`)
    /// that reach some pixel, in order, each with the first image row it reaches, and
    /// the most rows past its first that one of them reaches; None when the arithmetic
    /// fails or the memory is not there. A grid's blocks may be taken in parts (as its
    /// build makes them) and given to [`Aim::sorted`] together.
    pub(crate) fn firsts(&self, fine: &[u8], at: usize) -> Option<(Vec<(u32, u32)>, u32)> {
        let nf = self.nf;
        let mut out = Vec::new();
        let mut span = 0;
        // (The block's numbers per axis counted along, not divided out of its index.)
        let plane = nf[0].checked_mul(nf[1]).filter(|&p| p > 0)?;
        let mut b = [at % nf[0], at / nf[0] % nf[1], at / plane];
        for (i, &f) in fine.iter().enumerate() {
            if f & FINE_EMPTY == 0 {
                match self.reach_at(b) {
                    Some(Ok(r)) => {
                        span = span.max(r[3] - r[2]);
                        out.try_reserve(1).ok()?;
                        out.push((u32::try_from(at + i).ok()?, r[2]));
                    }
                    Some(Err(())) => return None,
                    None => {}
                }
            }
            b[0] += 1;
            if b[0] == nf[0] {
                b[0] = 0;
                b[1] += 1;
                if b[1] == nf[1] {
                    b[1] = 0;
                    b[2] += 1;
                }
            }
        }
        Some((out, span))
    }

    /// The aim with the grid's blocks placed: `parts` are [`Aim::firsts`] of every part
    /// of the grid that has blocks reaching a pixel, in the grid's order, and `span` the
    /// largest of their spans. None when the memory is not there or a part names a
    /// block or row outside the grid and image.
    pub(crate) fn sorted(mut self, parts: &[&[(u32, u32)]], span: u32) -> Option<Aim> {
        let h = self.size[1];
        let n = self.nf.iter().try_fold(1usize, |n, &a| n.checked_mul(a))?;
        // The blocks by the first row they reach (a counting sort, stable).
        let mut counts = Vec::new();
        counts.try_reserve_exact(h as usize + 1).ok()?;
        counts.resize(h as usize + 1, 0u32);
        for &(i, r) in parts.iter().flat_map(|p| p.iter()) {
            if i as usize >= n || r >= h {
                return None;
            }
            counts[r as usize + 1] += 1;
        }
        for r in 1..counts.len() {
            counts[r] += counts[r - 1];
        }
        let total = counts[h as usize] as usize;
        self.blocks.try_reserve_exact(total).ok()?;
        self.blocks.resize(total, 0);
        self.starts.try_reserve_exact(h as usize + 1).ok()?;
        self.starts.extend_from_slice(&counts[..h as usize + 1]);
        for &(i, r) in parts.iter().flat_map(|p| p.iter()) {
            let at = &mut counts[r as usize];
            self.blocks[*at as usize] = i;
            *at += 1;
        }
        self.span = span;
        Some(self)
    }

    /// The fine blocks per axis of the grid this aims at.
    pub(crate) fn fine_blocks(&self) -> [usize; 3] {
        self.nf
    }

    /// For tests: whether no block is placed.
    #[cfg(test)]
    pub(crate) fn is_empty(&self) -> bool {
        self.blocks.is_empty()
    }

    /// The pixels and samples that fine block `i` (its index in the grid) may reach:
    /// `[h0, h1 + 1, v0, v1 + 1, k0, k1 + 1]`, None when none; an error when the
    /// arithmetic fails (the model gives non-finite numbers).
    fn reach(&self, i: usize) -> Option<Result<[u32; 6], ()>> {
        let nf = self.nf;
        self.reach_at([i % nf[0], i / nf[0] % nf[1], i / (nf[0] * nf[1])])
    }

    /// [`Aim::reach`] of the fine block numbered `b` along each axis.
    #[inline(always)]
    fn reach_at(&self, b: [usize; 3]) -> Option<Result<[u32; 6], ()>> {
        use crate::math::v3::dot;
        use crate::math::{ceil, floor};
        let b = b.map(|b| b * FINE);
        let p: [f64; 3] = core::array::from_fn(|a| b[a] as f64 - self.h[a]);
        let t: [f64; 3] = core::array::from_fn(|r| dot(self.inv[r], p));
        if !t.iter().all(|t| t.is_finite()) {
            return Some(Err(()));
        }
        // Whole pixels and samples in a range (far wider than this f64 arithmetic's
        // rounding, far narrower than the SLACK the blocks are widened by).
        let ends = [self.size[0], self.size[1], self.kend];
        let mut r = [0u32; 6];
        for a in 0..3 {
            let lo = ceil(t[a] + self.clo[a] - 1e-6).max(0.0);
            let hi = floor(t[a] + self.chi[a] + 1e-6).min(ends[a] as f64 - 1.0);
            if lo > hi {
                return None;
            }
            (r[2 * a], r[2 * a + 1]) = (lo as u32, hi as u32 + 1);
        }
        Some(Ok(r))
    }

    /// The [`Windows`] of image rows `rows` (those inside the image); None when the
    /// memory is not there.
    pub(crate) fn windows(&self, rows: core::ops::Range<u32>) -> Option<Windows<'_>> {
        let [w, h] = self.size;
        let (r0, r1) = (rows.start.min(h), rows.end.min(h).max(rows.start.min(h)));
        let n = w as usize * (r1 - r0) as usize;
        let mut bits = Vec::new();
        bits.try_reserve_exact(n * self.wpp).ok()?;
        bits.resize(n * self.wpp, 0u64);
        let c = self.c;
        // The blocks that first reach rows r0 − span to r1 − 1: all that reach the band.
        let (s0, s1) = (
            self.starts[r0.saturating_sub(self.span) as usize] as usize,
            self.starts[r1 as usize] as usize,
        );
        for &i in &self.blocks[s0..s1] {
            let Some(Ok([h0, h1, v0, v1, k0, k1])) = self.reach(i as usize) else {
                continue;
            };
            let (v0, v1) = (v0.max(r0), v1.min(r1));
            // The block's bits, word by word (each word a plane of pixels).
            let (b0, b1) = (k0 / c, (k1 - 1) / c);
            for i in (b0 / 64) as usize..=(b1 / 64) as usize {
                let (lo, hi) = (i as u32 * 64, i as u32 * 64 + 63);
                let (s, e) = (b0.max(lo) - lo, b1.min(hi) - lo);
                let m = (u64::MAX >> (63 - e)) & (u64::MAX << s);
                for vi in v0 as usize..v1 as usize {
                    let row = i * n + (vi - r0 as usize) * w as usize;
                    for x in &mut bits[row + h0 as usize..row + h1 as usize] {
                        *x |= m;
                    }
                }
            }
        }
        Some(Windows {
            aim: self,
            rows: [r0, r1],
            bits,
        })
    }
}

#[cfg(test)]
impl<A: Arith> March<'_, '_, A> {
    /// For tests: with the render's [`Windows`], every sample of the ray through (hi,
    /// vi) whose support start lies in a fine block that is not empty lies in the ray's
    /// window (asserted); the number of such samples.
    pub(crate) fn check_windows(&self, hi: u32, vi: u32) -> usize {
        let kend = self.spec.kmax + 1;
        let (Some(g), Some(aim)) = (self.skip, self.aim()) else {
            return 0;
        };
        let ray = self.a.ray(hi, vi);
        let Some(l) = self.a.line(&ray, kend) else {
            return 0;
        };
        let jl = self.jumps(&l, kend);
        // The pixel's window is the same in a band of this row alone, of rows about it
        // and of the whole image.
        let w = aim.windows(vi..vi + 1).expect("memory");
        let Some(px) = w.of(&jl, hi, vi) else {
            return 0;
        };
        for rows in [vi.saturating_sub(3)..vi + 5, 0..self.spec.size()[1]] {
            let band = aim.windows(rows.clone()).expect("memory");
            assert_eq!(
                band.of(&jl, hi, vi),
                Some(px),
                "pixel ({hi}, {vi}), rows {rows:?}"
            );
        }
        let runs: Vec<(u32, u32)> = w.runs(px, (0, kend)).collect();
        let mut full = 0;
        for k in 0..kend {
            if let Some((n, _)) = self.a.place(&ray, k) {
                if g.flags_at(n) & FINE_EMPTY == 0 {
                    assert!(
                        runs.iter().any(|r| (r.0..r.1).contains(&k)),
                        "ray ({hi}, {vi}) sample {k} at {n:?} not in {runs:?}"
                    );
                    full += 1;
                }
            }
        }
        full
    }

    /// For tests: the ray through (hi, vi), when outside [`March::reach`], has no
    /// sample inside from the near plane to the far plane (asserted); 1 for such a
    /// ray, else 0.
    pub(crate) fn check_reach(&self, hi: u32, vi: u32) -> usize {
        if meets(self.reach, hi, vi) {
            return 0;
        }
        let ray = self.a.ray(hi, vi);
        for k in 0..self.kend() {
            let at = self.a.place(&ray, k).map(|(n, _)| n);
            assert_eq!(
                at, None,
                "ray ({hi}, {vi}) outside {:?}, sample {k}",
                self.reach
            );
        }
        1
    }

    /// For tests: every stretch that a [`Walk`] gives along the ray through (hi, vi),
    /// from its first sample to the far plane, has each sample inside and its support
    /// start in the walk's fine block (asserted); the number of samples so shown.
    pub(crate) fn check_walk(&self, hi: u32, vi: u32) -> usize {
        let (ray, kend) = (self.a.ray(hi, vi), self.spec.kmax + 1);
        let (Some(g), Some(line)) = (self.skip, self.a.line(&ray, kend)) else {
            return 0;
        };
        let jl = self.jumps(&line, kend);
        let mut w = Walk::default();
        let (mut k, mut shown) = (0, 0);
        while k < kend {
            let Some((end, _)) = w.step(&jl, g, k, kend) else {
                k += 1;
                continue;
            };
            assert!(end > k && end <= kend);
            for kk in k..end {
                let Some((at, _)) = self.a.place(&ray, kk) else {
                    panic!("sample {kk} of stretch {k}..{end} of ray ({hi}, {vi}) is outside");
                };
                let blk = at.map(|x| x as usize / FINE);
                assert_eq!(blk, w.blk, "ray ({hi}, {vi}) sample {kk} at {at:?}");
            }
            shown += (end - k) as usize;
            k = end;
        }
        shown
    }

    /// For tests: every run of `n` samples of the ray through (hi, vi) that
    /// [`March::run_box`] boxes has each sample inside, its support start in the box and
    /// its block's bound at most the box's (as [`SkipGrid::bound_over`] gives it, which
    /// [`March::run_under`] tests; asserted);
    /// the number of runs boxed.
    pub(crate) fn check_run_bounds(&self, hi: u32, vi: u32, n: u32) -> usize {
        let (ray, kend) = (self.a.ray(hi, vi), self.spec.kmax + 1);
        let (Some(g), Some(line)) = (self.skip, self.a.line(&ray, kend)) else {
            return 0;
        };
        let jl = self.jumps(&line, kend);
        let mut runs = 0;
        for k in 0..kend.saturating_sub(n) {
            let Some((b0, b1)) = self.run_box(&jl, k, k + n - 1) else {
                continue;
            };
            let b = g.bound_over(b0, b1);
            runs += 1;
            for kk in k..k + n {
                let Some((at, _)) = self.a.place(&ray, kk) else {
                    panic!("sample {kk} of a bounded run {k}.. of ray ({hi}, {vi}) is outside");
                };
                let boxed = (0..3).all(|a| b0[a] <= at[a] && at[a] <= b1[a]);
                assert!(
                    boxed,
                    "ray ({hi}, {vi}) sample {kk} at {at:?}, box {b0:?} {b1:?}"
                );
                assert!(
                    g.bound_at(at) <= b,
                    "ray ({hi}, {vi}) sample {kk} at {at:?}"
                );
            }
        }
        runs
    }
}
