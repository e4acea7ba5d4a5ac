//! Separable 3-D convolution at a point (SPEC §7.2): the inside rule, value, index- and
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

/// Per-thread convolution state over one volume with kernel `K` of support `S`.
#[derive(Debug, Clone)]
pub struct Convo<'v, V: Voxel, K: Kernel<S>, const S: usize> {
    vol: Volume<'v, V>,
    sizes: [i64; 3],
    /// Transpose of WtoI's 3×3 (maps index-space gradients to world space).
    gmat: [[f32; 3]; 3],
    /// Whether batches use the AVX2 pair sums, and the AVX-512 quad sums (same bits, see
    /// [`crate::avx`]).
    avx: bool,
    avx512: bool,
    _k: PhantomData<K>,
}

/// Largest |index coordinate| considered; beyond this everything is outside (keeps the
/// integer arithmetic far from overflow).
pub(crate) const INDEX_LIMIT: f64 = 1e12;

impl<'v, V: Voxel, K: Kernel<S>, const S: usize> Convo<'v, V, K, S> {
    /// New convolution state for `vol`, with the best vector level the processor has.
    pub fn new(vol: Volume<'v, V>) -> Self {
        Self::with_simd(vol, crate::avx::Simd::detect())
    }

    /// New convolution state for `vol` using vector level `simd` (the same bits at every
    /// level).
    pub fn with_simd(vol: Volume<'v, V>, simd: crate::avx::Simd) -> Self {
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
            gmat,
            avx: simd.avx2(),
            avx512: simd.avx512(),
            _k: PhantomData,
        }
    }

    /// The volume.
    pub fn volume(&self) -> &Volume<'v, V> {
        &self.vol
    }

    /// Convolution at world point `pos_w`; the gradient only when `grad` is true.
    #[inline]
    pub fn eval_world(&mut self, pos_w: [f64; 3], grad: bool) -> ConvoSample {
        let pos_i = self.vol.wtoi().point(pos_w);
        self.eval_index(pos_i, grad)
    }

    /// The first support index on each axis for index-space point `pos_i`, when the
    /// whole support is inside the volume (the inside rule), else None.
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
            let Place::Inside(b, al) = place::<K, S>(pos_i[a], self.sizes[a]) else {
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
        if let (4, true, 0, Some(co)) = (S, self.avx, N % 4, K::CUBIC4) {
            let (s0, s01) = (
                self.sizes[0] as usize,
                (self.sizes[0] * self.sizes[1]) as usize,
            );
            // SAFETY: AVX2 is available (self.avx), AVX-512F too when self.avx512, and N
            // is a multiple of 4; the supports are checked inside.
            unsafe {
                crate::avx::sums_run::<V, G, N>(
                    self.vol.data(),
                    s0,
                    s01,
                    K::LO as i64,
                    start,
                    step,
                    k,
                    &co,
                    self.avx512,
                    out,
                )
            };
            return;
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
        let data = self.vol.data();
        let (s0, s01) = (
            self.sizes[0] as usize,
            (self.sizes[0] * self.sizes[1]) as usize,
        );
        let base: [usize; N] = core::array::from_fn(|i| {
            let n = n[i];
            let b = n[0] as usize + s0 * n[1] as usize + s01 * n[2] as usize;
            // The support's last voxel; every row below ends at or before it.
            assert!(b + (S - 1) * (1 + s0 + s01) < data.len());
            b
        });
        #[cfg(target_arch = "x86_64")]
        if let (4, true, 0, Some(co)) = (S, self.avx, N % 4, K::CUBIC4) {
            let wide = self.avx512;
            // SAFETY: AVX2 is available (self.avx), AVX-512F too when wide, N is a
            // multiple of 4, and every support's last voxel was checked above.
            unsafe {
                crate::avx::sums_pairs::<V, G, N>(data, &base, s0, s01, alpha, &co, wide, out)
            };
            return;
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
                let b = base[i];
                // SAFETY: row (j, k) for j, k < 4 is the 4 voxels from b + j s0 + k s01,
                // which end at or before the voxel checked above.
                let row = |j: usize, k: usize| unsafe {
                    V::load4(data.as_ptr().add(b + j * s0 + k * s01))
                };
                out[i] = sse::sums4::<G>(row, &w[i], &d[i]);
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
                let b = base[i];
                // SAFETY: rows (j, k) for j, k < 2 are the 2 voxels from b + j s0 + k s01,
                // which end at or before the voxel checked above.
                let rows = unsafe {
                    let p = data.as_ptr().add(b);
                    V::load2x4(p, p.add(s0), p.add(s01), p.add(s0 + s01))
                };
                out[i] = sse::sums2::<G>(rows, &w[i], &d[i]);
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
            let b = base[i];
            let row = |j: usize, k: usize| -> [f32; S] {
                let o = b + j * s0 + k * s01;
                // SAFETY: o + S - 1 is at most the voxel checked above.
                let r = unsafe { data.get_unchecked(o..o + S) };
                core::array::from_fn(|x| r[x].to_f32())
            };
            out[i] = sums::<S, G>(row, &w[i], &d[i]);
        }
    }
}

