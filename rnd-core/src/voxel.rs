//! The voxel types a volume may hold: `f32` and `i16` (a sealed trait).

mod sealed {
    pub trait Sealed {}
    impl Sealed for f32 {}
    impl Sealed for i16 {}
}

/// A voxel sample type. Implemented for `f32` and `i16` only (sealed).
pub trait Voxel: sealed::Sealed + Copy + Send + Sync + Default + PartialOrd + 'static {
    /// NRRD-style type name (`float`, `short`).
    const TYPE_NAME: &'static str;
    /// The value as f32 (i16 converts exactly).
    fn to_f32(self) -> f32;
    /// The samples as f32 without conversion, when they already are f32.
    #[inline(always)]
    fn as_f32_slice(_s: &[Self]) -> Option<&[f32]> {
        None
    }
}

impl Voxel for f32 {
    const TYPE_NAME: &'static str = "float";
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self
    }
    #[inline(always)]
    fn as_f32_slice(s: &[f32]) -> Option<&[f32]> {
        Some(s)
    }
}

impl Voxel for i16 {
    const TYPE_NAME: &'static str = "short";
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self as f32
    }
}
