//! The voxel types a volume may hold: `f32` and `i16` (a sealed trait).

/// A voxel sample type. Implemented for `f32` and `i16` only (sealed: its supertrait,
/// the vector row loaders of `crate::simd`, cannot be named outside the crate).
pub trait Voxel: crate::simd::Load + Copy + Send + Sync + Default + PartialOrd + 'static {
    /// NRRD-style type name (`float`, `short`).
    const TYPE_NAME: &'static str;
    /// The value as f32 (i16 converts exactly).
    fn to_f32(self) -> f32;
    /// The largest value (+∞ for f32), the start of a running minimum.
    const TOP: Self;
    /// The smallest value (−∞ for f32), the start of a running maximum.
    const BOTTOM: Self;
    /// Element by element, `lo[i] = min(lo[i], src[i])` and `hi[i] = max(hi[i],
    /// src[i])`, except that a NaN in `src` makes the pair (−∞, +∞): running value
    /// bounds that a NaN voxel makes unbounded.
    fn widen_bounds(lo: &mut [Self], hi: &mut [Self], src: &[Self]);
    /// Element by element, `lo[i] = min(lo[i], slo[i])` and `hi[i] = max(hi[i],
    /// shi[i])`, for bounds without NaN (as [`Voxel::widen_bounds`] makes them); two
    /// plain loops the compiler vectorizes.
    fn merge_bounds(lo: &mut [Self], hi: &mut [Self], slo: &[Self], shi: &[Self]);
    /// The least and greatest of `lo` and `hi` (bounds without NaN) as f32, (+∞, −∞)
    /// when empty.
    #[inline]
    fn bounds_f32(lo: &[Self], hi: &[Self]) -> (f32, f32) {
        if lo.is_empty() || hi.is_empty() {
            return (f32::INFINITY, f32::NEG_INFINITY);
        }
        let m = lo.iter().fold(Self::TOP, |a, &x| if x < a { x } else { a });
        let mx = hi
            .iter()
            .fold(Self::BOTTOM, |a, &x| if x > a { x } else { a });
        (m.to_f32(), mx.to_f32())
    }
    /// The samples as f32 without conversion, when they already are f32.
    #[inline(always)]
    fn as_f32_slice(_s: &[Self]) -> Option<&[f32]> {
        None
    }
    /// `vol` as the [`AnyVolume`](crate::render::AnyVolume) of its voxel type.
    fn any(vol: crate::volume::Volume<'_, Self>) -> crate::render::AnyVolume<'_>;
}

impl Voxel for f32 {
    const TYPE_NAME: &'static str = "float";
    const TOP: f32 = f32::INFINITY;
    const BOTTOM: f32 = f32::NEG_INFINITY;
    #[inline]
    fn widen_bounds(lo: &mut [f32], hi: &mut [f32], src: &[f32]) {
        for ((lo, hi), &v) in lo.iter_mut().zip(hi.iter_mut()).zip(src) {
            let (l, h) = if v.is_nan() {
                (f32::NEG_INFINITY, f32::INFINITY)
            } else {
                (v, v)
            };
            // Every element stored, the bound kept on the left (`cur < l ? cur : l`,
            // one vminps): written as `if l < *lo { *lo = l }` the vectorized loop used
            // masked stores, microcoded and many times slower on AMD Zen.
            let (cl, ch) = (*lo, *hi);
            *lo = if cl < l { cl } else { l };
            *hi = if ch > h { ch } else { h };
        }
    }
    #[inline]
    fn merge_bounds(lo: &mut [f32], hi: &mut [f32], slo: &[f32], shi: &[f32]) {
        // `min`/`max` (no NaN here): unconditional stores, as in `widen_bounds` (the
        // select form of that loop gave masked stores here).
        for (lo, &l) in lo.iter_mut().zip(slo) {
            *lo = lo.min(l);
        }
        for (hi, &h) in hi.iter_mut().zip(shi) {
            *hi = hi.max(h);
        }
    }
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self
    }
    #[inline(always)]
    fn as_f32_slice(s: &[f32]) -> Option<&[f32]> {
        Some(s)
    }
    fn any(vol: crate::volume::Volume<'_, f32>) -> crate::render::AnyVolume<'_> {
        crate::render::AnyVolume::F32(vol)
    }
}

impl Voxel for i16 {
    const TYPE_NAME: &'static str = "short";
    const TOP: i16 = i16::MAX;
    const BOTTOM: i16 = i16::MIN;
    #[inline]
    fn widen_bounds(lo: &mut [i16], hi: &mut [i16], src: &[i16]) {
        // Integer min and max, which the compiler turns into 16-bit vector operations.
        for ((lo, hi), &v) in lo.iter_mut().zip(hi.iter_mut()).zip(src) {
            *lo = (*lo).min(v);
            *hi = (*hi).max(v);
        }
    }
    #[inline]
    fn merge_bounds(lo: &mut [i16], hi: &mut [i16], slo: &[i16], shi: &[i16]) {
        for (lo, &l) in lo.iter_mut().zip(slo) {
            *lo = (*lo).min(l);
        }
        for (hi, &h) in hi.iter_mut().zip(shi) {
            *hi = (*hi).max(h);
        }
    }
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self as f32
    }
    fn any(vol: crate::volume::Volume<'_, i16>) -> crate::render::AnyVolume<'_> {
        crate::render::AnyVolume::I16(vol)
    }
}
