//! Synthetic data: the test functions of `rendr sdg` ([`FUNCTIONS`]) sampled on a grid
//! whose geometry is given by edge lengths, shear, rotation and centre ([`Grid`]).

use alloc::vec::Vec;

use crate::affine::Affine4;
use crate::error::{Error, ErrorKind, Param, Result};
use crate::math;

/// Names of the `-w` functions, in order (index = `-w` number).
pub const FUNCTIONS: &[&str] = &[
    "-z (zramp)",
    "x^2 + y^2 - z (paraboloid)",
    "cube: exp(-(x^8 + y^8 + z^8)/6)",
    "x",
    "y",
    "i (fast index)",
    "j (middle index)",
    "k (slow index)",
    "impulse: 1 at index (s0/2, s1/2, s2/2), else 0",
    "-(x^2 + y^2 + z^2)",
    "Cayley cubic 1 - x^2 - y^2 - z^2 + z(x^2 - y^2)",
    "constant 1",
    "Marschner-Lobb on [-1,1]^3 (alpha 0.25, fM 6)",
    "sphere distance 1 - sqrt(x^2 + y^2 + z^2)",
    "slab: 1 where |z| < 0.5, else 0 (blocky, for clipping tests)",
    "marker: Gaussian blobs 1 at the origin, 0.66 at +x 0.6, 0.33 at +z 0.6",
    "10 (1 - sqrt(x^2 + y^2 + z^2)) (sphere distance, gradient magnitude 10)",
];

/// Grid request (`sdg` options).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    /// Samples per axis.
    pub sizes: [usize; 3],
    /// Edge lengths of the sampled box (world units).
    pub lengths: [f64; 3],
    /// Shear coefficients xy, xz, yz.
    pub shear: [f64; 3],
    /// Rotation, quaternion-style: normalize(1, r0, r1, r2).
    pub rot: [f64; 3],
    /// World-space centre.
    pub centre: [f64; 3],
}

impl Grid {
    /// Index-to-world: M = R·Sh·D, origin = c − M·((sz−1)/2).
    ///
    /// # Errors
    /// [`ErrorKind::Sdg`] for a zero size, non-finite numbers or edge lengths ≤ 0.
    pub fn itow(&self) -> Result<Affine4> {
        if self.sizes.contains(&0) {
            return Err(Error::about(
                ErrorKind::Sdg,
                Param::SdgSizes,
                "sizes must be > 0",
            ));
        }
        let all = self
            .lengths
            .iter()
            .chain(&self.shear)
            .chain(&self.rot)
            .chain(&self.centre);
        if all.clone().any(|x| !x.is_finite()) {
            return Err(Error::new(
                ErrorKind::Sdg,
                "edge lengths, shear, rotation and centre must be finite",
            ));
        }
        if self.lengths.iter().any(|&l| l <= 0.0) {
            return Err(Error::about(
                ErrorKind::Sdg,
                Param::SdgLengths,
                "edge lengths must be > 0",
            ));
        }
        let sp: [f64; 3] = core::array::from_fn(|i| self.lengths[i] / self.sizes[i] as f64);
        let [xy, xz, yz] = self.shear;
        let sh = [[1.0, xy, xz], [0.0, 1.0, yz], [0.0, 0.0, 1.0]];
        let (w, x, y, z) = {
            let [a, b, c] = self.rot;
            let l = math::sqrt(1.0 + a * a + b * b + c * c);
            (1.0 / l, a / l, b / l, c / l)
        };
        let r = [
            [
                1.0 - 2.0 * (y * y + z * z),
                2.0 * (x * y - w * z),
                2.0 * (x * z + w * y),
            ],
            [
                2.0 * (x * y + w * z),
                1.0 - 2.0 * (x * x + z * z),
                2.0 * (y * z - w * x),
            ],
            [
                2.0 * (x * z - w * y),
                2.0 * (y * z + w * x),
                1.0 - 2.0 * (x * x + y * y),
            ],
        ];
        let mut m = [[0.0; 3]; 3];
        for (i, row) in m.iter_mut().enumerate() {
            for (j, e) in row.iter_mut().enumerate() {
                *e = (0..3).map(|k| r[i][k] * sh[k][j]).sum::<f64>() * sp[j];
            }
        }
        let half: [f64; 3] = core::array::from_fn(|i| (self.sizes[i] as f64 - 1.0) / 2.0);
        let o: [f64; 3] = core::array::from_fn(|i| {
            self.centre[i] - (0..3).map(|j| m[i][j] * half[j]).sum::<f64>()
        });
        let col = |j: usize| [m[0][j], m[1][j], m[2][j]];
        let a = Affine4::from_columns(col(0), col(1), col(2), o);
        a.affine_inverse()
            .map_err(|e| Error::new(ErrorKind::Sdg, alloc::format!("grid: {}", e.msg)))?;
        Ok(a)
    }
}

