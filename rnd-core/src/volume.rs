//! A scalar volume over borrowed samples, with its index-to-world geometry.

use crate::affine::Affine4;
use crate::error::{Error, ErrorKind, Result};
use crate::voxel::Voxel;

/// A 3-D scalar volume: samples stored fast-to-slow (`i + s0*(j + s1*k)`), borrowed from
/// the caller, plus the index-to-world transform (SPEC §3.1).
#[derive(Debug, Clone, Copy)]
pub struct Volume<'a, V: Voxel> {
    data: &'a [V],
    sizes: [usize; 3],
    itow: Affine4,
    wtoi: Affine4,
}

impl<'a, V: Voxel> Volume<'a, V> {
    /// Wraps `data` with sizes (fast axis first) and index-to-world matrix `itow`.
    /// Fails when a size is 0, the data length does not match, or `itow` is not an
    /// invertible affine matrix.
    pub fn new(data: &'a [V], sizes: [usize; 3], itow: Affine4) -> Result<Self> {
        if sizes.contains(&0) {
            return Err(Error::new(
                ErrorKind::Volume,
                alloc::format!("volume has an empty axis (sizes {sizes:?})"),
            ));
        }
        let n = sizes[0]
            .checked_mul(sizes[1])
            .and_then(|x| x.checked_mul(sizes[2]));
        if n != Some(data.len()) {
            return Err(Error::new(
                ErrorKind::Volume,
                alloc::format!(
                    "volume sizes {} {} {} need {:?} samples but {} were given",
                    sizes[0],
                    sizes[1],
                    sizes[2],
                    n,
                    data.len()
                ),
            ));
        }
        if !itow.is_affine() {
            return Err(Error::new(
                ErrorKind::Volume,
                "ItoW bottom row is not 0 0 0 1",
            ));
        }
        let wtoi = itow.affine_inverse().map_err(|e| {
            Error::new(
                ErrorKind::Volume,
                alloc::format!("index-to-world matrix: {}", e.msg),
            )
        })?;
        Ok(Volume {
            data,
            sizes,
            itow,
            wtoi,
        })
    }

    /// The samples.
    #[inline(always)]
    pub fn data(&self) -> &'a [V] {
        self.data
    }
    /// Sizes, fast axis first.
    #[inline(always)]
    pub fn sizes(&self) -> [usize; 3] {
        self.sizes
    }
    /// Index-to-world.
    #[inline(always)]
    pub fn itow(&self) -> &Affine4 {
        &self.itow
    }
    /// World-to-index (affine inverse of ItoW).
    #[inline(always)]
    pub fn wtoi(&self) -> &Affine4 {
        &self.wtoi
    }
    /// Sample at integer index (i, j, k); panics when out of range.
    #[inline(always)]
    pub fn at(&self, i: usize, j: usize, k: usize) -> V {
        self.data[i + self.sizes[0] * (j + self.sizes[1] * k)]
    }
    /// Minimum and maximum sample value (as f32).
    pub fn min_max(&self) -> (f32, f32) {
        let mut lo = f32::INFINITY;
        let mut hi = f32::NEG_INFINITY;
        for v in self.data {
            let v = v.to_f32();
            if v < lo {
                lo = v;
            }
            if v > hi {
                hi = v;
            }
        }
        (lo, hi)
    }
}
