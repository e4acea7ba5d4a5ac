//! Reference arithmetic (`go`'s default engine, `-ref true`): the course reference
//! program's own f32 operation sequence, so that renderings agree with its images bit
//! for bit where possible.
//!
//! The reference program computed everything in C `float` (f32), and float results depend on
//! the order of every operation. The sequence below was recovered by experiment against
//! `cube-rgb.nrrd` (`docs/VERIFICATION.md`, "Reference arithmetic"): each choice here is
//! the one under which that image is reproduced (87,000 of its 89,600 pixels bit for
//! bit, the rest within 2.1e-6; none of the LUT bin flips the f64 engine shows).
//!
//! * Camera (f32): d = √(diff·diff), n = (1/d)·diff, u = (1/|up × n|)·(up × n),
//!   v = n × u, ncv = d + nc, fcv = d + fc, hght = 2·d·tan(π·fov/360), wdth = ar·hght.
//!   View-to-world is the matrix with columns u, v, n, fr.
//! * Ray (hi, vi): t = (hi + 0.5)/size, image-plane u = (wdth/2)·((1 − t)·(−1) + t·1)
//!   (v likewise from +1 to −1 with hght); the image-plane point P = (u, v, −d); start =
//!   (ncv/d)·P, step = (planeSep/d)·P (orthographic: (u, v, −ncv) and (0, 0, −planeSep));
//!   step length √(step·step).
//! * Sample k: view = start + k·step; world = VtoW·(view, 1); index = WtoI·(world, 1)
//!   where WtoI is the f32 cofactor inverse of the f32 index-to-world matrix; each
//!   matrix row summed left to right.
//! * Convolution: base = ⌊x⌋ (odd supports ⌊x + 0.5⌋), α = x − base; weights K(α − i) in
//!   f32 ([`Kernel::k_ref`]); the S³ terms summed in one running sum per result, z
//!   slowest and x fastest, each term ((v·w₀)·w₁)·w₂ (a derivative weight replacing one
//!   factor for the gradient). World gradient = transpose of WtoI's 3×3 times the index
//!   gradient.
//! * Opacity 1 − (1 − α)^(len/unitStep) by `powf`; normals −g·(1/|g|); half vectors
//!   (L + V)·(1/|L + V|) with V = −s·(1/|s|) for the world step s; `over` keeps the
//!   transparency T: C += T·α·rgb, T ·= 1 − α, and the pixel is C/(1 − T), 1 − T.
//!
//! `inside_span` bounds the samples of a ray that can be inside the volume; the ray
//! loop places sixteen samples side by side and [`Lanes`] convolves them, each lane doing exactly the
//! one-sample operations. The running sums still cost about 9 multiplies and 4 adds per
//! support sample (the f64 engine, `-ref false`, sums separably and is quicker).

use crate::affine::Affine4;
use crate::camera::CameraSpec;
use crate::kernel::Kernel;
use crate::light::Light;
use crate::math;
use crate::simd::LaneBatch;
use crate::volume::Volume;
use crate::voxel::Voxel;
use alloc::vec::Vec;

type V3 = [f32; 3];

#[inline(always)]
fn dot(a: V3, b: V3) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline(always)]
fn scale(s: f32, a: V3) -> V3 {
    [s * a[0], s * a[1], s * a[2]]
}

#[inline(always)]
fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Unit vector the reference's way: multiply by the f32 reciprocal of the length.
#[inline(always)]
fn normalize(a: V3) -> V3 {
    scale(1.0 / math::sqrtf(dot(a, a)), a)
}

fn f32x3(a: [f64; 3]) -> V3 {
    [a[0] as f32, a[1] as f32, a[2] as f32]
}

/// The camera frame in f32.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefCamera {
    /// Right.
    pub u: V3,
    /// Up.
    pub v: V3,
    /// Back (towards the eye).
    pub n: V3,
    /// Look-from point.
    pub fr: V3,
    /// Distance from look-from to look-at.
    pub d: f32,
    /// Eye to near plane.
    pub ncv: f32,
    /// Eye to far plane.
    pub fcv: f32,
    /// Image-plane height.
    pub hght: f32,
    /// Image-plane width.
    pub wdth: f32,
    size: [u32; 2],
    ortho: bool,
}

/// One ray's f32 geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefRay {
    /// View-space start on the near plane.
    pub start: V3,
    /// View-space step between sampling planes.
    pub step: V3,
    /// Opacity-correction exponent: step length over the unit step.
    pub alpha_exp: f32,
    /// Unit world direction from the samples towards the eye.
    pub to_eye: V3,
}

impl RefCamera {
    /// The frame for `spec` (already validated by [`crate::camera::Camera::new`]).
    pub fn new(spec: &CameraSpec) -> Self {
        let (fr, at, up) = (f32x3(spec.from), f32x3(spec.at), f32x3(spec.up));
        let diff = [fr[0] - at[0], fr[1] - at[1], fr[2] - at[2]];
        let d = math::sqrtf(dot(diff, diff));
        let n = scale(1.0 / d, diff);
        let u = normalize(cross(up, n));
        let v = cross(n, u);
        let ncv = d + spec.near as f32;
        let fcv = d + spec.far as f32;
        // tan rounded once from f64 (the C library's tanf agrees for the usual angles).
        let half = core::f32::consts::PI * spec.fov as f32 / 360.0;
        let hght = 2.0 * d * math::tan(half as f64) as f32;
        let ar = spec.size[0] as f32 / spec.size[1] as f32;
        RefCamera {
            u,
            v,
            n,
            fr,
            d,
            ncv,
            fcv,
            hght,
            wdth: ar * hght,
            size: spec.size,
            ortho: spec.orthographic,
        }
    }

    /// View to world for a point (`w` = 1) or a vector (`w` = 0).
    #[inline(always)]
    pub fn to_world(&self, p: V3, w: f32) -> V3 {
        let (u, v, n, fr) = (self.u, self.v, self.n, self.fr);
        core::array::from_fn(|r| u[r] * p[0] + v[r] * p[1] + n[r] * p[2] + fr[r] * w)
    }

