//! Separable 3-D convolution at a point: the inside rule (every sample of the kernel's
//! support lies in the volume), value, index- and
//! world-space gradient.
//!
//! [`Convo`] is generic over the voxel type `V`, the kernel `K` and its support `S`, so
//! every loop below runs over compile-time-sized arrays and is monomorphized per
//! (voxel, kernel) pair. The rows of the S×S×S neighbourhood are read straight from the
//! volume (support 4 on x86_64 with SSE, i16 converted in registers), and batches of
//! samples are convolved phase by phase (offsets and weights of all, then all sums) so
//! that the processor overlaps independent samples.

use core::marker::PhantomData;

use crate::kernel::Kernel;
#[cfg(target_arch = "x86_64")]
use crate::simd::sse;
use crate::simd::{Simd, Supports};
use crate::volume::Volume;
use crate::voxel::Voxel;

/// Result of one convolution.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ConvoSample {
    /// Index-space position that was evaluated.
    pub pos_i: [f64; 3],
    /// Whether the kernel support lies entirely inside the volume; when false the other
    /// fields are zero.
    pub inside: bool,
    /// Reconstructed value.
    pub value: f32,
    /// Gradient in index space (per unit index step); zero unless asked for.
    pub grad_i: [f32; 3],
    /// Gradient in world space; zero unless asked for.
    pub grad_w: [f32; 3],
}

/// Value and world-space first and second derivatives at a point: see
/// [`Convo::second_order_world`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SecondOrder {
    /// Reconstructed value.
    pub value: f64,
    /// Gradient (per world unit).
    pub gradient: [f64; 3],
    /// Hessian (per world unit squared), symmetric.
    pub hessian: [[f64; 3]; 3],
}

impl SecondOrder {
    /// The principal curvatures κ1 ≥ κ2 of the isosurface through the point, with
    /// Teem's conventions: the normal is n = −∇f/|∇f|, P = I − n nᵀ projects onto the
    /// tangent plane, G = −P H P / |∇f|, and with T = trace G and F its Frobenius norm,
    /// κ = (T ± √(2F² − T²)) / 2 (the root taken as 0 where rounding makes it negative).
    /// Both are 0 where |∇f| ≤ `min_grad` (the isosurface is not defined there).
    ///
    /// ```
    /// use rnd_core::convo::SecondOrder;
    ///
    /// // f = x² + y² + z² at (3, 0, 0): the sphere of radius 3, normal pointing inwards
    /// // (−∇f), so both curvatures are −1/3 with this sign convention.
    /// let s = SecondOrder {
    ///     value: 9.0,
    ///     gradient: [6.0, 0.0, 0.0],
    ///     hessian: [[2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0]],
    /// };
    /// let [k1, k2] = s.curvatures(0.0);
    /// assert!((k1 + 1.0 / 3.0).abs() < 1e-12 && (k2 + 1.0 / 3.0).abs() < 1e-12);
    /// ```
    pub fn curvatures(&self, min_grad: f64) -> [f64; 2] {
        let g = self.gradient;
        let len = crate::math::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
        if !(len > min_grad) {
            return [0.0, 0.0];
        }
        let n = [-g[0] / len, -g[1] / len, -g[2] / len];
        let p: [[f64; 3]; 3] = core::array::from_fn(|r| {
            core::array::from_fn(|c| f64::from(u8::from(r == c)) - n[r] * n[c])
        });
        let mul = |a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]| -> [[f64; 3]; 3] {
            core::array::from_fn(|r| {
                core::array::from_fn(|c| (0..3).map(|k| a[r][k] * b[k][c]).sum())
            })
        };
        let php = mul(&p, &mul(&self.hessian, &p));
        let gt: [[f64; 3]; 3] =
            core::array::from_fn(|r| core::array::from_fn(|c| -php[r][c] / len));
        let t = gt[0][0] + gt[1][1] + gt[2][2];
        let f2: f64 = gt.iter().flatten().map(|x| x * x).sum();
        let d = crate::math::sqrt((2.0 * f2 - t * t).max(0.0));
        [0.5 * (t + d), 0.5 * (t - d)]
    }
}