/// The first two weights (the whole support when S = 2).
#[inline(always)]
fn two<const S: usize>(w: [f32; S]) -> [f32; 2] {
    [w[0], w[1 % S]]
}

/// Where index coordinate `x` puts a kernel support on an axis of `size` samples (the
/// inside rule, SPEC §7.2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Place {
    /// The support starts before the first sample (or `x` is NaN or hugely negative).
    Below,
    /// Inside: first support index and fractional offset.
    Inside(i64, f64),
    /// The support ends after the last sample (or `x` is hugely positive).
    Above,
}

/// The inside rule on one axis for kernel `K`.
#[inline(always)]
pub(crate) fn place<K: Kernel<S>, const S: usize>(x: f64, size: i64) -> Place {
    if !(x > -INDEX_LIMIT) {
        return Place::Below;
    }
    if !(x < INDEX_LIMIT) {
        return Place::Above;
    }
    let (b, alpha) = K::base(x);
    let first = b + K::LO as i64;
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

/// Support-4 sums with SSE (x86_64 baseline).
#[cfg(target_arch = "x86_64")]
pub(crate) mod sse {
    use core::arch::x86_64::*;

    /// Four f32 lanes.
    pub(crate) type F4 = __m128;

    // SAFETY (every `unsafe` block here): SSE and SSE2 are part of the x86_64 baseline, so
    // the intrinsics are always available; loads and stores touch 4-entry f32 arrays.

    /// Zero in all lanes.
    #[inline(always)]
    pub(crate) fn zero() -> __m128 {
        // SAFETY: SSE is x86_64 baseline.
        unsafe { _mm_setzero_ps() }
    }

    /// Four f32 as lanes.
    #[inline(always)]
    pub(crate) fn load(x: &[f32; 4]) -> __m128 {
        // SAFETY: SSE/SSE2 are x86_64 baseline; the load reads the 4 floats of `x`.
        unsafe { _mm_loadu_ps(x.as_ptr()) }
    }

    /// [`crate::kernel::horner4`] in one vector, lane for lane the same operations.
    #[inline(always)]
    pub(crate) fn horner(co: &[[f32; 4]; 4], a: f32) -> __m128 {
        // SAFETY: SSE/SSE2 are x86_64 baseline; every load and store here touches a 4-float array.
        unsafe {
            let a = _mm_set1_ps(a);
            let t = _mm_add_ps(_mm_mul_ps(load(&co[3]), a), load(&co[2]));
            let t = _mm_add_ps(_mm_mul_ps(t, a), load(&co[1]));
            _mm_add_ps(_mm_mul_ps(t, a), load(&co[0]))
        }
    }

    /// Lane `i` of `v` in every lane.
    #[inline(always)]
    fn lane(v: __m128, i: usize) -> __m128 {
        // SAFETY: SSE/SSE2 are x86_64 baseline; every load and store here touches a 4-float array.
        unsafe {
            match i {
                0 => _mm_shuffle_ps::<0x00>(v, v),
                1 => _mm_shuffle_ps::<0x55>(v, v),
                2 => _mm_shuffle_ps::<0xAA>(v, v),
                _ => _mm_shuffle_ps::<0xFF>(v, v),
            }
        }
    }

    /// Four samples of [`super::world_gmags`]: the sums transposed so that each vector
    /// holds one component of all four, then the matrix product and the magnitude
    /// lane by lane (square root correctly rounded, as the scalar one).
    #[inline(always)]
    pub(crate) fn world_gmag4(m: &[[f32; 3]; 3], r: &[[f32; 4]; 4]) -> [f32; 4] {
        let mut out = [0.0f32; 4];
        // SAFETY: SSE/SSE2 are x86_64 baseline; every load and store here touches a 4-float array.
        unsafe {
            let (a, b, c, d) = (load(&r[0]), load(&r[1]), load(&r[2]), load(&r[3]));
            let t0 = _mm_unpacklo_ps(a, b);
            let t1 = _mm_unpacklo_ps(c, d);
            let t2 = _mm_unpackhi_ps(a, b);
            let t3 = _mm_unpackhi_ps(c, d);
            let g = [
                _mm_movehl_ps(t1, t0),
                _mm_movelh_ps(t2, t3),
                _mm_movehl_ps(t3, t2),
            ];
            let row = |i: usize| {
                let x = _mm_mul_ps(_mm_set1_ps(m[i][0]), g[0]);
                let x = _mm_add_ps(x, _mm_mul_ps(_mm_set1_ps(m[i][1]), g[1]));
                _mm_add_ps(x, _mm_mul_ps(_mm_set1_ps(m[i][2]), g[2]))
            };
            let (x, y, z) = (row(0), row(1), row(2));
            let s = _mm_add_ps(
                _mm_add_ps(_mm_mul_ps(x, x), _mm_mul_ps(y, y)),
                _mm_mul_ps(z, z),
            );
            _mm_storeu_ps(out.as_mut_ptr(), _mm_sqrt_ps(s));
        }
        out
    }

    /// [`super::sums`] for S = 2, the same operations in the same order (so bit-identical
    /// to it): `rows` holds rows (0, 0) and (1, 0) in the first vector and rows (0, 1)
    /// and (1, 1) in the second (row (j, k): row j of slice k, 2 voxels along x); `w`
    /// and `d` the value and derivative weights of the x, y and z axes.
    #[inline(always)]
    pub(crate) fn sums2<const G: bool>(
        rows: [__m128; 2],
        w: &[[f32; 2]; 3],
        d: &[[f32; 2]; 3],
    ) -> [f32; 4] {
        let [wx, wy, wz] = w;
        let [dx, dy, dz] = d;
        let mut out = [0.0f32; 4];
        // SAFETY: SSE/SSE2 are x86_64 baseline; every load and store here touches a 4-float array.
        unsafe {
            let [a, b] = rows;
            // Along z: lanes [p_0, p_1] (j = 0) and [p_0, p_1] (j = 1).
            let p = _mm_add_ps(
                _mm_mul_ps(_mm_set1_ps(wz[0]), a),
                _mm_mul_ps(_mm_set1_ps(wz[1]), b),
            );
            // Along y: the j = 0 products plus the j = 1 products.
            let wyv = _mm_set_ps(wy[1], wy[1], wy[0], wy[0]);
            let t1 = _mm_mul_ps(wyv, p);
            if G {
                let q = _mm_add_ps(
                    _mm_mul_ps(_mm_set1_ps(dz[0]), a),
                    _mm_mul_ps(_mm_set1_ps(dz[1]), b),
                );
                let t2 = _mm_mul_ps(_mm_set_ps(dy[1], dy[1], dy[0], dy[0]), p);
                let t3 = _mm_mul_ps(wyv, q);
                // [acc_0, acc_1, accy_0, accy_1] and [accz_0, accz_1, …].
                let x = _mm_add_ps(_mm_movelh_ps(t1, t2), _mm_movehl_ps(t2, t1));
                let z = _mm_add_ps(t3, _mm_movehl_ps(t3, t3));
                // Along x: products, then the two of each sum added.
                let m1 = _mm_mul_ps(x, _mm_set_ps(wx[1], wx[0], wx[1], wx[0]));
                let az = _mm_movelh_ps(x, z);
                let m2 = _mm_mul_ps(az, _mm_set_ps(wx[1], wx[0], dx[1], dx[0]));
                // [v, ∂y, ∂x, ∂z] = even lanes + odd lanes, then reordered.
                let h = _mm_add_ps(
                    _mm_shuffle_ps::<0b10_00_10_00>(m1, m2),
                    _mm_shuffle_ps::<0b11_01_11_01>(m1, m2),
                );
                let s = _mm_shuffle_ps::<0b11_01_10_00>(h, h);
                _mm_storeu_ps(out.as_mut_ptr(), s);
            } else {
                let acc = _mm_add_ps(t1, _mm_movehl_ps(t1, t1));
                let m = _mm_mul_ps(acc, _mm_set_ps(0.0, 0.0, wx[1], wx[0]));
                out[0] = _mm_cvtss_f32(_mm_add_ss(m, _mm_shuffle_ps::<0b01>(m, m)));
            }
        }
        out
    }

    /// [`super::sums`] for S = 4, the same operations in the same order four lanes at a
    /// time (so bit-identical to it); `row(j, k)` gives row j of slice k as 4 lanes, `w`
    /// and `d` the value and derivative weights of the x, y and z axes.
    #[inline(always)]
    pub(crate) fn sums4<const G: bool>(
        row: impl Fn(usize, usize) -> __m128,
        w: &[__m128; 3],
        d: &[__m128; 3],
    ) -> [f32; 4] {
        let mut out = [0.0f32; 4];
        // SAFETY: SSE/SSE2 are x86_64 baseline; every load and store here touches a 4-float array.
        unsafe {
            let (mut acc, mut accy, mut accz) = (zero(), zero(), zero());
            for j in 0..4 {
                let r0 = row(j, 0);
                let mut p = _mm_mul_ps(lane(w[2], 0), r0);
                let mut q = if G {
                    _mm_mul_ps(lane(d[2], 0), r0)
                } else {
                    zero()
                };
                for k in 1..4 {
                    let r = row(j, k);
                    p = _mm_add_ps(p, _mm_mul_ps(lane(w[2], k), r));
                    if G {
                        q = _mm_add_ps(q, _mm_mul_ps(lane(d[2], k), r));
                    }
                }
                let (wy, dy) = (lane(w[1], j), lane(d[1], j));
                if j == 0 {
                    acc = _mm_mul_ps(wy, p);
                    if G {
                        accy = _mm_mul_ps(dy, p);
                        accz = _mm_mul_ps(wy, q);
                    }
                } else {
                    acc = _mm_add_ps(acc, _mm_mul_ps(wy, p));
                    if G {
                        accy = _mm_add_ps(accy, _mm_mul_ps(dy, p));
                        accz = _mm_add_ps(accz, _mm_mul_ps(wy, q));
                    }
                }
            }
            let wx = w[0];
            let m0 = _mm_mul_ps(wx, acc);
            if G {
                let m1 = _mm_mul_ps(d[0], acc);
                let m2 = _mm_mul_ps(wx, accy);
                let m3 = _mm_mul_ps(wx, accz);
                // Transpose so lane c of column i holds product i of sum c, then add the
                // columns in order: lane c = ((m_c0 + m_c1) + m_c2) + m_c3.
                let t0 = _mm_unpacklo_ps(m0, m1);
                let t1 = _mm_unpacklo_ps(m2, m3);
                let t2 = _mm_unpackhi_ps(m0, m1);
                let t3 = _mm_unpackhi_ps(m2, m3);
                let c0 = _mm_movelh_ps(t0, t1);
                let c1 = _mm_movehl_ps(t1, t0);
                let c2 = _mm_movelh_ps(t2, t3);
                let c3 = _mm_movehl_ps(t3, t2);
                let s = _mm_add_ps(_mm_add_ps(_mm_add_ps(c0, c1), c2), c3);
                _mm_storeu_ps(out.as_mut_ptr(), s);
            } else {
                let s = _mm_add_ss(m0, _mm_shuffle_ps::<0b01>(m0, m0));
                let s = _mm_add_ss(s, _mm_shuffle_ps::<0b10>(m0, m0));
                let s = _mm_add_ss(s, _mm_shuffle_ps::<0b11>(m0, m0));
                out[0] = _mm_cvtss_f32(s);
            }
        }
        out
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    extern crate std;

    use super::*;

    /// A small deterministic generator of values in [-1000, 1000) with varied
    /// magnitudes (so round-off differs between operation orders).
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f32 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let u = (self.0 >> 40) as f32 / (1u64 << 24) as f32;
            let e = ((self.0 >> 20) & 7) as i32 - 3;
            (u * 2.0 - 1.0) * 10f32.powi(e)
        }
    }

    /// The SSE sums are bit-identical to the generic loop (the order of operations is
    /// the same), value only and with the gradient.
    #[test]
    fn sse_sums_match_generic_bit_for_bit() {
        let mut g = Lcg(7);
        for _ in 0..2000 {
            let nb: [[[f32; 4]; 4]; 4] = core::array::from_fn(|_| {
                core::array::from_fn(|_| core::array::from_fn(|_| g.next()))
            });
            let w: [[f32; 4]; 3] = core::array::from_fn(|_| core::array::from_fn(|_| g.next()));
            let d: [[f32; 4]; 3] = core::array::from_fn(|_| core::array::from_fn(|_| g.next()));
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
                        let x = g.next();
                        if n % 2 == 0 {
                            x
                        } else {
                            (x * 30.0) as i16 as f32
                        }
                    })
                })
            });
            let w: [[f32; 2]; 3] = core::array::from_fn(|_| core::array::from_fn(|_| g.next()));
            let d: [[f32; 2]; 3] = core::array::from_fn(|_| core::array::from_fn(|_| g.next()));
            // Rows (j, k) at j * 2 + k * 4 of a flat array, loaded as the volume path does.
            let flat: [f32; 8] = core::array::from_fn(|i| nb[i / 4][(i / 2) % 2][i % 2]);
            let short: [i16; 8] = flat.map(|x| x as i16);
            // SAFETY: every pointer has two readable voxels after it.
            let rows = unsafe {
                if n % 2 == 0 {
                    let p = flat.as_ptr();
                    f32::load2x4(p, p.add(2), p.add(4), p.add(6))
                } else {
                    let p = short.as_ptr();
                    i16::load2x4(p, p.add(2), p.add(4), p.add(6))
                }
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
            let m: [[f32; 3]; 3] = core::array::from_fn(|_| core::array::from_fn(|_| g.next()));
            let r: [[f32; 4]; 8] = core::array::from_fn(|_| core::array::from_fn(|_| g.next()));
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
                    let mut v = [0.0f32; 4];
                    // SAFETY: SSE is x86_64 baseline; the store writes 4 f32 to `v`.
                    unsafe { core::arch::x86_64::_mm_storeu_ps(v.as_mut_ptr(), sse::horner(c, a)) };
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
        if !crate::avx::Simd::detect().avx2() {
            std::eprintln!("skipped: this processor has no AVX2");
            return;
        }
        fn check<V: Voxel, K: Kernel<4>>(data: &[V], g: &mut Lcg) {
            let sizes = [9, 7, 8];
            let itow = Affine4::from_columns([1., 0., 0.], [0., 1., 0.], [0., 0., 1.], [0.; 3]);
            let vol = Volume::new(data, sizes, itow).unwrap();
            let c = Convo::<V, K, 4>::new(vol);
            let mut sse = Convo::<V, K, 4>::new(vol);
            assert!(c.avx);
            sse.avx = false;
            // AVX2 pairs also where the processor would use AVX-512 quads: both checked.
            let mut pairs = Convo::<V, K, 4>::new(vol);
            pairs.avx512 = false;
            for _ in 0..300 {
                let n: [[i64; 3]; 8] = core::array::from_fn(|_| {
                    core::array::from_fn(|a| (g.next().abs() * 97.0) as i64 % (sizes[a] as i64 - 3))
                });
                let alpha: [[f64; 3]; 8] = core::array::from_fn(|_| {
                    core::array::from_fn(|_| (g.next().abs() as f64).fract())
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
        let f: std::vec::Vec<f32> = (0..9 * 7 * 8).map(|_| g.next()).collect();
        let s: std::vec::Vec<i16> = (0..9 * 7 * 8).map(|_| (g.next() * 30.0) as i16).collect();
        check::<f32, Bspln3>(&f, &mut g);
        check::<f32, Ctmr>(&f, &mut g);
        check::<i16, Bspln3>(&s, &mut g);
        check::<i16, Ctmr>(&s, &mut g);
    }
}