    /// The ray through pixel (hi, vi) with planes `plane_sep` apart (0: one sample).
    pub fn ray(&self, hi: u32, vi: u32, plane_sep: f32, unit_step: f32) -> RefRay {
        // Cell centres of [-1, 1] (horizontal) and [1, -1] (vertical, top row first).
        let lerp = |i: u32, n: u32, lo: f32, hi: f32| {
            let t = (i as f32 + 0.5) / n as f32;
            (1.0 - t) * lo + t * hi
        };
        let pu = self.wdth / 2.0 * lerp(hi, self.size[0], -1.0, 1.0);
        let pv = self.hght / 2.0 * lerp(vi, self.size[1], 1.0, -1.0);
        let geom = |sep: f32| {
            if self.ortho {
                ([pu, pv, -self.ncv], [0.0, 0.0, -sep])
            } else {
                let p = [pu, pv, -self.d];
                (scale(self.ncv / self.d, p), scale(sep / self.d, p))
            }
        };
        let (start, step) = geom(plane_sep);
        // The eye direction from a unit-separation step when sampling once.
        let dir = if plane_sep == 0.0 { geom(1.0).1 } else { step };
        let s = self.to_world(dir, 0.0);
        let il = 1.0 / math::sqrtf(dot(s, s));
        RefRay {
            start,
            step,
            alpha_exp: math::sqrtf(dot(step, step)) / unit_step,
            to_eye: [-s[0] * il, -s[1] * il, -s[2] * il],
        }
    }

    /// Whether every number of the frame is finite, the eye distance positive and the
    /// far plane beyond the near one: a camera valid in f64 can overflow, underflow or
    /// lose its planes' separation in f32.
    pub fn is_finite(&self) -> bool {
        let v3 = |a: V3| a.iter().all(|x| x.is_finite());
        v3(self.u)
            && v3(self.v)
            && v3(self.n)
            && v3(self.fr)
            && [self.d, self.ncv, self.fcv, self.hght, self.wdth]
                .iter()
                .all(|x| x.is_finite())
            && self.d > 0.0
            && self.fcv > self.ncv
    }

    /// Lights as world-space (colour, unit direction): view-space directions mapped by
    /// the view-to-world rotation, then normalized the reference's way.
    pub fn lights(&self, lights: &[Light]) -> Vec<(V3, V3)> {
        lights
            .iter()
            .map(|l| {
                let d = f32x3(l.dir);
                let d = if l.space == crate::light::LightSpace::View {
                    self.to_world(d, 0.0)
                } else {
                    d
                };
                (l.rgb, normalize(d))
            })
            .collect()
    }
}

/// World-to-index in f32: the cofactor inverse of the f32 index-to-world matrix.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefIndex {
    pub(crate) m: [[f32; 3]; 3],
    pub(crate) t: V3,
}

impl RefIndex {
    /// From a volume's index-to-world matrix.
    pub fn new(itow: &Affine4) -> Self {
        let e = |r: usize, c: usize| itow.at(r, c) as f32;
        let (a, b, c) = (e(0, 0), e(0, 1), e(0, 2));
        let (d, f0, f) = (e(1, 0), e(1, 1), e(1, 2));
        let (g, h, i) = (e(2, 0), e(2, 1), e(2, 2));
        let det = a * (f0 * i - f * h) - b * (d * i - f * g) + c * (d * h - f0 * g);
        let m = [
            [
                (f0 * i - f * h) / det,
                (c * h - b * i) / det,
                (b * f - c * f0) / det,
            ],
            [
                (f * g - d * i) / det,
                (a * i - c * g) / det,
                (c * d - a * f) / det,
            ],
            [
                (d * h - f0 * g) / det,
                (b * g - a * h) / det,
                (a * f0 - b * d) / det,
            ],
        ];
        let tr = [e(0, 3), e(1, 3), e(2, 3)];
        let t = core::array::from_fn(|r| -(m[r][0] * tr[0] + m[r][1] * tr[1] + m[r][2] * tr[2]));
        RefIndex { m, t }
    }

    /// Index-space position of world point `p`.
    #[inline(always)]
    pub fn point(&self, p: V3) -> V3 {
        let (m, t) = (&self.m, &self.t);
        core::array::from_fn(|r| m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + t[r])
    }

    /// World-space gradient from an index-space one.
    #[inline(always)]
    pub fn gradient(&self, g: V3) -> V3 {
        let m = &self.m;
        core::array::from_fn(|c| m[0][c] * g[0] + m[1][c] * g[1] + m[2][c] * g[2])
    }
}

/// One convolution in reference arithmetic.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefSample {
    /// First support index per axis.
    pub start: [i64; 3],
    /// Value.
    pub value: f32,
    /// Index-space gradient (zero unless asked for).
    pub grad_i: V3,
}

/// First support index (counted from grid index `org`) and fractional offset of index
/// coordinate `x` on an axis of which `size` samples from `org` on are held, when the
/// whole support is inside them (NaN is outside).
#[inline(always)]
fn place<K: Kernel<S>, const S: usize>(x: f32, org: usize, size: usize) -> Option<(i64, f32)> {
    let y = if S.is_multiple_of(2) { x } else { x + 0.5 };
    let base = math::floorf(y);
    let lo = base + K::LO as f32 - org as f32;
    // The bounds are small integers, exact in f32 for any volume this crate accepts.
    if lo >= 0.0 && lo + (S as f32 - 1.0) <= size as f32 - 1.0 {
        Some((lo as i64, x - base))
    } else {
        None
    }
}

/// First support index (counted from `org`) and fractions per axis of index position
/// `p` when the whole support is inside the `sizes` samples held from grid index `org`
/// on (the inside rule in f32; `org` is 0 for a whole volume).
#[inline(always)]
pub fn place3<K: Kernel<S>, const S: usize>(
    p: V3,
    org: [usize; 3],
    sizes: [usize; 3],
) -> Option<([i64; 3], V3)> {
    let (mut n, mut f) = ([0i64; 3], [0.0f32; 3]);
    for a in 0..3 {
        (n[a], f[a]) = place::<K, S>(p[a], org[a], sizes[a])?;
    }
    Some((n, f))
}