/// Value, world gradient and world Hessian of `vol` with kernel `K` for the support
/// starting at `n` (inside the volume) and fractional offsets `alpha`, summed in f64:
/// the body of [`Convo::second_order_world`], shared with the renderer's second-order
/// probes (which place their samples in their own arithmetic).
pub(crate) fn second_order_at<V: Voxel, K: Kernel<S>, const S: usize>(
    vol: &Volume<'_, V>,
    n: [i64; 3],
    alpha: [f64; 3],
) -> SecondOrder {
    let tab = |a: usize, f: fn(f64) -> f64| -> [f64; S] {
        core::array::from_fn(|i| f(alpha[a] - (K::LO + i as i32) as f64))
    };
    let w: [[f64; S]; 3] = core::array::from_fn(|a| tab(a, K::k::<f64>));
    let d: [[f64; S]; 3] = core::array::from_fn(|a| tab(a, K::d1::<f64>));
    let dd: [[f64; S]; 3] = core::array::from_fn(|a| tab(a, K::d2::<f64>));
    let sz = vol.sizes();
    let data = vol.data();
    let (mut v, mut g, mut h) = (0.0f64, [0.0f64; 3], [[0.0f64; 3]; 3]);
    for k in 0..S {
        for j in 0..S {
            let row = (n[0] as usize)
                + vol.row_stride() * ((n[1] as usize + j) + sz[1] * (n[2] as usize + k));
            for i in 0..S {
                let Some(x) = data.get(row + i) else {
                    continue;
                };
                let x = x.to_f32() as f64;
                let (w0, w1, w2) = (w[0][i], w[1][j], w[2][k]);
                let (d0, d1, d2) = (d[0][i], d[1][j], d[2][k]);
                v += x * w0 * w1 * w2;
                g[0] += x * d0 * w1 * w2;
                g[1] += x * w0 * d1 * w2;
                g[2] += x * w0 * w1 * d2;
                h[0][0] += x * dd[0][i] * w1 * w2;
                h[1][1] += x * w0 * dd[1][j] * w2;
                h[2][2] += x * w0 * w1 * dd[2][k];
                h[0][1] += x * d0 * d1 * w2;
                h[0][2] += x * d0 * w1 * d2;
                h[1][2] += x * w0 * d1 * d2;
            }
        }
    }
    (h[1][0], h[2][0], h[2][1]) = (h[0][1], h[0][2], h[1][2]);
    let m = vol.wtoi();
    let gradient = core::array::from_fn(|c| (0..3).map(|a| g[a] * m.at(a, c)).sum());
    let hessian = core::array::from_fn(|r| {
        core::array::from_fn(|c| {
            let mut sum = 0.0;
            for a in 0..3 {
                for b in 0..3 {
                    sum += m.at(a, r) * h[a][b] * m.at(b, c);
                }
            }
            sum
        })
    });
    SecondOrder {
        value: v,
        gradient,
        hessian,
    }
}

/// Per-thread convolution state over one volume with kernel `K` of support `S`.
#[derive(Debug, Clone)]
pub struct Convo<'v, V: Voxel, K: Kernel<S>, const S: usize> {
    vol: Volume<'v, V>,
    /// Sizes of the samples held and the grid index of the first (see
    /// [`Volume::region`]).
    sizes: [i64; 3],
    org: [i64; 3],
    /// Transpose of WtoI's 3×3 (maps index-space gradients to world space).
    gmat: [[f32; 3]; 3],
    /// The vector level of batches (the same bits at every level, see [`crate::simd`]).
    simd: Simd,
    _k: PhantomData<K>,
}

/// Largest |index coordinate| considered; beyond this everything is outside (keeps the
/// integer arithmetic far from overflow).
pub(crate) const INDEX_LIMIT: f64 = 1e12;

impl<'v, V: Voxel, K: Kernel<S>, const S: usize> Convo<'v, V, K, S> {
    /// New convolution state for `vol`, with the best vector level the processor has.
    pub fn new(vol: Volume<'v, V>) -> Self {
        Self::with_simd(vol, Simd::detect())
    }

