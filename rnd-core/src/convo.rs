//! Separable 3-D convolution at a point (SPEC §7.2): the inside rule, value, index- and
//! world-space gradient.
//!
//! [`Convo`] is generic over the voxel type `V`, the kernel `K` and its support `S`, so
//! every loop below runs over compile-time-sized arrays and is monomorphized per
//! (voxel, kernel) pair. It caches the S×S×S voxel neighbourhood and reuses it while the
//! integer base index does not change (consecutive ray samples often share it).

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
    base: [i64; 3],
    have: bool,
    nb: [[[f32; S]; S]; S],
    _k: PhantomData<K>,
}

/// Largest |index coordinate| considered; beyond this everything is outside (keeps the
/// integer arithmetic far from overflow).
const INDEX_LIMIT: f64 = 1e12;

impl<'v, V: Voxel, K: Kernel<S>, const S: usize> Convo<'v, V, K, S> {
    /// New convolution state for `vol`.
    pub fn new(vol: Volume<'v, V>) -> Self {
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
            base: [0; 3],
            have: false,
            nb: [[[0.0; S]; S]; S],
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
        let mut n = [0i64; 3];
        for a in 0..3 {
            let x = pos_i[a];
            if !(x > -INDEX_LIMIT && x < INDEX_LIMIT) {
                return None;
            }
            let lo = K::base(x).0 + K::LO as i64;
            if lo < 0 || lo + S as i64 > self.sizes[a] {
                return None;
            }
            n[a] = lo;
        }
        Some(n)
    }

    /// Convolution at index-space point `pos_i`.
    #[inline]
    pub fn eval_index(&mut self, pos_i: [f64; 3], grad: bool) -> ConvoSample {
        let mut out = ConvoSample {
            pos_i,
            ..ConvoSample::default()
        };
        let mut n = [0i64; 3];
        let mut alpha = [0.0f64; 3];
        for a in 0..3 {
            let x = pos_i[a];
            if !(x > -INDEX_LIMIT && x < INDEX_LIMIT) {
                return out;
            }
            let (b, al) = K::base(x);
            let lo = b + K::LO as i64;
            if lo < 0 || lo + S as i64 > self.sizes[a] {
                return out;
            }
            n[a] = lo;
            alpha[a] = al;
        }
        out.inside = true;
        let wx = K::weights(alpha[0]);
        let wy = K::weights(alpha[1]);
        let wz = K::weights(alpha[2]);
        // f32 voxels with support 4 are read straight from the volume's rows; otherwise
        // from the cached (converted) neighbourhood.
        let direct = if S == 4 && cfg!(target_arch = "x86_64") {
            V::as_f32_slice(self.vol.data())
        } else {
            None
        };
        let (s0, s01) = (
            self.sizes[0] as usize,
            (self.sizes[0] * self.sizes[1]) as usize,
        );
        let base = n[0] as usize + s0 * n[1] as usize + s01 * n[2] as usize;
        if let Some(d) = direct {
            // The inside rule put the whole 4×4×4 support in the volume; check its last
            // voxel once instead of every row.
            assert!(base + 3 + 3 * s0 + 3 * s01 < d.len());
        } else if !self.have || n != self.base {
            self.load(n);
        }
        let nb = &self.nb;
        // SAFETY (direct rows): for j, k < 4 the row [o, o + 4) ends at or before the
        // voxel checked above, which is inside `d`.
        let row = |j: usize, k: usize| -> &[f32] {
            match direct {
                Some(d) => unsafe {
                    d.get_unchecked(base + s0 * j + s01 * k..base + s0 * j + s01 * k + 4)
                },
                None => &nb[k][j][..],
            }
        };
        // Separable sums arranged so the innermost loop runs along x over S lanes with
        // one combined y·z weight per row.
        if !grad {
            #[cfg(target_arch = "x86_64")]
            if S == 4 {
                out.value = value4(row, &wx, &wy, &wz);
                return out;
            }
            let mut acc = [0.0f32; S];
            for k in 0..S {
                for j in 0..S {
                    let w = wy[j] * wz[k];
                    let r = row(j, k);
                    for i in 0..S {
                        acc[i] += w * r[i];
                    }
                }
            }
            let mut val = 0.0f32;
            for i in 0..S {
                val += wx[i] * acc[i];
            }
            out.value = val;
            return out;
        }
        let dx = K::weights_d1(alpha[0]);
        let dy = K::weights_d1(alpha[1]);
        let dz = K::weights_d1(alpha[2]);
        // acc: value weights in y and z; accy: y derivative; accz: z derivative.
        let mut acc = [0.0f32; S];
        let mut accy = [0.0f32; S];
        let mut accz = [0.0f32; S];
        #[cfg(target_arch = "x86_64")]
        let simd = S == 4;
        #[cfg(not(target_arch = "x86_64"))]
        let simd = false;
        if simd {
            #[cfg(target_arch = "x86_64")]
            grad4(row, &wy, &wz, &dy, &dz, [&mut acc, &mut accy, &mut accz]);
        } else {
            for k in 0..S {
                for j in 0..S {
                    let (w, wdy, wdz) = (wy[j] * wz[k], dy[j] * wz[k], wy[j] * dz[k]);
                    let r = row(j, k);
                    for i in 0..S {
                        acc[i] += w * r[i];
                        accy[i] += wdy * r[i];
                        accz[i] += wdz * r[i];
                    }
                }
            }
        }
        let (mut val, mut gx, mut gy, mut gz) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
        for i in 0..S {
            val += wx[i] * acc[i];
            gx += dx[i] * acc[i];
            gy += wx[i] * accy[i];
            gz += wx[i] * accz[i];
        }
        out.value = val;
        out.grad_i = [gx, gy, gz];
        let m = &self.gmat;
        out.grad_w = [
            m[0][0] * gx + m[0][1] * gy + m[0][2] * gz,
            m[1][0] * gx + m[1][1] * gy + m[1][2] * gz,
            m[2][0] * gx + m[2][1] * gy + m[2][2] * gz,
        ];
        out
    }