/// Convolves `vol` at index position `p` (value, and the index gradient when `grad`);
/// `None` when the support is not inside.
#[inline]
pub fn convolve<V: Voxel, K: Kernel<S>, const S: usize>(
    vol: &Volume<'_, V>,
    p: V3,
    grad: bool,
) -> Option<RefSample> {
    let (sz, org) = (vol.sizes(), vol.origin());
    let (mut n, mut al) = ([0i64; 3], [0.0f32; 3]);
    for a in 0..3 {
        (n[a], al[a]) = place::<K, S>(p[a], org[a], sz[a])?;
    }
    let (value, grad_i) = convolve_placed::<V, K, S>(vol, n, al, grad);
    Some(RefSample {
        start: n,
        value,
        grad_i,
    })
}

/// [`convolve`] of a sample already placed: support start `n` (relative to the samples
/// held, the whole support inside them) and fractions `al`. The value, and the index
/// gradient when `grad` (else zero).
#[inline]
pub(crate) fn convolve_placed<V: Voxel, K: Kernel<S>, const S: usize>(
    vol: &Volume<'_, V>,
    n: [i64; 3],
    al: V3,
    grad: bool,
) -> (f32, V3) {
    let mut w = [[0.0f32; S]; 3];
    let mut dw = [[0.0f32; S]; 3];
    for a in 0..3 {
        for i in 0..S {
            let x = al[a] - (K::LO + i as i32) as f32;
            w[a][i] = K::k_ref(x);
            if grad {
                dw[a][i] = K::d1_ref(x);
            }
        }
    }
    let data = vol.data();
    let (s0, s01) = (vol.row_stride(), vol.slice_stride());
    let base = n[0] as usize + s0 * n[1] as usize + s01 * n[2] as usize;
    let (mut val, mut g) = (0.0f32, [0.0f32; 3]);
    for k in 0..S {
        for j in 0..S {
            let o = base + j * s0 + k * s01;
            let Some(row) = data.get(o..o + S) else {
                return (f32::NAN, [f32::NAN; 3]);
            };
            for (i, x) in row.iter().enumerate() {
                let x = x.to_f32();
                val += x * w[0][i] * w[1][j] * w[2][k];
                if grad {
                    g[0] += x * dw[0][i] * w[1][j] * w[2][k];
                    g[1] += x * w[0][i] * dw[1][j] * w[2][k];
                    g[2] += x * w[0][i] * w[1][j] * dw[2][k];
                }
            }
        }
    }
    (val, g)
}

/// The longest volume axis (in samples) the reference arithmetic handles: its index
/// bounds are compared in f32, exact only below 2^24. Longer axes must not be rendered
/// with `params.reference` (rendr refuses them; the sums assert it).
pub const MAX_AXIS: usize = (1 << 24) - 1;

/// A range of sample numbers `first ..= last` (within `0 ..= kmax`) outside which no
/// sample of `ray` is inside `vol` for a kernel of support `S`, as the reference
/// arithmetic decides it in f32 ([`place3`] of the sample's index position); `None` when no sample can be inside. Found once per ray in f64
/// from the same f32 parameters, widened by a bound on the f32 rounding error, so the
/// samples it leaves out are provably outside (a batched loop may start and stop there
/// with the same bits).
///
/// The bound: the arithmetic computes the view position (2 roundings), the world
/// position (4 products and sums) and the index position (4 more), then adds 0.5 for
/// odd supports. With unit roundoff u = 2^-24 each result is off the exact value of the
/// same formula by at most about 11 u times the sum of the magnitudes of its terms; 16 u
/// of that sum (plus 1) is used, and one more sample at each end.
pub(crate) fn inside_span<V: Voxel, K: Kernel<S>, const S: usize>(
    line: Option<&crate::arith::Line>,
    vol: &Volume<'_, V>,
    kmax: u32,
) -> Option<(u32, u32)> {
    let kmax_f = kmax as f64;
    let Some(line) = line else {
        return Some((0, kmax));
    };
    let half = if S.is_multiple_of(2) { 0.0 } else { 0.5 };
    let (sz, org) = (vol.sizes(), vol.origin());
    let (mut lo, mut hi) = (0.0f64, kmax_f);
    for a in 0..3 {
        let (x0, x1, err) = (line.s[a] + half, line.d[a], line.err[a]);
        // Inside in f32: floor(y) + LO - org >= 0 and floor(y) + LO - org + S - 1 <=
        // size - 1, that is y in [org - LO, org + size - LO - S + 1).
        let o = org[a] as f64;
        let ylo = o - (K::LO as f64) - err;
        let yhi = (o + sz[a] as f64 - K::LO as f64 - S as f64 + 1.0) + err;
        if x1 == 0.0 {
            if x0 < ylo || x0 > yhi {
                return None;
            }
            continue;
        }
        let (k_a, k_b) = ((ylo - x0) / x1, (yhi - x0) / x1);
        lo = lo.max(k_a.min(k_b));
        hi = hi.min(k_a.max(k_b));
    }
    let first = (math::floor(lo) - 1.0).max(0.0);
    let last = (math::ceil(hi) + 1.0).min(kmax_f);
    if first > last {
        return None;
    }
    Some((first as u32, last as u32))
}

/// The reference arithmetic's view-to-index map in f64, for index lines: world-to-index
/// after view-to-world composed once, x = A p + b, with the magnitudes |M||R| and
/// |M||fr| + |t| of its terms (M, t world-to-index; R, fr view-to-world).
#[derive(Debug, Clone, Copy)]
pub struct ViewIndex {
    a: [[f64; 3]; 3],
    b: [f64; 3],
    amag: [[f64; 3]; 3],
    bmag: [f64; 3],
}

impl ViewIndex {
    /// The map of a camera and a volume's world-to-index.
    pub fn new(cam: &RefCamera, wtoi: &RefIndex) -> Self {
        let f = |x: f32| x as f64;
        let cols = [cam.u, cam.v, cam.n];
        let (m, t) = (&wtoi.m, &wtoi.t);
        let sum = |g: &dyn Fn(usize) -> f64| g(0) + g(1) + g(2);
        ViewIndex {
            a: core::array::from_fn(|a| {
                core::array::from_fn(|c| sum(&|r| f(m[a][r]) * f(cols[c][r])))
            }),
            b: core::array::from_fn(|a| sum(&|r| f(m[a][r]) * f(cam.fr[r])) + f(t[a])),
            amag: core::array::from_fn(|a| {
                core::array::from_fn(|c| sum(&|r| (f(m[a][r]) * f(cols[c][r])).abs()))
            }),
            bmag: core::array::from_fn(|a| {
                sum(&|r| (f(m[a][r]) * f(cam.fr[r])).abs()) + f(t[a]).abs()
            }),
        }
    }