    /// New convolution state for `vol` using vector level `simd` (the same bits at every
    /// level).
    pub fn with_simd(vol: Volume<'v, V>, simd: Simd) -> Self {
        let w = vol.wtoi();
        let mut gmat = [[0.0f32; 3]; 3];
        for (r, row) in gmat.iter_mut().enumerate() {
            for (c, e) in row.iter_mut().enumerate() {
                *e = w.at(c, r) as f32;
            }
        }
        let s = vol.sizes();
        Convo {
            vol,
            sizes: [s[0] as i64, s[1] as i64, s[2] as i64],
            org: vol.origin().map(|o| o as i64),
            gmat,
            simd,
            _k: PhantomData,
        }
    }

    /// The volume.
    pub fn volume(&self) -> &Volume<'v, V> {
        &self.vol
    }

    /// Value, gradient and Hessian at world point `pos_w`, summed in f64 with the
    /// kernel's f64 weights and its first and second derivatives (for probing; the
    /// renderer's sums are f32). The world-space derivatives come through WtoI's linear
    /// part M: ∇_w f = Mᵀ ∇_i f and H_w = Mᵀ H_i M, so sheared and rotated grids are
    /// exact. `None` where the inside rule fails (or the point is not finite).
    pub fn second_order_world(&self, pos_w: [f64; 3]) -> Option<SecondOrder> {
        let pos_i = self.vol.wtoi().point(pos_w);
        let (n, alpha) = self.place3(pos_i)?;
        Some(second_order_at::<V, K, S>(&self.vol, n, alpha))
    }

    /// Convolution at world point `pos_w`; the gradient only when `grad` is true.
    #[inline]
    pub fn eval_world(&mut self, pos_w: [f64; 3], grad: bool) -> ConvoSample {
        let pos_i = self.vol.wtoi().point(pos_w);
        self.eval_index(pos_i, grad)
    }

    /// The first support index on each axis for index-space point `pos_i` (counted from
    /// [`Volume::origin`]), when the whole support is inside the samples held (the
    /// inside rule), else None.
    #[inline(always)]
    pub fn support_start(&self, pos_i: [f64; 3]) -> Option<[i64; 3]> {
        self.place3(pos_i).map(|(n, _)| n)
    }

    /// [`place`] on all three axes: first support indices and fractional offsets when
    /// the support is inside on every axis.
    #[inline(always)]
    fn place3(&self, pos_i: [f64; 3]) -> Option<([i64; 3], [f64; 3])> {
        let mut n = [0i64; 3];
        let mut alpha = [0.0f64; 3];
        for a in 0..3 {
            let Place::Inside(b, al) = place::<K, S>(pos_i[a], self.org[a], self.sizes[a]) else {
                return None;
            };
            n[a] = b;
            alpha[a] = al;
        }
        Some((n, alpha))
    }

    /// Convolution at index-space point `pos_i`.
    #[inline]
    pub fn eval_index(&mut self, pos_i: [f64; 3], grad: bool) -> ConvoSample {
        let mut out = ConvoSample {
            pos_i,
            ..ConvoSample::default()
        };
        let Some((n, alpha)) = self.place3(pos_i) else {
            return out;
        };
        out.inside = true;
        let (value, grad_i, grad_w) = self.convolve(n, alpha, grad);
        out.value = value;
        out.grad_i = grad_i;
        out.grad_w = grad_w;
        out
    }

    /// The separable sums for first support indices `n` (inside the volume) and
    /// fractional offsets `alpha`: value, index- and world-space gradient (zero unless
    /// `grad`). Support indices outside the volume panic rather than read out of bounds.
    #[inline(always)]
    pub(crate) fn convolve(
        &mut self,
        n: [i64; 3],
        alpha: [f64; 3],
        grad: bool,
    ) -> (f32, [f32; 3], [f32; 3]) {
        if grad {
            let r = self.sums::<true>(n, alpha);
            let gi = [r[1], r[2], r[3]];
            (r[0], gi, grad_to_world(&self.gmat, gi))
        } else {
            (self.sums::<false>(n, alpha)[0], [0.0; 3], [0.0; 3])
        }
    }

    /// The matrix that maps index-space gradients to world space.
    #[inline(always)]
    pub(crate) fn grad_matrix(&self) -> [[f32; 3]; 3] {
        self.gmat
    }

    /// [value, ∂x, ∂y, ∂z] in index space (the last three only when `G`) for first
    /// support indices `n` (inside the volume) and fractional offsets `alpha`, by
    /// [`sums`]; support 4 on x86_64 reads the rows straight from the volume with SSE.
    #[inline(always)]
    pub(crate) fn sums<const G: bool>(&self, n: [i64; 3], alpha: [f64; 3]) -> [f32; 4] {
        let mut out = [[0.0; 4]];
        self.sums_n::<G, 1>(&[n], &[alpha], &mut out);
        out[0]
    }

    /// The sums of the first `m` of N samples: a whole batch through [`Convo::sums_n`],
    /// a partial one sample by sample (the same bits either way).
    #[inline(always)]
    pub(crate) fn sums_first<const G: bool, const N: usize>(
        &self,
        n: &[[i64; 3]; N],
        alpha: &[[f64; 3]; N],
        m: usize,
        out: &mut [[f32; 4]; N],
    ) {
        if m == N {
            self.sums_n::<G, N>(n, alpha, out);
        } else {
            for i in 0..m {
                out[i] = self.sums::<G>(n[i], alpha[i]);
            }
        }
    }

    /// [`Convo::sums_n`] for the N consecutive samples k, k + 1, … of the index-space
    /// ray `start + k step`, all of which the caller knows satisfy the inside rule
    /// (positions and offsets as [`locate`] computes them).
    #[inline(always)]
    pub(crate) fn sums_run<const G: bool, const N: usize>(
        &self,
        start: &[f64; 3],
        step: &[f64; 3],
        k: u32,
        out: &mut [[f32; 4]; N],
    ) {
        #[cfg(target_arch = "x86_64")]
        if let (4, Some(co)) = (S, K::CUBIC4) {
            let (s0, s01) = (self.vol.row_stride(), self.vol.slice_stride());
            let (data, lo) = (self.vol.data(), K::LO as i64);
            if crate::simd::cubic_run::<V, G, N>(
                self.simd, data, s0, s01, lo, start, step, k, &co, out,
            ) {
                return;
            }
        }
        let mut n = [[0i64; 3]; N];
        let mut alpha = [[0.0f64; 3]; N];
        for i in 0..N {
            let kf = (k + i as u32) as f64;
            (n[i], alpha[i]) = locate::<K, S>(core::array::from_fn(|a| start[a] + kf * step[a]));
        }
        self.sums_n::<G, N>(&n, &alpha, out);
    }

    /// [`Convo::sums`] for N samples at once, each result bit for bit what
    /// [`Convo::sums`] gives. With SSE the work is split into phases over all N samples
    /// (support offsets and weights for every sample, then every sample's sums) so that
    /// each phase is a short dependency chain per sample the processor can overlap,
    /// instead of one long chain per sample.
    #[inline(always)]
    pub(crate) fn sums_n<const G: bool, const N: usize>(
        &self,
        n: &[[i64; 3]; N],
        alpha: &[[f64; 3]; N],
        out: &mut [[f32; 4]; N],
    ) {
        let (s0, s01) = (self.vol.row_stride(), self.vol.slice_stride());
        let base: [usize; N] = core::array::from_fn(|i| {
            let n = n[i];
            n[0] as usize + s0 * n[1] as usize + s01 * n[2] as usize
        });
        let sup = Supports::<V, S, N>::new(self.vol.data(), base, s0, s01);
        #[cfg(target_arch = "x86_64")]
        if let Some(co) = K::CUBIC4 {
            if sup.cubic_sums::<G>(self.simd, alpha, &co, out) {
                return;
            }
        }
        #[cfg(target_arch = "x86_64")]
        if S == 4 {
            let weights = |i: usize, a: usize, d: usize| -> sse::F4 {
                let x = alpha[i][a];
                match K::CUBIC4 {
                    Some(co) => sse::horner(&co[d], x as f32),
                    None => {
                        let v = if d == 0 {
                            K::weights(x)
                        } else {
                            K::weights_d1(x)
                        };
                        sse::load(&[v[0], v[1], v[2], v[3]])
                    }
                }
            };
            let w: [[sse::F4; 3]; N] =
                core::array::from_fn(|i| core::array::from_fn(|a| weights(i, a, 0)));
            let d: [[sse::F4; 3]; N] = core::array::from_fn(|i| {
                core::array::from_fn(|a| if G { weights(i, a, 1) } else { sse::zero() })
            });
            for i in 0..N {
                out[i] = sse::sums4::<G>(|j, k| sup.row4(i, j, k), &w[i], &d[i]);
            }
            return;
        }
        #[cfg(target_arch = "x86_64")]
        if S == 2 {
            let w: [[[f32; 2]; 3]; N] =
                core::array::from_fn(|i| alpha[i].map(|a| two(K::weights(a))));
            let d: [[[f32; 2]; 3]; N] = core::array::from_fn(|i| {
                if G {
                    alpha[i].map(|a| two(K::weights_d1(a)))
                } else {
                    [[0.0; 2]; 3]
                }
            });
            for i in 0..N {
                out[i] = sse::sums2::<G>(sup.rows2(i), &w[i], &d[i]);
            }
            return;
        }
        // Other supports: the same two phases, rows read from the volume and converted.
        let w: [[[f32; S]; 3]; N] = core::array::from_fn(|i| alpha[i].map(K::weights));
        let d: [[[f32; S]; 3]; N] = core::array::from_fn(|i| {
            if G {
                alpha[i].map(K::weights_d1)
            } else {
                [[0.0; S]; 3]
            }
        });
        for i in 0..N {
            out[i] = sums::<S, G>(|j, k| sup.row(i, j, k), &w[i], &d[i]);
        }
    }
}

