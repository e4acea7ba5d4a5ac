//! The one place that knows where float functions come from.
//!
//! `rnd-core` is `#![no_std]`, so the inherent `f64::sqrt` and friends (which live in
//! `std`) are not available; every transcendental goes through `libm` here.

/// Square root (f64).
#[inline(always)]
pub fn sqrt(x: f64) -> f64 {
    libm::sqrt(x)
}
/// Square root (f32).
#[inline(always)]
pub fn sqrtf(x: f32) -> f32 {
    libm::sqrtf(x)
}
/// Largest integer not above `x` (f64).
#[inline(always)]
pub fn floor(x: f64) -> f64 {
    libm::floor(x)
}
/// Largest integer not above `x` (f32), exactly as `libm::floorf` (signed zeros, NaN
/// and infinities included) but without a call or an integer conversion: below 2^23 in
/// magnitude, adding and taking away 2^23 (with `x`'s sign) rounds `x` to an integer
/// (the sum's unit in the last place is 1), and one correction makes it the floor; at
/// or above 2^23 every f32 is already an integer. (Checked against `libm::floorf` on
/// every f32 bit pattern once; the test keeps a stride through them.)
#[inline(always)]
pub fn floorf(x: f32) -> f32 {
    // Selects rather than branches (`&`, not `&&`), so loops over lanes vectorize.
    const BIG: f32 = 8_388_608.0;
    let m = if x < 0.0 { -BIG } else { BIG };
    let r = (x + m) - m;
    let f = if r > x { r - 1.0 } else { r };
    if (x.abs() < BIG) & (x != 0.0) {
        f
    } else {
        x
    }
}
/// Smallest integer ≥ `x` (f64).
#[inline(always)]
pub fn ceil(x: f64) -> f64 {
    libm::ceil(x)
}
/// `x` raised to `y` (f64).
#[inline(always)]
pub fn pow(x: f64, y: f64) -> f64 {
    libm::pow(x, y)
}
/// `x` raised to `y` (f32).
#[inline(always)]
pub fn powf(x: f32, y: f32) -> f32 {
    libm::powf(x, y)
}
/// Tangent (radians).
#[inline(always)]
pub fn tan(x: f64) -> f64 {
    libm::tan(x)
}
/// Sine (radians).
#[inline(always)]
pub fn sin(x: f64) -> f64 {
    libm::sin(x)
}
/// Cosine (radians).
#[inline(always)]
pub fn cos(x: f64) -> f64 {
    libm::cos(x)
}
/// Arc cosine (radians).
#[inline(always)]
pub fn acos(x: f64) -> f64 {
    libm::acos(x)
}
/// e raised to `x`.
#[inline(always)]
pub fn ln(x: f64) -> f64 {
    libm::log(x)
}
/// e raised to `x` (f64).
#[inline(always)]
pub fn exp(x: f64) -> f64 {
    libm::exp(x)
}
/// Round half away from zero.
#[inline(always)]
pub fn round(x: f64) -> f64 {
    libm::round(x)
}

/// 3-vector helpers on `[f64; 3]` (the geometry type of the crate).
pub mod v3 {
    /// Dot product.
    #[inline(always)]
    pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }
    /// Cross product a × b.
    #[inline(always)]
    pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    }
    /// a − b.
    #[inline(always)]
    pub fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
    }
    /// a + b.
    #[inline(always)]
    pub fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
    }
    /// s·a.
    #[inline(always)]
    pub fn scale(s: f64, a: [f64; 3]) -> [f64; 3] {
        [s * a[0], s * a[1], s * a[2]]
    }
    /// Euclidean length.
    #[inline(always)]
    pub fn len(a: [f64; 3]) -> f64 {
        super::sqrt(dot(a, a))
    }
    /// a / |a| (NaNs for a zero vector; callers check first).
    #[inline(always)]
    pub fn normalize(a: [f64; 3]) -> [f64; 3] {
        scale(1.0 / len(a), a)
    }
    /// True when all three components are finite.
    #[inline(always)]
    pub fn finite(a: [f64; 3]) -> bool {
        a.iter().all(|x| x.is_finite())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floorf_is_libm_floorf_bit_for_bit() {
        let check = |x: f32| {
            assert_eq!(
                floorf(x).to_bits(),
                libm::floorf(x).to_bits(),
                "floorf({x:e}) ({:#x})",
                x.to_bits()
            );
        };
        // Every float around the integers -300..300, the magnitudes near 2^23 and 2^31,
        // zeros, infinities, NaN, subnormals; then a stride through all bit patterns.
        for i in -300i32..=300 {
            let b = (i as f32).to_bits();
            for d in 0..64u32 {
                check(f32::from_bits(b.wrapping_add(d)));
                check(f32::from_bits(b.wrapping_sub(d)));
            }
        }
        for m in [8_388_608.0f32, 16_777_216.0, 2_147_483_648.0, 1.0e-40, 0.5] {
            let b = m.to_bits();
            for d in 0..256u32 {
                for s in [1.0f32, -1.0] {
                    check(s * f32::from_bits(b - d));
                    check(s * f32::from_bits(b + d));
                }
            }
        }
        for x in [
            0.0f32,
            -0.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            f32::MAX,
        ] {
            check(x);
        }
        let mut b = 0u32;
        loop {
            check(f32::from_bits(b));
            match b.checked_add(65_521) {
                Some(n) => b = n,
                None => break,
            }
        }
    }
}