    /// The index-space line `s + k d` of `ray` in exact arithmetic on the f32
    /// parameters, with a bound `err` per axis on how far the f32 index position of any
    /// sample 0 ..= kmax (plus 0.5 for odd supports, rounded) lies from it (see
    /// [`inside_span`]); None when a number is not finite. (The f64 roundings here and
    /// in composing the map are some 2^-29 of that bound: inside its margin.)
    #[inline]
    pub(crate) fn line(&self, ray: &RefRay, kmax: u32) -> Option<crate::arith::Line> {
        let (p, q) = (ray.start.map(f64::from), ray.step.map(f64::from));
        let km = f64::from(kmax);
        let pmax = [0, 1, 2].map(|c| p[c].abs() + km * q[c].abs());
        let dot = |r: &[f64; 3], x: &[f64; 3]| r[0] * x[0] + r[1] * x[1] + r[2] * x[2];
        let unit = 1.0 / (1u32 << 24) as f64;
        // (Plain loops: this runs once or twice per ray.)
        let mut line = crate::arith::Line {
            s: [0.0; 3],
            d: [0.0; 3],
            err: [0.0; 3],
        };
        let mut all = 0.0;
        for a in 0..3 {
            line.s[a] = dot(&self.a[a], &p) + self.b[a];
            line.d[a] = dot(&self.a[a], &q);
            line.err[a] = 16.0 * unit * (dot(&self.amag[a], &pmax) + self.bmag[a] + 1.0);
            all += line.s[a] + line.d[a] + line.err[a];
        }
        // A NaN or infinity anywhere makes the sum so (as may a finite overflow: then
        // no line, which is always safe).
        all.is_finite().then_some(line)
    }
}

pub use crate::simd::LANES;

/// Up to [`LANES`] samples convolved together in reference arithmetic: every lane does
/// exactly the operations of [`convolve`] for its sample (so the same bits), and the
/// lanes run side by side in vector registers: the running sums of one sample are
/// chains of S³ dependent additions, the lanes' chains are independent.
#[derive(Debug, Clone)]
pub struct Lanes<const S: usize> {
    /// Flat index of each lane's first support sample.
    base: [usize; LANES],
    /// Each lane's fractional offset per axis.
    al: [[f32; LANES]; 3],
    len: usize,
}

impl<const S: usize> Default for Lanes<S> {
    fn default() -> Self {
        Lanes {
            base: [0; LANES],
            al: [[0.0; LANES]; 3],
            len: 0,
        }
    }
}

impl<const S: usize> Lanes<S> {
    /// Number of samples added since the last [`Lanes::clear`].
    #[inline(always)]
    pub fn len(&self) -> usize {
        self.len
    }
    /// Whether no sample has been added.
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
    /// Whether all lanes are taken.
    #[inline(always)]
    pub fn is_full(&self) -> bool {
        self.len == LANES
    }
    /// Empties the batch.
    #[inline(always)]
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Adds a sample already placed: support start `n` (counted from the samples held)
    /// and fractions `al`; false (nothing added) when the batch is full or that support
    /// is not inside `vol`.
    pub fn push_placed<V: Voxel>(
        &mut self,
        vol: &Volume<'_, V>,
        n: [i64; 3],
        al: [f32; 3],
    ) -> bool {
        let sz = vol.sizes();
        let inside = (0..3).all(|a| n[a] >= 0 && n[a] as u64 + S as u64 <= sz[a] as u64);
        if self.is_full() || !inside {
            return false;
        }
        self.put(vol, n, al);
        true
    }

    /// [`Lanes::push_placed`] of a sample the caller placed inside, in a batch not full.
    #[inline(always)]
    pub(crate) fn put<V: Voxel>(&mut self, vol: &Volume<'_, V>, n: [i64; 3], al: [f32; 3]) {
        let sz = vol.sizes();
        let l = self.len;
        self.base[l] = n[0] as usize + vol.row_stride() * (n[1] as usize + sz[1] * n[2] as usize);
        for a in 0..3 {
            self.al[a][l] = al[a];
        }
        self.len += 1;
    }

    /// Adds the sample at index position `p` when its support is inside `vol` and the
    /// batch is not full (true); false (nothing added) otherwise.
    #[inline(always)]
    pub fn push<V: Voxel, K: Kernel<S>>(&mut self, vol: &Volume<'_, V>, p: V3) -> bool {
        if self.is_full() {
            return false;
        }
        let (sz, org) = (vol.sizes(), vol.origin());
        let (mut n, mut al) = ([0i64; 3], [0.0f32; 3]);
        for a in 0..3 {
            let Some((lo, f)) = place::<K, S>(p[a], org[a], sz[a]) else {
                return false;
            };
            (n[a], al[a]) = (lo, f);
        }
        self.put(vol, n, al);
        true
    }

    /// Convolves the batch: `out[l]` is lane l's value and (with `G`) index gradient,
    /// bit for bit what [`convolve`] gives for that sample, at the widest vector level
    /// `simd` allows. False (nothing written) when the batch is empty or `vol` does not
    /// hold the supports (another volume than the samples were added for).
    pub fn convolve<V: Voxel, K: Kernel<S>, const G: bool>(
        &self,
        vol: &Volume<'_, V>,
        simd: crate::simd::Simd,
        out: &mut [[f32; 4]; LANES],
    ) -> bool {
        let (s0, s01) = (vol.row_stride(), vol.slice_stride());
        let end = crate::simd::Supports::<V, S, LANES>::end(vol.data().len(), s0, s01);
        if self.is_empty() || self.base[..self.len].iter().any(|&b| b >= end) {
            return false;
        }
        self.sums::<V, K, G>(vol, simd, out);
        true
    }

    /// [`Lanes::convolve`] of a batch not empty, its samples added for `vol`.
    #[inline]
    pub(crate) fn sums<V: Voxel, K: Kernel<S>, const G: bool>(
        &self,
        vol: &Volume<'_, V>,
        simd: crate::simd::Simd,
        out: &mut [[f32; 4]; LANES],
    ) {
        let (base, al, len) = (&self.base, &self.al, self.len);
        let batch = LaneBatch {
            vol,
            base,
            al,
            len,
            value: true,
        };
        crate::simd::lane_sums::<V, K, S, G>(simd, batch, out);
    }
}