/// The first two weights (the whole support when S = 2).
#[inline(always)]
fn two<const S: usize>(w: [f32; S]) -> [f32; 2] {
    [w[0], w[1 % S]]
}

/// Where index coordinate `x` puts a kernel support on an axis of `size` samples (the
/// inside rule).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Place {
    /// The support starts before the first sample (or `x` is NaN or hugely negative).
    Below,
    /// Inside: first support index and fractional offset.
    Inside(i64, f64),
    /// The support ends after the last sample (or `x` is hugely positive).
    Above,
}

/// The inside rule on one axis for kernel `K`, for the `size` samples held from grid
/// index `org` on (the first support index returned counts from `org`).
#[inline(always)]
pub(crate) fn place<K: Kernel<S>, const S: usize>(x: f64, org: i64, size: i64) -> Place {
    if !(x > -INDEX_LIMIT) {
        return Place::Below;
    }
    if !(x < INDEX_LIMIT) {
        return Place::Above;
    }
    let (b, alpha) = K::base(x);
    let first = b + K::LO as i64 - org;
    if first < 0 {
        Place::Below
    } else if first + S as i64 > size {
        Place::Above
    } else {
        Place::Inside(first, alpha)
    }
}

/// First support indices and fractional offsets for index-space point `pos_i`, which
/// the caller knows satisfies the inside rule (see [`place`]); the same arithmetic.
#[inline(always)]
pub(crate) fn locate<K: Kernel<S>, const S: usize>(pos_i: [f64; 3]) -> ([i64; 3], [f64; 3]) {
    let mut n = [0i64; 3];
    let mut alpha = [0.0f64; 3];
    for a in 0..3 {
        let (b, al) = K::base(pos_i[a]);
        n[a] = b + K::LO as i64;
        alpha[a] = al;
    }
    (n, alpha)
}