    #[inline]
    fn load(&mut self, n: [i64; 3]) {
        let data = self.vol.data();
        let s0 = self.sizes[0] as usize;
        let s1 = self.sizes[1] as usize;
        let (n0, n1, n2) = (n[0] as usize, n[1] as usize, n[2] as usize);
        // The inside rule put the whole support in the volume: check its last voxel once.
        let last = n0 + S - 1 + s0 * ((n1 + S - 1) + s1 * (n2 + S - 1));
        assert!(last < data.len());
        for k in 0..S {
            for j in 0..S {
                let start = n0 + s0 * ((n1 + j) + s1 * (n2 + k));
                // SAFETY: start + S - 1 <= last < data.len() for j, k < S.
                let src = unsafe { data.get_unchecked(start..start + S) };
                let dst = &mut self.nb[k][j];
                for i in 0..S {
                    dst[i] = src[i].to_f32();
                }
            }
        }
        self.base = n;
        self.have = true;
    }
}

/// The value sum for support 4 with SSE (x86_64 baseline): the same operations in the
/// same order as the generic loop, four lanes at a time, so the result is bit-identical
/// to it. `row(j, k)` gives the 4 voxels of row j (y) in slice k (z).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn value4<'a, const S: usize>(
    row: impl Fn(usize, usize) -> &'a [f32],
    wx: &[f32; S],
    wy: &[f32; S],
    wz: &[f32; S],
) -> f32 {
    use core::arch::x86_64::{
        _mm_add_ps, _mm_loadu_ps, _mm_mul_ps, _mm_set1_ps, _mm_setzero_ps, _mm_storeu_ps,
    };
    debug_assert_eq!(S, 4);
    let mut t = [0.0f32; 4];
    // SAFETY: SSE and SSE2 are part of the x86_64 baseline, so these intrinsics are
    // always available. Every load reads 4 f32: the rows are checked to hold 4 values
    // and the weight arrays have S == 4 entries; the store writes `t`, 4 f32.
    unsafe {
        let mut acc = _mm_setzero_ps();
        for k in 0..S {
            for j in 0..S {
                let r = row(j, k);
                assert!(r.len() >= 4);
                let w = _mm_set1_ps(wy[j] * wz[k]);
                acc = _mm_add_ps(acc, _mm_mul_ps(w, _mm_loadu_ps(r.as_ptr())));
            }
        }
        let prod = _mm_mul_ps(acc, _mm_loadu_ps(wx.as_ptr()));
        _mm_storeu_ps(t.as_mut_ptr(), prod);
    }
    ((0.0 + t[0]) + t[1] + t[2]) + t[3]
}

/// The three gradient accumulations for support 4 with SSE, lane for lane the same
/// operations as the generic loop (so bit-identical to it).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn grad4<'a, const S: usize>(
    row: impl Fn(usize, usize) -> &'a [f32],
    wy: &[f32; S],
    wz: &[f32; S],
    dy: &[f32; S],
    dz: &[f32; S],
    out: [&mut [f32; S]; 3],
) {
    use core::arch::x86_64::{
        _mm_add_ps, _mm_loadu_ps, _mm_mul_ps, _mm_set1_ps, _mm_setzero_ps, _mm_storeu_ps,
    };
    debug_assert_eq!(S, 4);
    let [o0, o1, o2] = out;
    // SAFETY: SSE/SSE2 are x86_64 baseline. Loads read 4 f32 from rows checked to hold 4;
    // stores write the 4-entry (S == 4) output arrays.
    unsafe {
        let (mut a, mut b, mut c) = (_mm_setzero_ps(), _mm_setzero_ps(), _mm_setzero_ps());
        for k in 0..S {
            for j in 0..S {
                let r = row(j, k);
                assert!(r.len() >= 4);
                let v = _mm_loadu_ps(r.as_ptr());
                a = _mm_add_ps(a, _mm_mul_ps(_mm_set1_ps(wy[j] * wz[k]), v));
                b = _mm_add_ps(b, _mm_mul_ps(_mm_set1_ps(dy[j] * wz[k]), v));
                c = _mm_add_ps(c, _mm_mul_ps(_mm_set1_ps(wy[j] * dz[k]), v));
            }
        }
        _mm_storeu_ps(o0.as_mut_ptr(), a);
        _mm_storeu_ps(o1.as_mut_ptr(), b);
        _mm_storeu_ps(o2.as_mut_ptr(), c);
    }
}