/// `x^y` rounded once to f32 (via f64, so nearly always the correctly rounded power):
/// the reference's C library `powf` agrees with it on all but about 0.06% of arguments,
/// where `libm::powf` differs on about 10%.
#[inline]
pub fn powf(x: f32, y: f32) -> f32 {
    if x == 0.0 && y > 0.0 {
        // As the library's pow (C99 F.9.4.4): ±0 to an odd whole power is itself, to any
        // other positive power +0 (specular powers of back-facing normals, often).
        let odd = y < 16_777_216.0 && y == math::floorf(y) && (y as u32) % 2 == 1;
        return if odd { x } else { 0.0 };
    }
    match powf_whole(x, y) {
        Some(r) => r,
        None => math::pow(x as f64, y as f64) as f32,
    }
}

/// [`powf`] of the first `n` lanes of `x` to one power `y`, the same bits (0 in the
/// others): where `y` is whole, the repeated squaring of all lanes side by side (f64
/// lanes the compiler keeps in vector registers), and [`powf`] itself for the lanes
/// that [`powf_whole`] would not settle.
#[inline(always)]
pub(crate) fn powf_lanes<const N: usize>(x: &[f32; N], y: f32, n: usize) -> [f32; N] {
    let mut out = [0.0f32; N];
    let n = n.min(N);
    let Some(e) = whole_exp(y) else {
        for l in 0..n {
            out[l] = powf(x[l], y);
        }
        return out;
    };
    let (mut r, mut b) = ([1.0f64; N], [0.0f64; N]);
    for l in 0..N {
        b[l] = f64::from(x[l]);
    }
    squarings(e, &mut r, &mut b);
    for l in 0..n {
        let xl = x[l];
        let fast = if xl > 0.0 && xl <= 1.0 {
            settle(r[l], y)
        } else {
            None
        };
        out[l] = fast.unwrap_or_else(|| powf(xl, y));
    }
    out
}

/// `y` as a whole exponent in [1, 2^16], the range [`powf_whole`] takes.
#[inline(always)]
fn whole_exp(y: f32) -> Option<u32> {
    ((1.0..=65_536.0).contains(&y) && y == math::floorf(y)).then_some(y as u32)
}

/// `r·b^n` of every lane, by repeated squaring in f64 (`b` squared as it goes).
#[inline(always)]
fn squarings<const N: usize>(mut n: u32, r: &mut [f64; N], b: &mut [f64; N]) {
    loop {
        if n & 1 == 1 {
            for l in 0..N {
                r[l] *= b[l];
            }
        }
        n >>= 1;
        if n == 0 {
            break;
        }
        for l in 0..N {
            b[l] *= b[l];
        }
    }
}

/// The f32 of a power `r` found by repeated squaring to whole exponent `y`, when every
/// value within its error bound rounds to it (see [`powf_whole`]); else None.
#[inline(always)]
fn settle(r: f64, y: f32) -> Option<f32> {
    if r < 1e-290 {
        return None;
    }
    let e = (y as f64 + 64.0) * f64::EPSILON;
    let (lo, hi) = ((r * (1.0 - e)) as f32, (r * (1.0 + e)) as f32);
    (lo == hi).then_some(lo)
}

/// [`powf`] without the library `pow`, where that is provably the same f32: for a whole
/// exponent y in [1, 2^16] and x in (0, 1] (specular powers), x^y by repeated squaring
/// in f64 is within (y + 33)·2^-53 of the exact power (each squaring doubles the
/// relative error so far and adds 2^-53; the multiplications into the result add 2^-53
/// each), the library's `pow` within 2 ulps. When everything within a wider bound
/// rounds to one f32, both do; otherwise (near a rounding boundary, or a result close
/// to the f64 underflow) None.
#[inline]
fn powf_whole(x: f32, y: f32) -> Option<f32> {
    let n = whole_exp(y)?;
    if !(x > 0.0 && x <= 1.0) {
        return None;
    }
    let (mut r, mut b) = ([1.0f64], [x as f64]);
    squarings(n, &mut r, &mut b);
    settle(r[0], y)
}

/// Opacity `a` clamped to [0, 1] and corrected for `ex` unit steps: 1 − (1 − a)^ex.
#[inline]
pub fn correct_alpha(a: f32, ex: f32) -> f32 {
    let a = a.clamp(0.0, 1.0);
    if a == 0.0 {
        // 1 − 1^ex: pow(1, y) is exactly 1 for every y.
        return 0.0;
    }
    1.0 - powf(1.0 - a, ex)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::{Bspln3, Tent};

    #[test]
    fn bspln3_reference_form_matches_the_kernel() {
        for i in -250..=250 {
            let x = i as f32 / 100.0;
            let (a, b) = (Bspln3::k_ref(x), Bspln3::k::<f64>(x as f64));
            assert!((a as f64 - b).abs() < 1e-7, "{x}: {a} vs {b}");
            let (a, b) = (Bspln3::d1_ref(x), Bspln3::d1::<f64>(x as f64));
            assert!((a as f64 - b).abs() < 1e-7, "{x}: {a} vs {b}");
        }
    }

    #[test]
    fn index_inverse_is_exact_on_powers_of_two() {
        let itow = Affine4::from_columns([0.5, 0., 0.], [0., 2., 0.], [0., 0., 4.], [1., -2., 3.]);
        let wi = RefIndex::new(&itow);
        assert_eq!(wi.point([1.5, 0.0, 7.0]), [1.0, 1.0, 1.0]);
        assert_eq!(wi.gradient([1.0, 1.0, 1.0]), [2.0, 0.5, 0.25]);
    }

    #[test]
    fn tent_convolution_reproduces_a_linear_ramp() {
        // f = 3i + 2j - k + 1 on a 5x6x7 grid; tent reproduces it exactly inside.
        let sz = [5usize, 6, 7];
        let mut data = Vec::new();
        for k in 0..sz[2] {
            for j in 0..sz[1] {
                for i in 0..sz[0] {
                    data.push(3.0 * i as f32 + 2.0 * j as f32 - k as f32 + 1.0);
                }
            }
        }
        let vol = Volume::new(&data, sz, Affine4::from_rows(IDENTITY)).unwrap();
        let p = [1.25, 2.5, 3.75];
        let s = convolve::<f32, Tent, 2>(&vol, p, true).unwrap();
        assert_eq!(s.value, 3.0 * 1.25 + 2.0 * 2.5 - 3.75 + 1.0);
        assert_eq!(s.grad_i, [3.0, 2.0, -1.0]);
        assert_eq!(s.start, [1, 2, 3]);
        // x = size - 1 exactly needs index size: outside.
        assert!(convolve::<f32, Tent, 2>(&vol, [4.0, 1.0, 1.0], false).is_none());
        assert!(convolve::<f32, Tent, 2>(&vol, [f32::NAN, 1.0, 1.0], false).is_none());
    }

    const IDENTITY: [f64; 16] = [
        1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1.,
    ];

    #[test]
    fn centre_ray_runs_along_minus_n() {
        let spec = CameraSpec {
            from: [6., 12., 5.],
            at: [0., 0., 0.],
            up: [0., 0., 1.],
            near: -2.3,
            far: 2.3,
            fov: 14.,
            size: [3, 3],
            orthographic: false,
        };
        let c = RefCamera::new(&spec);
        let r = c.ray(1, 1, 0.03, 0.03);
        assert_eq!(r.start[..2], [0.0, 0.0]);
        assert_eq!(r.step[..2], [0.0, 0.0]);
        for a in 0..3 {
            assert!((r.to_eye[a] - c.n[a]).abs() < 1e-6);
        }
        assert!(
            (c.ncv as f64 - 12.0178211).abs() < 2e-6 && (c.fcv as f64 - 16.6178211).abs() < 2e-6
        );
    }
}

