//! Scalar volumes with their index-to-world geometry: [`Volume`] borrows its samples,
//! [`OwnedVolume`] holds them.

use alloc::vec::Vec;

use crate::affine::Affine4;
use crate::error::{Error, ErrorKind, Result};
use crate::voxel::Voxel;

/// A 3-D scalar volume: samples stored fast-to-slow (`i + r*(j + s1*k)`, where the row
/// stride `r` is the fast axis's size `s0`, or more for a [`Volume::padded`] volume),
/// borrowed from the caller, plus the index-to-world transform: sample (i, j, k) sits at
/// world point `itow · (i, j, k, 1)` (the sample is at the centre of its cell; index positions run
/// from 0 to size − 1 along each axis).
///
/// ```
/// use rnd_core::affine::Affine4;
/// use rnd_core::volume::Volume;
///
/// let data = [0i16, 1, 2, 3, 4, 5, 6, 7];
/// let vol = Volume::new(&data, [2, 2, 2], Affine4::from_spacing([0.5, 0.5, 2.0], [0.0; 3]))
///     .unwrap();
/// assert_eq!(vol.get(1, 1, 1), Some(7));
/// assert_eq!(vol.get(2, 0, 0), None); // not sample (0, 1, 0)
/// assert_eq!(vol.itow().point([1.0, 1.0, 1.0]), [0.5, 0.5, 2.0]);
/// assert!(Volume::new(&data[..7], [2, 2, 2], Affine4::IDENTITY).is_err());
/// ```
#[derive(Debug, Clone, Copy)]
pub struct Volume<'a, V: Voxel> {
    data: &'a [V],
    sizes: [usize; 3],
    /// Samples from one row to the next (`sizes[0]`, or more for [`Volume::padded`]).
    row: usize,
    /// Index (in the grid) of the first sample held, and the grid's sizes: a volume made
    /// by [`Volume::region`] holds a box of a larger grid (origin 0 and grid = sizes
    /// otherwise).
    origin: [usize; 3],
    grid: [usize; 3],
    itow: Affine4,
    wtoi: Affine4,
}

impl<'a, V: Voxel> Volume<'a, V> {
    /// Wraps `data` with sizes (fast axis first) and index-to-world matrix `itow`.
    ///
    /// # Errors
    /// [`ErrorKind::Volume`] when a size is 0, the data length does not match, or `itow`
    /// is not an invertible affine matrix.
    pub fn new(data: &'a [V], sizes: [usize; 3], itow: Affine4) -> Result<Self> {
        Self::with_rows(data, sizes, sizes[0], itow)
    }

