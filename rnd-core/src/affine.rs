//! 4×4 homogeneous affine matrices in f64 (row-major), as used for ItoW, WtoI, VtoW, WtoV.

use crate::error::{Error, ErrorKind, Result};

/// A 4×4 matrix, row-major: element (r, c) is `m[4 * r + c]`. For an affine matrix the
/// bottom row is `0 0 0 1`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Affine4 {
    /// The sixteen entries, row-major.
    pub m: [f64; 16],
}

impl Default for Affine4 {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Affine4 {
    /// The identity.
    pub const IDENTITY: Affine4 = Affine4 {
        m: [
            1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1.,
        ],
    };

    /// From sixteen row-major entries.
    pub fn from_rows(m: [f64; 16]) -> Self {
        Affine4 { m }
    }

    /// From a 3×3 linear part given as three **columns** and a translation `t`.
    pub fn from_columns(c0: [f64; 3], c1: [f64; 3], c2: [f64; 3], t: [f64; 3]) -> Self {
        Affine4 {
            m: [
                c0[0], c1[0], c2[0], t[0], //
                c0[1], c1[1], c2[1], t[1], //
                c0[2], c1[2], c2[2], t[2], //
                0., 0., 0., 1.,
            ],
        }
    }

    /// An axis-aligned grid: `spacing` world units between samples along each index axis,
    /// sample (0, 0, 0) at world point `origin`.
    ///
    /// ```
    /// use rnd_core::affine::Affine4;
    ///
    /// let itow = Affine4::from_spacing([0.5, 0.5, 2.0], [10.0, 0.0, -4.0]);
    /// assert_eq!(itow.point([2.0, 0.0, 1.0]), [11.0, 0.0, -2.0]);
    /// ```
    pub fn from_spacing(spacing: [f64; 3], origin: [f64; 3]) -> Self {
        Affine4::from_columns(
            [spacing[0], 0.0, 0.0],
            [0.0, spacing[1], 0.0],
            [0.0, 0.0, spacing[2]],
            origin,
        )
    }

    /// Entry at row `r`, column `c` (NaN when either is 4 or more: no entry).
    #[inline(always)]
    pub fn at(&self, r: usize, c: usize) -> f64 {
        if r < 4 && c < 4 {
            self.m[4 * r + c]
        } else {
            f64::NAN
        }
    }

    /// Column `c` of the upper 3×4 block (a direction for c < 3, the translation for c = 3;
    /// NaNs for c ≥ 4).
    pub fn column3(&self, c: usize) -> [f64; 3] {
        [self.at(0, c), self.at(1, c), self.at(2, c)]
    }

    /// Matrix product `self · b`.
    pub fn mul(&self, b: &Affine4) -> Affine4 {
        let mut m = [0.0; 16];
        for r in 0..4 {
            for c in 0..4 {
                m[4 * r + c] = (0..4).map(|k| self.at(r, k) * b.at(k, c)).sum();
            }
        }
        Affine4 { m }
    }

    /// General 4-vector product `self · v`.
    pub fn mul_vec4(&self, v: [f64; 4]) -> [f64; 4] {
        let mut o = [0.0; 4];
        for (r, o) in o.iter_mut().enumerate() {
            *o = (0..4).map(|k| self.at(r, k) * v[k]).sum();
        }
        o
    }

    /// Transforms a point (w = 1).
    #[inline(always)]
    pub fn point(&self, p: [f64; 3]) -> [f64; 3] {
        let m = &self.m;
        [
            m[0] * p[0] + m[1] * p[1] + m[2] * p[2] + m[3],
            m[4] * p[0] + m[5] * p[1] + m[6] * p[2] + m[7],
            m[8] * p[0] + m[9] * p[1] + m[10] * p[2] + m[11],
        ]
    }

    /// Transforms a vector (w = 0): only the linear part acts.
    #[inline(always)]
    pub fn vector(&self, p: [f64; 3]) -> [f64; 3] {
        let m = &self.m;
        [
            m[0] * p[0] + m[1] * p[1] + m[2] * p[2],
            m[4] * p[0] + m[5] * p[1] + m[6] * p[2],
            m[8] * p[0] + m[9] * p[1] + m[10] * p[2],
        ]
    }

    /// Determinant of the upper-left 3×3 block.
    pub fn det3(&self) -> f64 {
        let a = |r, c| self.at(r, c);
        a(0, 0) * (a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1))
            - a(0, 1) * (a(1, 0) * a(2, 2) - a(1, 2) * a(2, 0))
            + a(0, 2) * (a(1, 0) * a(2, 1) - a(1, 1) * a(2, 0))
    }