#[cfg(test)]
mod lane_tests {
    use super::*;
    use crate::kernel::{BoxK, Bspln2, Bspln3, C4Hexic, Ctmr, Tent};
    use crate::simd::{Simd, SimdLevel};

    use crate::test_rng::Lcg;

    fn check<V: Voxel, K: Kernel<S>, const S: usize>(data: &[V], sz: [usize; 3], simd: Simd) {
        let vol = Volume::new(data, sz, Affine4::IDENTITY).unwrap();
        let mut rng = Lcg(S as u64 * 77 + sz[0] as u64);
        // Earlier batches with their sums, to be summed again in pairs: the last one, and
        // the last line of each direction.
        type Done<const S: usize> = (Lanes<S>, [[[f32; 4]; LANES]; 3]);
        let mut last: Option<Done<S>> = None;
        let mut last_line: [Option<Done<S>>; 2] = [None, None];
        for round in 0..200 {
            let mut lanes = Lanes::<S>::default();
            let mut pts = Vec::new();
            // Random points, some outside, some exactly on samples (fraction 0) and
            // half-way between them; fill a random number of lanes.
            let want = 1 + round % LANES;
            let mut tries = 0;
            // Every fourth round with all lanes: one line along the axis long enough (if
            // any), one voxel a point, forwards and backwards in turn (supports a voxel,
            // a row or a slice apart: the AVX-512 sums load runs or share rows).
            let ax = (0..3).find(|&a| sz[a] >= LANES + 8);
            let back = round / 4 % 2 == 1;
            let line = ax.filter(|_| round % 4 == 3).map(|ax| {
                let mut at = |a: usize| {
                    let n = if a == ax { sz[a] - LANES + 1 } else { sz[a] };
                    let x = 3.0 + rng.next() * (n as f32 - 7.0);
                    x + if a == ax && back {
                        (LANES - 1) as f32
                    } else {
                        0.0
                    }
                };
                ([at(0), at(1), at(2)], ax)
            });
            let want = if line.is_some() { LANES } else { want };
            while lanes.len() < want && tries < 100 {
                tries += 1;
                let p: V3 = core::array::from_fn(|a| {
                    if let Some((q, ax)) = line {
                        let d = if a != ax {
                            0.0
                        } else if back {
                            -((tries - 1) as f32)
                        } else {
                            (tries - 1) as f32
                        };
                        return q[a] + d;
                    }
                    let x = rng.next() * (sz[a] as f32 + 2.0) - 1.0;
                    match round % 3 {
                        0 => x,
                        1 => math::floorf(x),
                        _ => math::floorf(x) + 0.5,
                    }
                });
                let inside = convolve::<V, K, S>(&vol, p, false).is_some();
                assert_eq!(lanes.push::<V, K>(&vol, p), inside, "{p:?}");
                if inside {
                    pts.push(p);
                }
            }
            if lanes.is_empty() {
                continue;
            }
            // A batch's value sums, its sums with the gradient, and the gradient alone (no
            // value sums, where a level has such a path).
            let sums = |lanes: &Lanes<S>| {
                let mut v = [[0.0f32; 4]; LANES];
                let mut vg = [[0.0f32; 4]; LANES];
                assert!(lanes.convolve::<V, K, false>(&vol, simd, &mut v));
                assert!(lanes.convolve::<V, K, true>(&vol, simd, &mut vg));
                let mut g = [[0.0f32; 4]; LANES];
                let batch = LaneBatch {
                    vol: &vol,
                    base: &lanes.base,
                    al: &lanes.al,
                    len: lanes.len,
                    value: false,
                };
                crate::simd::lane_sums::<V, K, S, true>(simd, batch, &mut g);
                [v, vg, g]
            };
            let [v, vg, g] = sums(&lanes);
            for (l, p) in pts.iter().enumerate() {
                let s = convolve::<V, K, S>(&vol, *p, true).unwrap();
                let bits = |a: [f32; 4]| a.map(f32::to_bits);
                let want = [s.value, s.grad_i[0], s.grad_i[1], s.grad_i[2]];
                assert_eq!(bits(vg[l]), bits(want), "S={S} lane {l} at {p:?}");
                assert_eq!(v[l][0].to_bits(), s.value.to_bits(), "S={S} value at {p:?}");
                assert_eq!(bits(g[l])[1..], bits(want)[1..], "S={S} gradient at {p:?}");
            }
            // Two batches summed as a pair give each one's sums alone, bit for bit.
            let done = (lanes, [v, vg, g]);
            let other = if line.is_some() {
                &mut last_line[usize::from(back)]
            } else {
                &mut last
            };
            for pair in [[&done, &done], [other.as_ref().unwrap_or(&done), &done]] {
                check_pair::<V, K, S>(&vol, simd, pair);
            }
            // A line and the same line one voxel over: other supports, the same offsets
            // (and so the same weights) in every lane.
            if let Some((_, ax)) = line {
                let mut moved = Lanes::<S>::default();
                let over = (ax + 1) % 3;
                for p in &pts {
                    let mut q = *p;
                    q[over] -= 1.0;
                    moved.push::<V, K>(&vol, q);
                }
                if moved.len() == pts.len() {
                    let s = sums(&moved);
                    let moved = (moved, s);
                    for pair in [[&done, &moved], [&moved, &done]] {
                        check_pair::<V, K, S>(&vol, simd, pair);
                    }
                }
            }
            *other = Some(done);
        }
    }