/// Evaluates function `which` at world point `p` and index (i, j, k) of a grid of `sizes`.
pub fn eval(which: u32, p: [f64; 3], idx: [usize; 3], sizes: [usize; 3]) -> f64 {
    let [x, y, z] = p;
    match which {
        0 => -z,
        1 => x * x + y * y - z,
        2 => {
            let p8 = |v: f64| {
                let v2 = v * v;
                let v4 = v2 * v2;
                v4 * v4
            };
            math::exp(-(p8(x) + p8(y) + p8(z)) / 6.0)
        }
        3 => x,
        4 => y,
        5 => idx[0] as f64,
        6 => idx[1] as f64,
        7 => idx[2] as f64,
        8 => {
            if idx == [sizes[0] / 2, sizes[1] / 2, sizes[2] / 2] {
                1.0
            } else {
                0.0
            }
        }
        9 => -(x * x + y * y + z * z),
        10 => 1.0 - x * x - y * y - z * z + z * (x * x - y * y),
        11 => 1.0,
        12 => {
            let alpha = 0.25;
            let fm = 6.0;
            let pi = core::f64::consts::PI;
            let r = math::sqrt(x * x + y * y);
            let rho = math::cos(2.0 * pi * fm * math::cos(pi * r / 2.0));
            (1.0 - math::sin(pi * z / 2.0) + alpha * (1.0 + rho)) / (2.0 * (1.0 + alpha))
        }
        13 => 1.0 - math::sqrt(x * x + y * y + z * z),
        14 => {
            if z.abs() < 0.5 {
                1.0
            } else {
                0.0
            }
        }
        15 => {
            let blob = |c: [f64; 3]| {
                let (a, b, e) = (x - c[0], y - c[1], z - c[2]);
                let d2 = a * a + b * b + e * e;
                math::exp(-d2 / (0.15 * 0.15))
            };
            blob([0.0; 3]) + 0.66 * blob([0.6, 0.0, 0.0]) + 0.33 * blob([0.0, 0.0, 0.6])
        }
        16 => 10.0 * (1.0 - math::sqrt(x * x + y * y + z * z)),
        _ => f64::NAN,
    }
}

/// Samples function `which` on `grid`, returning the values (fast axis first) and ItoW.
///
/// # Errors
/// [`ErrorKind::Sdg`] for an unknown function or a bad grid ([`Grid::itow`]);
/// [`ErrorKind::Memory`] when the samples cannot be allocated.
pub fn generate(which: u32, grid: &Grid) -> Result<(Vec<f64>, Affine4)> {
    if which as usize >= FUNCTIONS.len() {
        return Err(Error::about(
            ErrorKind::Sdg,
            Param::SdgFunction,
            alloc::format!("unknown function {which} (0..{})", FUNCTIONS.len() - 1),
        ));
    }
    let itow = grid.itow()?;
    let [s0, s1, s2] = grid.sizes;
    let n = s0
        .checked_mul(s1)
        .and_then(|v| v.checked_mul(s2))
        .ok_or_else(|| Error::about(ErrorKind::Sdg, Param::SdgSizes, "too many samples"))?;
    let mut out = Vec::new();
    out.try_reserve_exact(n).map_err(|_| {
        Error::about(
            ErrorKind::Memory,
            Param::SdgSizes,
            alloc::format!("{n} samples do not fit in memory"),
        )
    })?;
    for k in 0..s2 {
        for j in 0..s1 {
            for i in 0..s0 {
                let p = itow.point([i as f64, j as f64, k as f64]);
                out.push(eval(which, p, [i, j, k], grid.sizes));
            }
        }
    }
    Ok((out, itow))
}