    /// True when every entry is finite.
    pub fn is_finite(&self) -> bool {
        self.m.iter().all(|x| x.is_finite())
    }

    /// Affine inverse `[[M⁻¹, −M⁻¹t], [0 0 0 1]]` (M the 3×3 linear part, t the translation). The bottom row of `self` is
    /// assumed to be `0 0 0 1` and is not read. Fails when M is singular (relative to its
    /// scale) or not finite.
    ///
    /// # Errors
    /// [`ErrorKind::Matrix`] when the 3×3 part is singular or a number is not finite.
    pub fn affine_inverse(&self) -> Result<Affine4> {
        if !self.is_finite() {
            return Err(Error::new(
                ErrorKind::Matrix,
                "matrix has non-finite entries",
            ));
        }
        let det = self.det3();
        let scale: f64 = (0..3)
            .flat_map(|r| (0..3).map(move |c| (r, c)))
            .map(|(r, c)| self.at(r, c).abs())
            .fold(0.0, f64::max);
        if det == 0.0 || !det.is_finite() || det.abs() <= 1e-14 * scale * scale * scale {
            return Err(Error::new(
                ErrorKind::Matrix,
                alloc::format!("upper 3x3 of the matrix is singular (determinant {det:e})"),
            ));
        }
        let a = |r, c| self.at(r, c);
        let inv_det = 1.0 / det;
        // Adjugate (transpose of the cofactor matrix) divided by the determinant.
        let mut i3 = [[0.0f64; 3]; 3];
        for (r, row) in i3.iter_mut().enumerate() {
            for (c, e) in row.iter_mut().enumerate() {
                // cofactor of (c, r)
                let (r0, r1) = match c {
                    0 => (1, 2),
                    1 => (0, 2),
                    _ => (0, 1),
                };
                let (c0, c1) = match r {
                    0 => (1, 2),
                    1 => (0, 2),
                    _ => (0, 1),
                };
                let minor = a(r0, c0) * a(r1, c1) - a(r0, c1) * a(r1, c0);
                let sign = if (r + c) % 2 == 0 { 1.0 } else { -1.0 };
                *e = sign * minor * inv_det;
            }
        }
        let t = [a(0, 3), a(1, 3), a(2, 3)];
        let mut m = [0.0; 16];
        for r in 0..3 {
            for c in 0..3 {
                m[4 * r + c] = i3[r][c];
            }
            m[4 * r + 3] = -(i3[r][0] * t[0] + i3[r][1] * t[1] + i3[r][2] * t[2]);
        }
        m[15] = 1.0;
        Ok(Affine4 { m })
    }

    /// Frobenius norm of `self − I`.
    pub fn frobenius_from_identity(&self) -> f64 {
        let mut s = 0.0;
        for (i, x) in self.m.iter().enumerate() {
            let id = if i % 5 == 0 { 1.0 } else { 0.0 };
            s += (x - id) * (x - id);
        }
        crate::math::sqrt(s)
    }

    /// True when the bottom row is exactly `0 0 0 1`.
    pub fn is_affine(&self) -> bool {
        self.m[12] == 0.0 && self.m[13] == 0.0 && self.m[14] == 0.0 && self.m[15] == 1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_of_known_matrix() {
        let a = Affine4::from_rows([
            2., 0., 0., 1., 0., 4., 0., 2., 0., 0., 8., 3., 0., 0., 0., 1.,
        ]);
        let i = a.affine_inverse().unwrap();
        assert_eq!(i.point([1., 2., 3.]), [0.0, 0.0, 0.0]);
        assert!(a.mul(&i).frobenius_from_identity() < 1e-15);
    }

    #[test]
    fn entries_are_read_only_inside() {
        let a = Affine4::from_rows(core::array::from_fn(|i| i as f64));
        for r in 0..4 {
            for c in 0..4 {
                assert_eq!(a.at(r, c), (4 * r + c) as f64);
            }
        }
        // (Row 0, column 5 would be entry 5 of the storage: row 1's.)
        for (r, c) in [(0, 4), (0, 5), (4, 0), (usize::MAX, usize::MAX)] {
            assert!(a.at(r, c).is_nan(), "({r}, {c})");
        }
        assert!(a.column3(7).iter().all(|x| x.is_nan()));
    }

    #[test]
    fn singular_is_refused() {
        let a = Affine4::from_rows([
            1., 2., 3., 0., 2., 4., 6., 0., 0., 0., 1., 0., 0., 0., 0., 1.,
        ]);
        assert_eq!(a.affine_inverse().unwrap_err().kind, ErrorKind::Matrix);
    }
}