    /// `lane_sums_pair` of two batches (where the level has it: AVX-512, support 4) gives
    /// each batch's own sums (`pair[h].1`: its value sums, its sums with the gradient,
    /// and its gradient's alone, `LaneBatch::value` false), bit for bit.
    fn check_pair<V: Voxel, K: Kernel<S>, const S: usize>(
        vol: &Volume<'_, V>,
        simd: Simd,
        pair: [&(Lanes<S>, [[[f32; 4]; LANES]; 3]); 2],
    ) {
        fn batch<'b, V: Voxel, const S: usize>(
            vol: &'b Volume<'b, V>,
            lanes: &'b Lanes<S>,
            value: bool,
        ) -> LaneBatch<'b, V> {
            LaneBatch {
                vol,
                base: &lanes.base,
                al: &lanes.al,
                len: lanes.len,
                value,
            }
        }
        let bits = |x: f32| x.to_bits();
        let [a, b] = pair;
        let pv = crate::simd::lane_sums_pair::<V, K, S, false>(
            simd,
            [batch(vol, &a.0, true), batch(vol, &b.0, true)],
        );
        let pg = crate::simd::lane_sums_pair::<V, K, S, true>(
            simd,
            [batch(vol, &a.0, true), batch(vol, &b.0, true)],
        );
        let po = crate::simd::lane_sums_pair::<V, K, S, true>(
            simd,
            [batch(vol, &a.0, false), batch(vol, &b.0, false)],
        );
        let (Some(pv), Some(pg), Some(po)) = (pv, pg, po) else {
            // No pairs at this level.
            assert!(!simd.avx512() || S != 4);
            return;
        };
        for (h, (lanes, [v, vg, g])) in pair.into_iter().enumerate() {
            for l in 0..lanes.len {
                assert_eq!(
                    bits(pv[h][0][l]),
                    bits(v[l][0]),
                    "S={S} pair value, lane {l}"
                );
                for c in 0..4 {
                    assert_eq!(
                        bits(pg[h][c][l]),
                        bits(vg[l][c]),
                        "S={S} pair sum {c}, lane {l}"
                    );
                }
                for c in 1..4 {
                    assert_eq!(
                        bits(po[h][c][l]),
                        bits(g[l][c]),
                        "S={S} pair gradient {c}, lane {l}"
                    );
                }
            }
        }
    }

    fn all_kernels<V: Voxel>(data: &[V], sz: [usize; 3], simd: Simd) {
        check::<V, BoxK, 1>(data, sz, simd);
        check::<V, Tent, 2>(data, sz, simd);
        check::<V, Bspln2, 3>(data, sz, simd);
        check::<V, Bspln3, 4>(data, sz, simd);
        check::<V, Ctmr, 4>(data, sz, simd);
        check::<V, C4Hexic, 6>(data, sz, simd);
    }

    /// Lanes give exactly `convolve`'s bits, for every kernel, both voxel types, with
    /// AVX-512 (where the processor has it), AVX2 only, and neither.
    #[test]
    fn lanes_are_convolve_bit_for_bit() {
        // (The last three volumes are long enough on their first, second and third axes
        // for lines of points.)
        for sz in [[11usize, 9, 13], [27, 9, 8], [9, 27, 8], [9, 8, 27]] {
            let n = sz[0] * sz[1] * sz[2];
            let mut rng = Lcg(5);
            let f: Vec<f32> = (0..n).map(|_| rng.next() * 2000.0 - 700.0).collect();
            let s: Vec<i16> = f.iter().map(|&x| x as i16).collect();
            // AVX-512 (where the processor has it), AVX2 only, and no AVX: each level is
            // passed down, so tests running at once cannot disturb each other.
            for level in [SimdLevel::Avx512, SimdLevel::Avx2, SimdLevel::Baseline] {
                let simd = Simd::at_most(level);
                all_kernels(&f, sz, simd);
                all_kernels(&s, sz, simd);
            }
        }
    }

    /// `powf_lanes` is `powf` lane by lane: bases in (0, 1] and outside it (zeros of both
    /// signs, NaN, infinities, negatives, above 1), whole and other exponents.
    #[test]
    fn power_lanes_are_powf() {
        let mut rng = Lcg(7);
        let odd = [
            0.0f32,
            -0.0,
            f32::NAN,
            f32::INFINITY,
            -0.5,
            1.5,
            1.0,
            1e-45,
            f32::MIN_POSITIVE,
        ];
        for y in [
            1.0f32, 2.0, 3.0, 7.0, 150.0, 151.0, 1000.0, 65_536.0, 70_000.0, 0.5, 0.0, -2.0,
        ] {
            for round in 0..200 {
                let x: [f32; 16] = core::array::from_fn(|l| match (round + l) % 4 {
                    0 => odd[(round * 16 + l) % odd.len()],
                    1 => 1.0 - rng.next() * 1e-3,
                    _ => rng.next(),
                });
                let n = 16 - round % 3;
                let got = powf_lanes(&x, y, n);
                for l in 0..n {
                    assert_eq!(got[l].to_bits(), powf(x[l], y).to_bits(), "{:e}^{y}", x[l]);
                }
            }
        }
    }

    /// The repeated-squaring path of `powf` gives the library `pow`'s f32 bits.
    #[test]
    fn whole_powers_are_the_library_pow() {
        let mut rng = Lcg(99);
        let mut fast = 0;
        let ys = (1..=200).chain([255, 256, 500, 1000, 4096, 65_535, 65_536]);
        for y in ys {
            let y = y as f32;
            for i in 0..4000 {
                // Uniform in (0, 1], near 1, and spread over many binades.
                let x = match i % 3 {
                    0 => 1.0 - rng.next(),
                    1 => 1.0 - rng.next() * 1e-3,
                    _ => (2.0f32).powi(-(rng.next() * 60.0) as i32) * (1.0 - rng.next() / 2.0),
                };
                let want = math::pow(x as f64, y as f64) as f32;
                assert_eq!(powf(x, y).to_bits(), want.to_bits(), "{x:e}^{y}");
                if i % 3 != 2 {
                    fast += powf_whole(x, y).is_some() as usize;
                }
            }
        }
        for (x, y) in [
            (1.0f32, 7.0f32),
            (0.0, 3.0),
            (-0.0, 3.0),
            (-0.0, 150.0),
            (-0.0, 0.5),
            (0.0, 150.0),
            (-0.0, 16_777_215.0),
            (-0.0, 3e9),
            (0.0, 0.0),
            (-0.0, -3.0),
            (-0.0, -2.0),
            (0.5, 0.5),
            (1e-45, 2.0),
            (0.9, 70_000.0),
        ] {
            assert_eq!(
                powf(x, y).to_bits(),
                (math::pow(x as f64, y as f64) as f32).to_bits()
            );
        }
        // Nearly every power that does not underflow takes the fast path.
        let tried = 207 * 4000 * 2 / 3;
        assert!(fast > tried * 97 / 100, "{fast} of {tried}");
    }

    /// Every sample the reference arithmetic finds inside lies within [`inside_span`], and the
    /// span is tight (a sample or two wider at each end): random perspective and
    /// orthographic rays, grazing and missing ones included, through sheared volumes
    /// far from the origin (large coordinates, so f32 rounding is coarse), for supports
    /// 1 to 4.
    #[test]
    fn inside_span_holds_every_inside_sample() {
        fn one<K: Kernel<S>, const S: usize>(rng: &mut Lcg, seen: &mut [usize; 4]) {
            let sz = [
                2 + (rng.next() * 12.0) as usize,
                2 + (rng.next() * 12.0) as usize,
                2 + (rng.next() * 12.0) as usize,
            ];
            let data = alloc::vec![0.0f32; sz[0] * sz[1] * sz[2]];
            let far = if rng.next() < 0.5 { 0.0 } else { 3000.0 };
            let mut c = |s: f64| (rng.next() as f64 - 0.5) * s;
            let origin = [far + c(4.0), c(4.0) - far, c(4.0)];
            let itow = Affine4::from_columns(
                [0.7 + c(0.2), c(0.3), c(0.3)],
                [c(0.3), 0.9 + c(0.2), c(0.3)],
                [c(0.3), c(0.3), 1.1 + c(0.2)],
                origin,
            );
            let vol = Volume::new(&data, sz, itow).unwrap();
            let at = itow.point([sz[0] as f64 / 2.0, sz[1] as f64 / 2.0, sz[2] as f64 / 2.0]);
            let fr = [at[0] + 20.0 + c(10.0), at[1] + c(30.0), at[2] + c(30.0)];
            let spec = CameraSpec {
                from: fr,
                at: [at[0] + c(4.0), at[1] + c(4.0), at[2] + c(4.0)],
                up: [0.0, 0.0, 1.0],
                near: -15.0 - c(10.0).abs(),
                far: 15.0 + c(10.0).abs(),
                fov: 20.0 + c(30.0),
                size: [9, 7],
                orthographic: c(1.0) > 0.0,
            };
            let cam = RefCamera::new(&spec);
            let sep = [0.013f32, 0.1, 0.37, 1.0][(rng.next() * 4.0) as usize];
            let kmax = ((cam.fcv - cam.ncv) / sep) as u32;
            let wtoi = RefIndex::new(&itow);
            let vix = ViewIndex::new(&cam, &wtoi);
            for vi in 0..7 {
                for hi in 0..9 {
                    let ray = cam.ray(hi, vi, sep, 1.0);
                    let span = inside_span::<f32, K, S>(vix.line(&ray, kmax).as_ref(), &vol, kmax);
                    let mut inside = alloc::vec::Vec::new();
                    for k in 0..=kmax {
                        // The reference arithmetic's own sample position and inside rule.
                        let kf = k as f32;
                        let pv = core::array::from_fn(|a| ray.start[a] + kf * ray.step[a]);
                        let pi = wtoi.point(cam.to_world(pv, 1.0));
                        if place3::<K, S>(pi, [0; 3], vol.sizes()).is_some() {
                            inside.push(k);
                        }
                    }
                    match (span, inside.first(), inside.last()) {
                        (None, None, _) => seen[0] += 1,
                        (Some((a, b)), Some(&lo), Some(&hi)) => {
                            assert!(
                                a <= lo && hi <= b,
                                "{}: inside {lo}..={hi}, span {a}..={b}",
                                K::NAME
                            );
                            // Usually a sample or two wider; more where the bound
                            // spans several short steps or a ray grazes a face.
                            seen[1] += 1;
                            if far == 0.0 {
                                seen[2] += 1;
                                seen[3] += usize::from(lo - a <= 2 && b - hi <= 2);
                            }
                        }
                        // A span that holds nothing (a ray grazing a face within the
                        // rounding bound): allowed, it only costs time.
                        (Some(_), None, _) => {}
                        (None, Some(lo), _) => panic!("{}: sample {lo} inside, no span", K::NAME),
                        _ => unreachable!(),
                    }
                }
            }
        }
        let mut rng = Lcg(2024);
        let mut seen = [0usize; 4];
        for _ in 0..40 {
            one::<BoxK, 1>(&mut rng, &mut seen);
            one::<Tent, 2>(&mut rng, &mut seen);
            one::<Bspln2, 3>(&mut rng, &mut seen);
            one::<Bspln3, 4>(&mut rng, &mut seen);
        }
        // Both kinds of ray occur often, and near the origin the span is tight for
        // nearly every ray.
        assert!(seen[0] > 500 && seen[1] > 2000, "{seen:?}");
        assert!(seen[3] * 100 > seen[2] * 95, "{seen:?}");
    }
}