/// Index-space gradient `g` to world space by matrix `m` (the transpose of WtoI's 3×3).
#[inline(always)]
pub(crate) fn grad_to_world(m: &[[f32; 3]; 3], g: [f32; 3]) -> [f32; 3] {
    [
        m[0][0] * g[0] + m[0][1] * g[1] + m[0][2] * g[2],
        m[1][0] * g[0] + m[1][1] * g[1] + m[1][2] * g[2],
        m[2][0] * g[0] + m[2][1] * g[1] + m[2][2] * g[2],
    ]
}

/// World-space gradient magnitudes of N samples from their index-space sums `r` (each
/// [value, ∂x, ∂y, ∂z]) and the matrix `m` of [`grad_to_world`]: for each sample
/// `sqrt(gx² + gy² + gz²)` of `grad_to_world(m, ..)`, the same operations (four samples
/// per SSE vector on x86_64), so the same bits.
#[inline(always)]
pub(crate) fn world_gmags<const N: usize>(m: &[[f32; 3]; 3], r: &[[f32; 4]; N]) -> [f32; N] {
    let mut out = [0.0f32; N];
    let mut done = 0;
    #[cfg(target_arch = "x86_64")]
    while done + 4 <= N {
        let q: &[[f32; 4]; 4] = r[done..done + 4].try_into().expect("four samples");
        out[done..done + 4].copy_from_slice(&sse::world_gmag4(m, q));
        done += 4;
    }
    for i in done..N {
        let g = grad_to_world(m, [r[i][1], r[i][2], r[i][3]]);
        out[i] = crate::math::sqrtf(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
    }
    out
}

/// The separable sums [value, ∂x, ∂y, ∂z] (the last three only when `G`) over the
/// S×S×S neighbourhood whose row j of slice k is `row(j, k)` (S voxels along x), for
/// value weights `w` and derivative weights `d` per axis (x, y, z).
///
/// The order of operations is fixed (and [`sse::sums4`] follows it lane for lane, so both
/// give the same bits): for each row j, reduce along z (`p_j = Σ_k wz_k row(j, k)`, and
/// `q_j` with dz), then along y (`acc = Σ_j wy_j p_j`, `accy` with dy, `accz = Σ_j wy_j
/// q_j`), then along x; every sum starts from its first product and adds in index order.
#[inline(always)]
pub(crate) fn sums<const S: usize, const G: bool>(
    row: impl Fn(usize, usize) -> [f32; S],
    w: &[[f32; S]; 3],
    d: &[[f32; S]; 3],
) -> [f32; 4] {
    let [wx, wy, wz] = w;
    let [dx, dy, dz] = d;
    let mut acc = [0.0f32; S];
    let mut accy = [0.0f32; S];
    let mut accz = [0.0f32; S];
    for j in 0..S {
        let r0 = row(j, 0);
        let mut p: [f32; S] = core::array::from_fn(|i| wz[0] * r0[i]);
        let mut q: [f32; S] = core::array::from_fn(|i| dz[0] * r0[i]);
        for k in 1..S {
            let r = row(j, k);
            for i in 0..S {
                p[i] += wz[k] * r[i];
                if G {
                    q[i] += dz[k] * r[i];
                }
            }
        }
        for i in 0..S {
            if j == 0 {
                acc[i] = wy[0] * p[i];
                accy[i] = dy[0] * p[i];
                accz[i] = wy[0] * q[i];
            } else {
                acc[i] += wy[j] * p[i];
                if G {
                    accy[i] += dy[j] * p[i];
                    accz[i] += wy[j] * q[i];
                }
            }
        }
    }
    let dot = |u: &[f32; S], v: &[f32; S]| {
        let mut s = u[0] * v[0];
        for i in 1..S {
            s += u[i] * v[i];
        }
        s
    };
    if G {
        [dot(wx, &acc), dot(dx, &acc), dot(wx, &accy), dot(wx, &accz)]
    } else {
        [dot(wx, &acc), 0.0, 0.0, 0.0]
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    extern crate std;

    use super::*;

    use crate::test_rng::Lcg;

    /// The SSE sums are bit-identical to the generic loop (the order of operations is
    /// the same), value only and with the gradient.
    #[test]
    fn sse_sums_match_generic_bit_for_bit() {
        let mut g = Lcg(7);
        for _ in 0..2000 {
            let nb: [[[f32; 4]; 4]; 4] = core::array::from_fn(|_| {
                core::array::from_fn(|_| core::array::from_fn(|_| g.varied()))
            });
            let w: [[f32; 4]; 3] = core::array::from_fn(|_| core::array::from_fn(|_| g.varied()));
            let d: [[f32; 4]; 3] = core::array::from_fn(|_| core::array::from_fn(|_| g.varied()));
            let (wv, dv) = (w.map(|x| sse::load(&x)), d.map(|x| sse::load(&x)));
            let row = |j: usize, k: usize| sse::load(&nb[k][j]);
            let a = sse::sums4::<true>(row, &wv, &dv);
            let b = sums::<4, true>(|j, k| nb[k][j], &w, &d);
            assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits), "{a:?} vs {b:?}");
            let a = sse::sums4::<false>(row, &wv, &dv)[0];
            let b = sums::<4, false>(|j, k| nb[k][j], &w, &d)[0];
            assert_eq!(a.to_bits(), b.to_bits(), "{a} vs {b}");
        }
    }

    /// The SSE support-2 sums are bit-identical to the generic loop, with rows from f32
    /// and from i16 voxels, value only and with the gradient.
    #[test]
    fn sse_sums2_match_generic_bit_for_bit() {
        let mut g = Lcg(5);
        for n in 0..4000 {
            let nb: [[[f32; 2]; 2]; 2] = core::array::from_fn(|_| {
                core::array::from_fn(|_| {
                    core::array::from_fn(|_| {
                        let x = g.varied();
                        if n % 2 == 0 {
                            x
                        } else {
                            (x * 30.0) as i16 as f32
                        }
                    })
                })
            });
            let w: [[f32; 2]; 3] = core::array::from_fn(|_| core::array::from_fn(|_| g.varied()));
            let d: [[f32; 2]; 3] = core::array::from_fn(|_| core::array::from_fn(|_| g.varied()));
            // Rows (j, k) at j * 2 + k * 4 of a flat array, loaded as the volume path does.
            let flat: [f32; 8] = core::array::from_fn(|i| nb[i / 4][(i / 2) % 2][i % 2]);
            let short: [i16; 8] = flat.map(|x| x as i16);
            let rows = if n % 2 == 0 {
                Supports::<f32, 2, 1>::new(&flat, [0], 2, 4).rows2(0)
            } else {
                Supports::<i16, 2, 1>::new(&short, [0], 2, 4).rows2(0)
            };
            let a = sse::sums2::<true>(rows, &w, &d);
            let b = sums::<2, true>(|j, k| nb[k][j], &w, &d);
            assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits), "{a:?} vs {b:?}");
            let a = sse::sums2::<false>(rows, &w, &d)[0];
            let b = sums::<2, false>(|j, k| nb[k][j], &w, &d)[0];
            assert_eq!(a.to_bits(), b.to_bits(), "{a} vs {b}");
        }
    }

    /// Four-at-a-time world gradient magnitudes equal the scalar ones bit for bit.
    #[test]
    fn sse_world_gmags_match_scalar() {
        let mut g = Lcg(9);
        for _ in 0..3000 {
            let m: [[f32; 3]; 3] = core::array::from_fn(|_| core::array::from_fn(|_| g.varied()));
            let r: [[f32; 4]; 8] = core::array::from_fn(|_| core::array::from_fn(|_| g.varied()));
            let a = world_gmags(&m, &r);
            for i in 0..8 {
                let w = grad_to_world(&m, [r[i][1], r[i][2], r[i][3]]);
                let b = crate::math::sqrtf(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
                assert_eq!(a[i].to_bits(), b.to_bits(), "{} vs {b}", a[i]);
            }
        }
    }

    /// The vector Horner evaluation gives the scalar one's bits.
    #[test]
    fn sse_horner_matches_scalar() {
        use crate::kernel::{horner4, Bspln3, Ctmr, Kernel};
        for co in [Bspln3::CUBIC4, Ctmr::CUBIC4].into_iter().flatten() {
            for j in 0..=1000 {
                let a = j as f32 / 1000.0;
                for c in &co {
                    let v = sse::store(sse::horner(c, a));
                    assert_eq!(v.map(f32::to_bits), horner4(c, a).map(f32::to_bits));
                }
            }
        }
    }
    /// The AVX2 pair sums (two samples per 256-bit register) give the bits of the SSE
    /// and generic paths: batches of 8 random samples in random f32 and i16 volumes,
    /// value only and with the gradient, both cubic kernels.
    #[test]
    fn avx_pair_sums_match_sse_bit_for_bit() {
        use crate::affine::Affine4;
        use crate::kernel::{Bspln3, Ctmr};
        use crate::volume::Volume;
        if !Simd::detect().avx2() {
            std::eprintln!("skipped: this processor has no AVX2");
            return;
        }
        fn check<V: Voxel, K: Kernel<4>>(data: &[V], g: &mut Lcg) {
            let sizes = [9, 7, 8];
            let itow = Affine4::from_columns([1., 0., 0.], [0., 1., 0.], [0., 0., 1.], [0.; 3]);
            let vol = Volume::new(data, sizes, itow).unwrap();
            let c = Convo::<V, K, 4>::new(vol);
            let sse =
                Convo::<V, K, 4>::with_simd(vol, Simd::at_most(crate::simd::SimdLevel::Baseline));
            assert!(c.simd.avx2());
            // AVX2 pairs also where the processor would use AVX-512 quads: both checked.
            let pairs =
                Convo::<V, K, 4>::with_simd(vol, Simd::at_most(crate::simd::SimdLevel::Avx2));
            for _ in 0..300 {
                let n: [[i64; 3]; 8] = core::array::from_fn(|_| {
                    core::array::from_fn(|a| {
                        (g.varied().abs() * 97.0) as i64 % (sizes[a] as i64 - 3)
                    })
                });
                let alpha: [[f64; 3]; 8] = core::array::from_fn(|_| {
                    core::array::from_fn(|_| (g.varied().abs() as f64).fract())
                });
                let (mut a, mut b) = ([[0.0f32; 4]; 8], [[0.0f32; 4]; 8]);
                c.sums_n::<true, 8>(&n, &alpha, &mut a);
                sse.sums_n::<true, 8>(&n, &alpha, &mut b);
                assert_eq!(
                    a.map(|r| r.map(f32::to_bits)),
                    b.map(|r| r.map(f32::to_bits))
                );
                pairs.sums_n::<true, 8>(&n, &alpha, &mut a);
                assert_eq!(
                    a.map(|r| r.map(f32::to_bits)),
                    b.map(|r| r.map(f32::to_bits))
                );
                pairs.sums_n::<false, 8>(&n, &alpha, &mut a);
                sse.sums_n::<false, 8>(&n, &alpha, &mut b);
                assert_eq!(
                    a.map(|r| r.map(f32::to_bits)),
                    b.map(|r| r.map(f32::to_bits))
                );
                c.sums_n::<false, 8>(&n, &alpha, &mut a);
                sse.sums_n::<false, 8>(&n, &alpha, &mut b);
                assert_eq!(
                    a.map(|r| r.map(f32::to_bits)),
                    b.map(|r| r.map(f32::to_bits))
                );
                assert_eq!(
                    a[3][0].to_bits(),
                    sse.sums::<false>(n[3], alpha[3])[0].to_bits()
                );
            }
        }
        let mut g = Lcg(11);
        let f: std::vec::Vec<f32> = (0..9 * 7 * 8).map(|_| g.varied()).collect();
        let s: std::vec::Vec<i16> = (0..9 * 7 * 8).map(|_| (g.varied() * 30.0) as i16).collect();
        check::<f32, Bspln3>(&f, &mut g);
        check::<f32, Ctmr>(&f, &mut g);
        check::<i16, Bspln3>(&s, &mut g);
        check::<i16, Ctmr>(&s, &mut g);
    }
}