    /// [`Volume::new`] with rows `row` samples apart ([`Volume::padded`]).
    fn with_rows(data: &'a [V], sizes: [usize; 3], row: usize, itow: Affine4) -> Result<Self> {
        if sizes.contains(&0) {
            return Err(Error::new(
                ErrorKind::Volume,
                alloc::format!("volume has an empty axis (sizes {sizes:?})"),
            ));
        }
        if row < sizes[0] {
            return Err(Error::new(
                ErrorKind::Volume,
                alloc::format!("rows {row} samples apart are shorter than a row ({sizes:?})"),
            ));
        }
        let n = row
            .checked_mul(sizes[1])
            .and_then(|x| x.checked_mul(sizes[2]));
        if n != Some(data.len()) {
            let rows = if row == sizes[0] {
                alloc::string::String::new()
            } else {
                alloc::format!(" with rows {row} samples apart")
            };
            return Err(Error::new(
                ErrorKind::Volume,
                alloc::format!(
                    "volume sizes {} {} {}{rows} need {:?} samples but {} were given",
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
            row,
            origin: [0; 3],
            grid: sizes,
            itow,
            wtoi,
        })
    }

    /// Wraps `data` whose rows are `row` samples apart (`row >= sizes[0]`; the last
    /// `row - sizes[0]` samples of each row are padding, never read as samples): the
    /// layout a caller may copy a volume into when its row length in bytes is a large
    /// power of two, whose rows would otherwise share the processor's cache sets. It
    /// renders, probes and skips exactly as the same samples without padding.
    ///
    /// ```
    /// use rnd_core::affine::Affine4;
    /// use rnd_core::volume::Volume;
    ///
    /// let data = [0i16, 1, -1, 2, 3, -1, 4, 5, -1, 6, 7, -1]; // rows of 2 samples, 1 pad
    /// let vol = Volume::padded(&data, [2, 2, 2], 3, Affine4::IDENTITY).unwrap();
    /// assert_eq!((vol.get(1, 1, 1), vol.row_stride()), (Some(7), 3));
    /// assert_eq!(vol.get(2, 0, 0), None); // the padding is not a sample
    /// assert_eq!(vol.min_max(), (0.0, 7.0));
    /// assert!(Volume::padded(&data, [2, 2, 2], 1, Affine4::IDENTITY).is_err());
    /// assert!(Volume::padded(&data, [0, 2, 2], 3, Affine4::IDENTITY).is_err());
    /// assert!(Volume::padded(&data[..11], [2, 2, 2], 3, Affine4::IDENTITY).is_err());
    /// ```
    ///
    /// # Errors
    /// As [`Volume::new`] (the data length being `row * sizes[1] * sizes[2]`), and when
    /// `row < sizes[0]`.
    pub fn padded(data: &'a [V], sizes: [usize; 3], row: usize, itow: Affine4) -> Result<Self> {
        Self::with_rows(data, sizes, row, itow)
    }

    /// Wraps `data`, the samples of the box `region` of a grid of `grid` samples whose
    /// index-to-world matrix is `itow` (index positions are the grid's): the piece of a
    /// volume one process holds in a bricked render. Its samples are those of the box
    /// (fast axis first); everything positional (ItoW, [`Volume::world_corners`]) is
    /// the grid's, and a point is convolved only where its whole kernel support lies
    /// in the box.
    ///
    /// ```
    /// use rnd_core::affine::Affine4;
    /// use rnd_core::brick::Brick;
    /// use rnd_core::volume::Volume;
    ///
    /// let part = [5.0f32, 6.0, 7.0, 8.0]; // samples (1..3, 2..4, 0..1) of a 4 x 4 x 3 grid
    /// let b = Brick { lo: [1, 2, 0], hi: [3, 4, 1] };
    /// let vol = Volume::region(&part, [4, 4, 3], b, Affine4::IDENTITY).unwrap();
    /// assert_eq!((vol.sizes(), vol.origin(), vol.grid()), ([2, 2, 1], [1, 2, 0], [4, 4, 3]));
    /// assert_eq!(vol.get(1, 1, 0), Some(8.0));
    /// assert_eq!(vol.get(0, 0, 1), None); // the box has one slice
    /// ```
    ///
    /// # Errors
    /// As [`Volume::new`], and when the box is empty or leaves the grid.
    pub fn region(
        data: &'a [V],
        grid: [usize; 3],
        region: crate::brick::Brick,
        itow: Affine4,
    ) -> Result<Self> {
        let sizes = region.sizes();
        if (0..3).any(|a| region.hi[a] > grid[a] || region.lo[a] >= region.hi[a]) {
            return Err(Error::new(
                ErrorKind::Volume,
                alloc::format!(
                    "region {:?}..{:?} is empty or leaves the grid of sizes {grid:?}",
                    region.lo,
                    region.hi
                ),
            ));
        }
        let mut v = Volume::new(data, sizes, itow)?;
        v.origin = region.lo;
        v.grid = grid;
        Ok(v)
    }

    /// The samples as stored: sample (i, j, k) of those held is at `i + r * (j +
    /// sizes[1] * k)`, `r` being [`Volume::row_stride`].
    #[inline(always)]
    pub fn data(&self) -> &'a [V] {
        self.data
    }
    /// Samples from one row to the next: `sizes()[0]`, or more for [`Volume::padded`].
    #[inline(always)]
    pub fn row_stride(&self) -> usize {
        self.row
    }
    /// Samples from one slice (`k`) to the next: row stride × `sizes()[1]`.
    #[inline(always)]
    pub fn slice_stride(&self) -> usize {
        self.row * self.sizes[1]
    }
    /// Sizes of the samples held, fast axis first (the grid's, but for a
    /// [`Volume::region`]).
    #[inline(always)]
    pub fn sizes(&self) -> [usize; 3] {
        self.sizes
    }
    /// Grid index of the first sample held (0 but for a [`Volume::region`]).
    #[inline(always)]
    pub fn origin(&self) -> [usize; 3] {
        self.origin
    }
    /// Sizes of the whole grid (those of the samples held, but for a
    /// [`Volume::region`]).
    #[inline(always)]
    pub fn grid(&self) -> [usize; 3] {
        self.grid
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
    /// Sample at integer index (i, j, k) of the samples held (for a [`Volume::region`],
    /// counted from its origin); None when an index is outside its axis (never another
    /// sample, nor a [`Volume::padded`] row's padding).
    #[inline]
    pub fn get(&self, i: usize, j: usize, k: usize) -> Option<V> {
        let [s0, s1, s2] = self.sizes;
        if i >= s0 || j >= s1 || k >= s2 {
            return None;
        }
        self.data.get(i + self.row * (j + s1 * k)).copied()
    }
    /// The world positions of the grid's eight corner samples (index 0 or size − 1 on
    /// each axis), e.g. for [`crate::camera::CameraSpec::framing`].
    pub fn world_corners(&self) -> [[f64; 3]; 8] {
        corners(&self.itow, self.grid)
    }

    /// Minimum and maximum sample value (as f32).
    pub fn min_max(&self) -> (f32, f32) {
        let mut lo = f32::INFINITY;
        let mut hi = f32::NEG_INFINITY;
        let rows = self.data.chunks(self.row.max(1));
        for v in rows.flat_map(|r| &r[..self.sizes[0].min(r.len())]) {
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

/// World positions of the corner samples of a grid of `sizes` under `itow`.
pub(crate) fn corners(itow: &Affine4, sizes: [usize; 3]) -> [[f64; 3]; 8] {
    core::array::from_fn(|c| {
        let p: [f64; 3] = core::array::from_fn(|a| {
            if c >> a & 1 == 1 {
                (sizes[a] - 1) as f64
            } else {
                0.0
            }
        });
        itow.point(p)
    })
}

/// A 3-D scalar volume that owns its samples (see [`Volume`] for the layout and the
/// geometry). Built checked, so [`OwnedVolume::view`] cannot fail.
///
/// ```
/// use rnd_core::affine::Affine4;
/// use rnd_core::volume::OwnedVolume;
///
/// // A 32^3 ball of radius 12 voxels, 0.5 mm spacing, centred on the world origin.
/// let geom = Affine4::from_spacing([0.5; 3], [-7.75; 3]);
/// let vol = OwnedVolume::from_fn([32, 32, 32], geom, |[i, j, k]| {
///     let r2 = [i, j, k].iter().map(|&x| (x as f32 - 15.5).powi(2)).sum::<f32>();
///     if r2 < 144.0 { 1.0f32 } else { 0.0 }
/// })
/// .unwrap();
/// assert_eq!(vol.view().get(16, 16, 16), Some(1.0));
/// assert_eq!(vol.view().get(0, 0, 0), Some(0.0));
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct OwnedVolume<V: Voxel> {
    data: Vec<V>,
    sizes: [usize; 3],
    itow: Affine4,
    wtoi: Affine4,
}

impl<V: Voxel> OwnedVolume<V> {
    /// Takes `data` (fast axis first) with its sizes and index-to-world matrix.
    ///
    /// # Errors
    /// As [`Volume::new`].
    pub fn from_vec(data: Vec<V>, sizes: [usize; 3], itow: Affine4) -> Result<Self> {
        let wtoi = Volume::new(&data, sizes, itow)?.wtoi;
        Ok(OwnedVolume {
            data,
            sizes,
            itow,
            wtoi,
        })
    }

    /// Fills a volume of `sizes` with `f([i, j, k])` for every sample, i fastest.
    ///
    /// # Errors
    /// As [`Volume::new`]; [`ErrorKind::Memory`] when the samples cannot be allocated.
    pub fn from_fn(
        sizes: [usize; 3],
        itow: Affine4,
        mut f: impl FnMut([usize; 3]) -> V,
    ) -> Result<Self> {
        let n = sizes[0]
            .checked_mul(sizes[1])
            .and_then(|x| x.checked_mul(sizes[2]))
            .filter(|n| n.checked_mul(core::mem::size_of::<V>()).is_some())
            .ok_or_else(|| {
                Error::new(
                    ErrorKind::Memory,
                    alloc::format!("a volume of sizes {sizes:?} is too large to address"),
                )
            })?;
        let mut data = Vec::new();
        data.try_reserve_exact(n).map_err(|_| {
            Error::new(
                ErrorKind::Memory,
                alloc::format!("no memory for a volume of sizes {sizes:?}"),
            )
        })?;
        for k in 0..sizes[2] {
            for j in 0..sizes[1] {
                for i in 0..sizes[0] {
                    data.push(f([i, j, k]));
                }
            }
        }
        Self::from_vec(data, sizes, itow)
    }

    /// The borrowed view, for rendering and probing.
    pub fn view(&self) -> Volume<'_, V> {
        Volume {
            data: &self.data,
            sizes: self.sizes,
            row: self.sizes[0],
            origin: [0; 3],
            grid: self.sizes,
            itow: self.itow,
            wtoi: self.wtoi,
        }
    }

    /// The samples, fast axis first.
    pub fn data(&self) -> &[V] {
        &self.data
    }

    /// Sizes, fast axis first.
    pub fn sizes(&self) -> [usize; 3] {
        self.sizes
    }

    /// Index-to-world.
    pub fn itow(&self) -> &Affine4 {
        &self.itow
    }

    /// The samples, giving up the volume.
    pub fn into_vec(self) -> Vec<V> {
        self.data
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn get_reads_only_samples_held() {
        // 3 x 2 x 2 samples numbered i + 10 j + 100 k, rows padded to 5 with -1.
        let mut data = alloc::vec![-1i16; 5 * 2 * 2];
        for (k, j, i) in
            (0..2).flat_map(|k| (0..2).flat_map(move |j| (0..3).map(move |i| (k, j, i))))
        {
            data[i + 5 * (j + 2 * k)] = (i + 10 * j + 100 * k) as i16;
        }
        let vol = Volume::padded(&data, [3, 2, 2], 5, Affine4::IDENTITY).unwrap();
        for k in 0..4 {
            for j in 0..4 {
                for i in 0..7 {
                    let want = (i < 3 && j < 2 && k < 2).then_some((i + 10 * j + 100 * k) as i16);
                    assert_eq!(vol.get(i, j, k), want, "({i}, {j}, {k})");
                }
            }
        }
        assert_eq!(vol.get(usize::MAX, 0, 0), None);
        assert_eq!(vol.get(0, usize::MAX, usize::MAX), None);
    }
}
