//! One sample's support-2 and support-4 sums in SSE registers (x86_64 baseline), lane
//! for lane the operations of the portable [`crate::convo::sums`].

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

/// The four lanes.
#[inline(always)]
pub(crate) fn store(v: __m128) -> [f32; 4] {
    let mut out = [0.0f32; 4];
    // SAFETY: SSE is x86_64 baseline; the store writes the 4 floats of `out`.
    unsafe { _mm_storeu_ps(out.as_mut_ptr(), v) };
    out
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

/// Four samples of [`crate::convo::world_gmags`]: the sums transposed so that each vector
/// holds one component of all four, then the matrix product and the magnitude
/// lane by lane (square root correctly rounded, as the scalar one).
#[inline(always)]
pub(crate) fn world_gmag4(m: &[[f32; 3]; 3], r: &[[f32; 4]; 4]) -> [f32; 4] {
    // SAFETY: SSE/SSE2 are x86_64 baseline; every load here reads a 4-float array.
    let s = unsafe {
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
        _mm_sqrt_ps(s)
    };
    store(s)
}

/// [`crate::convo::sums`] for S = 2, the same operations in the same order (so bit-identical
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
            out = store(s);
        } else {
            let acc = _mm_add_ps(t1, _mm_movehl_ps(t1, t1));
            let m = _mm_mul_ps(acc, _mm_set_ps(0.0, 0.0, wx[1], wx[0]));
            out[0] = _mm_cvtss_f32(_mm_add_ss(m, _mm_shuffle_ps::<0b01>(m, m)));
        }
    }
    out
}

/// [`crate::convo::sums`] for S = 4, the same operations in the same order four lanes at a
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
            out = store(s);
        } else {
            let s = _mm_add_ss(m0, _mm_shuffle_ps::<0b01>(m0, m0));
            let s = _mm_add_ss(s, _mm_shuffle_ps::<0b10>(m0, m0));
            let s = _mm_add_ss(s, _mm_shuffle_ps::<0b11>(m0, m0));
            out[0] = _mm_cvtss_f32(s);
        }
    }
    out
}
