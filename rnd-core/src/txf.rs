//! Transfer functions: control-point maps in rgb / hsv / alpha, HSV→RGB, LUT
//! generation and lookup, and Levoy (1988) iso-contour opacity.

use alloc::vec::Vec;
use core::fmt;
use core::str::FromStr;

use crate::classify::{LutAxis, Quantity};
use crate::error::{Error, ErrorKind, Param, Result};
use crate::math;

/// The space of a control-point file (`#space:=...` or `#range:=...`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TxfSpace {
    /// Red, green, blue in [0, 1].
    Rgb,
    /// Hue, saturation, value in [0, 1] (hue wraps).
    Hsv,
    /// One opacity.
    Alpha,
}

impl TxfSpace {
    /// Number of values per control point after the position.
    pub fn channels(self) -> usize {
        match self {
            TxfSpace::Alpha => 1,
            _ => 3,
        }
    }
    /// Name as written in files.
    pub fn as_str(self) -> &'static str {
        match self {
            TxfSpace::Rgb => "rgb",
            TxfSpace::Hsv => "hsv",
            TxfSpace::Alpha => "alpha",
        }
    }
}

impl fmt::Display for TxfSpace {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl FromStr for TxfSpace {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s.trim().to_ascii_lowercase().as_str() {
            "rgb" => Ok(TxfSpace::Rgb),
            "hsv" => Ok(TxfSpace::Hsv),
            "alpha" => Ok(TxfSpace::Alpha),
            _ => Err(Error::new(
                ErrorKind::Name,
                alloc::format!("unknown space \"{s}\" (need rgb, hsv or alpha)"),
            )),
        }
    }
}

/// HSV → RGB by the hexcone model (H in sixths of the circle: the sextant picks which
/// of R, G, B is V, which is V·(1 − S) and which ramps between). All components in [0, 1]; H = 1 behaves like H = 0.
pub fn hsv_to_rgb(hsv: [f64; 3]) -> [f64; 3] {
    let [h, s, v] = hsv;
    if s == 0.0 {
        return [v, v, v];
    }
    let h = 6.0 * (h - math::floor(h));
    let i = math::floor(h);
    let f = h - i;
    let p = v * (1.0 - s);
    let q = v * (1.0 - s * f);
    let t = v * (1.0 - s * (1.0 - f));
    match i as i32 {
        0 | 6 => [v, t, p],
        1 => [q, v, p],
        2 => [p, v, t],
        3 => [p, q, v],
        4 => [t, p, v],
        _ => [v, p, q],
    }
}

/// A validated control-point transfer function.
#[derive(Debug, Clone, PartialEq)]
pub struct Txf {
    space: TxfSpace,
    /// Control point positions, strictly increasing.
    xs: Vec<f64>,
    /// Control point values (1 or 3 used, per `space`).
    vals: Vec<[f64; 3]>,
}

impl Txf {
    /// Builds from rows `x c0 [c1 c2]` whose width is checked here (the form of a
    /// control-point file; [`Txf::rgb`], [`Txf::hsv`] and [`Txf::alpha`] take rows of
    /// the right width by type). Positions must be finite and strictly increasing,
    /// values finite; at least one row.
    ///
    /// # Errors
    /// [`ErrorKind::Txf`] naming the first bad row.
    pub fn new(space: TxfSpace, rows: &[&[f64]]) -> Result<Txf> {
        let nc = space.channels() + 1;
        if rows.is_empty() {
            return Err(Error::new(
                ErrorKind::Txf,
                "transfer function has no control points",
            ));
        }
        let mut xs = Vec::with_capacity(rows.len());
        let mut vals = Vec::with_capacity(rows.len());
        for (i, r) in rows.iter().enumerate() {
            if r.len() != nc {
                return Err(Error::new(
                    ErrorKind::Txf,
                    alloc::format!(
                        "row {i} has {} columns; space {space} needs {nc} (position + {})",
                        r.len(),
                        nc - 1
                    ),
                ));
            }
            if r.iter().any(|x| !x.is_finite()) {
                return Err(Error::new(
                    ErrorKind::Txf,
                    alloc::format!("row {i} has a non-finite number"),
                ));
            }
            if let Some(&last) = xs.last() {
                if r[0] <= last {
                    return Err(Error::new(
                        ErrorKind::Txf,
                        alloc::format!(
                            "control points not strictly increasing: row {i} at {} after {last}",
                            r[0]
                        ),
                    ));
                }
            }
            xs.push(r[0]);
            let mut v = [0.0; 3];
            v[..nc - 1].copy_from_slice(&r[1..]);
            vals.push(v);
        }
        // Interpolation divides by differences of positions: they must be finite.
        let (first, last) = (xs[0], xs[xs.len() - 1]);
        if !(last - first).is_finite() {
            return Err(Error::new(
                ErrorKind::Txf,
                alloc::format!(
                    "control points span [{first:e}, {last:e}], wider than a double can hold"
                ),
            ));
        }
        Ok(Txf { space, xs, vals })
    }

    /// A colour transfer function from RGB control points `[position, r, g, b]`.
    ///
    /// ```
    /// use rnd_core::txf::Txf;
    ///
    /// let ramp = Txf::rgb(&[[0.0, 0.0, 0.0, 1.0], [1.0, 1.0, 0.5, 0.0]]).unwrap();
    /// assert_eq!(ramp.eval(0.5), [0.5, 0.25, 0.5]);
    /// ```
    ///
    /// # Errors
    /// As [`Txf::new`].
    pub fn rgb(points: &[[f64; 4]]) -> Result<Txf> {
        Self::from_points(TxfSpace::Rgb, points)
    }

    /// A colour transfer function from HSV control points `[position, h, s, v]` (hue in
    /// [0, 1), interpolated the short way round; evaluated to RGB).
    ///
    /// # Errors
    /// As [`Txf::new`].
    pub fn hsv(points: &[[f64; 4]]) -> Result<Txf> {
        Self::from_points(TxfSpace::Hsv, points)
    }

    /// An opacity transfer function from control points `[position, alpha]`.
    ///
    /// ```
    /// use rnd_core::txf::Txf;
    ///
    /// let a = Txf::alpha(&[[0.0, 0.0], [100.0, 0.0], [200.0, 0.8]]).unwrap();
    /// assert_eq!(a.eval(150.0)[0], 0.4);
    /// assert!(Txf::alpha(&[[1.0, 0.0], [0.0, 1.0]]).is_err()); // not increasing
    /// ```
    ///
    /// # Errors
    /// As [`Txf::new`].
    pub fn alpha(points: &[[f64; 2]]) -> Result<Txf> {
        Self::from_points(TxfSpace::Alpha, points)
    }

    fn from_points<const N: usize>(space: TxfSpace, points: &[[f64; N]]) -> Result<Txf> {
        let rows: Vec<&[f64]> = points.iter().map(|p| &p[..]).collect();
        Txf::new(space, &rows)
    }

    /// The space.
    pub fn space(&self) -> TxfSpace {
        self.space
    }
    /// First and last control-point positions (the txf's own domain).
    pub fn domain(&self) -> (f64, f64) {
        (self.xs[0], self.xs[self.xs.len() - 1])
    }

    /// Evaluates at `x`: clamped ends, piecewise linear between points; HSV interpolated
    /// (hue along the shorter arc of the colour circle) and returned converted to RGB. For alpha, only
    /// element 0 is meaningful.
    pub fn eval(&self, x: f64) -> [f64; 3] {
        let raw = self.eval_raw(x);
        match self.space {
            TxfSpace::Hsv => hsv_to_rgb(raw),
            _ => raw,
        }
    }

    /// Evaluates without HSV→RGB conversion.
    pub fn eval_raw(&self, x: f64) -> [f64; 3] {
        let n = self.xs.len();
        if x.is_nan() {
            return [f64::NAN; 3];
        }
        if x <= self.xs[0] {
            return self.vals[0];
        }
        if x >= self.xs[n - 1] {
            return self.vals[n - 1];
        }
        // first index with xs[i] > x
        let hi = self.xs.partition_point(|&p| p <= x);
        let lo = hi - 1;
        let t = (x - self.xs[lo]) / (self.xs[hi] - self.xs[lo]);
        let (a, b) = (self.vals[lo], self.vals[hi]);
        let mut out = [0.0; 3];
        for c in 0..3 {
            out[c] = a[c] + t * (b[c] - a[c]);
        }
        if self.space == TxfSpace::Hsv {
            let (h0, mut h1) = (a[0], b[0]);
            let d = h1 - h0;
            // Shorter arc; exactly 0.5 apart goes toward increasing hue.
            if d > 0.5 {
                h1 -= 1.0;
            } else if d <= -0.5 {
                h1 += 1.0;
            }
            let h = h0 + t * (h1 - h0);
            out[0] = h - math::floor(h);
        }
        out
    }
}

/// How a [`Lut`] is made from transfer functions: see [`Lut::builder`].
#[derive(Debug, Clone, Copy)]
pub struct LutBuilder<'t> {
    domain: (f64, f64),
    entries: usize,
    colour: Option<(&'t Txf, bool)>,
    opacity: Option<(&'t Txf, bool)>,
}

impl<'t> LutBuilder<'t> {
    /// Colour from an RGB or HSV txf, evaluated at the values themselves.
    pub fn colour(mut self, txf: &'t Txf) -> Self {
        self.colour = Some((txf, false));
        self
    }
    /// Colour from an RGB or HSV txf whose own domain (first to last control point) is
    /// stretched onto the LUT's.
    pub fn colour_stretched(mut self, txf: &'t Txf) -> Self {
        self.colour = Some((txf, true));
        self
    }
    /// Opacity from an alpha txf, evaluated at the values themselves.
    pub fn opacity(mut self, txf: &'t Txf) -> Self {
        self.opacity = Some((txf, false));
        self
    }
    /// Opacity from an alpha txf whose own domain is stretched onto the LUT's.
    pub fn opacity_stretched(mut self, txf: &'t Txf) -> Self {
        self.opacity = Some((txf, true));
        self
    }
    /// The number of entries (cells of equal width over the domain).
    pub fn entries(mut self, n: usize) -> Self {
        self.entries = n;
        self
    }
    /// Makes the LUT (white where no colour txf is given, opaque where no opacity txf
    /// is).
    ///
    /// # Errors
    /// [`ErrorKind::Txf`] for a domain that is not finite min < max, no entries, or a
    /// txf of the wrong space; [`ErrorKind::Memory`] when the entries cannot be
    /// allocated.
    pub fn build(self) -> Result<Lut> {
        let (c, cs) = self.colour.map_or((None, false), |(t, s)| (Some(t), s));
        let (a, as_) = self.opacity.map_or((None, false), |(t, s)| (Some(t), s));
        Lut::generate(c, a, cs, as_, self.entries, self.domain.0, self.domain.1)
    }
}

/// An RGBA lookup table over one or two quantities, with cell-centred entries: along
/// an axis of N entries over [min, max], entry i stands for the cell
/// [min + i·w, min + (i + 1)·w), w = (max − min)/N. A 1-D LUT is usually over the value
/// (`v`); a 2-D one (see [`crate::classify`]) has entry (i, j) at i + N·j.
#[derive(Debug, Clone, PartialEq)]
pub struct Lut {
    axes: [LutAxis; 2],
    dims: usize,
    rgba: Vec<[f32; 4]>,
}

impl Lut {
    /// Wraps existing entries of a 1-D LUT over the value. Fails unless vmin < vmax are
    /// finite and there is at least one entry.
    ///
    /// # Errors
    /// [`ErrorKind::Txf`] for a domain that is not finite min < max, no entries or
    /// non-finite entries.
    pub fn new(vmin: f64, vmax: f64, rgba: Vec<[f32; 4]>) -> Result<Lut> {
        if !(vmin.is_finite() && vmax.is_finite() && vmin < vmax) {
            return Err(Error::new(
                ErrorKind::Txf,
                alloc::format!("LUT domain [{vmin}, {vmax}] needs finite min < max"),
            ));
        }
        let axis = LutAxis::new(Quantity::Value, vmin, vmax, rgba.len());
        Lut::with_axes(&[axis], rgba)
    }

    /// Wraps existing entries of a LUT over one or two axes (entry (i, j) at i + N·j),
    /// each axis a different quantity.
    ///
    /// # Errors
    /// [`ErrorKind::Txf`] for no or more than two axes, an axis whose domain is not
    /// finite min < max or that has no entries, two axes of one quantity, a number of
    /// entries other than the product of the axes' lengths, or non-finite entries.
    pub fn with_axes(axes: &[LutAxis], rgba: Vec<[f32; 4]>) -> Result<Lut> {
        let dims = axes.len();
        let Some(&first) = axes.first().filter(|_| dims <= 2) else {
            return Err(Error::new(
                ErrorKind::Txf,
                alloc::format!("a LUT has 1 or 2 axes, not {dims}"),
            ));
        };
        let second = axes.get(1).copied().unwrap_or(LutAxis::new(
            if first.quantity == Quantity::Value {
                Quantity::GradMag
            } else {
                Quantity::Value
            },
            0.0,
            1.0,
            1,
        ));
        if rgba.is_empty() {
            return Err(Error::new(ErrorKind::Txf, "LUT has no entries"));
        }
        let all = [first, second];
        let n = Lut::entry_count(&all)?;
        if rgba.len() != n {
            return Err(Error::new(
                ErrorKind::Txf,
                alloc::format!(
                    "LUT has {} entries, its axes need {n} ({} x {})",
                    rgba.len(),
                    first.len,
                    second.len
                ),
            ));
        }
        if rgba.iter().flatten().any(|x| !x.is_finite()) {
            return Err(Error::new(ErrorKind::Txf, "LUT has non-finite entries"));
        }
        Ok(Lut {
            axes: all,
            dims,
            rgba,
        })
    }

    /// The number of entries of a LUT over both `axes` (checked, distinct quantities).
    pub(crate) fn entry_count(axes: &[LutAxis; 2]) -> Result<usize> {
        for a in axes {
            a.check()?;
        }
        if axes[0].quantity == axes[1].quantity {
            return Err(Error::new(
                ErrorKind::Txf,
                alloc::format!("both LUT axes are {}", axes[0].quantity),
            ));
        }
        axes[0]
            .len
            .checked_mul(axes[1].len)
            .ok_or_else(|| Error::new(ErrorKind::Memory, "LUT too large to allocate"))
    }

    /// A builder of a LUT over the value domain [`vmin`, `vmax`] from colour and opacity
    /// transfer functions (256 entries unless told).
    ///
    /// ```
    /// use rnd_core::txf::{Lut, Txf};
    ///
    /// let colour = Txf::rgb(&[[0.0, 1.0, 0.9, 0.8], [1.0, 1.0, 1.0, 1.0]]).unwrap();
    /// let opacity = Txf::alpha(&[[0.0, 0.0], [1.0, 1.0]]).unwrap();
    /// let lut = Lut::builder(0.0, 500.0)
    ///     .colour_stretched(&colour) // [0, 1] of the colour txf spans [0, 500]
    ///     .opacity_stretched(&opacity)
    ///     .entries(100)
    ///     .build()
    ///     .unwrap();
    /// assert_eq!(lut.entries().len(), 100);
    /// assert_eq!(lut.lookup(0.0)[3], 0.005); // the first entry's centre: 0.5 / 100
    /// ```
    pub fn builder<'t>(vmin: f64, vmax: f64) -> LutBuilder<'t> {
        LutBuilder {
            domain: (vmin, vmax),
            entries: 256,
            colour: None,
            opacity: None,
        }
    }

    /// Generates a LUT of `len` entries over [vmin, vmax]: entry i samples the
    /// transfer functions at the centre of its cell, vmin + (i + ½)(vmax − vmin)/len.
    /// `ctxf` must be in rgb/hsv, `atxf` in alpha; a missing txf gives 1. `crs`/`ars`
    /// stretch each txf's own domain onto the LUT domain (an error without that txf).
    /// [`Lut::builder`] is the same with names instead of positions.
    ///
    /// # Errors
    /// [`ErrorKind::Txf`] for a bad domain, length or txf space.
    #[doc(hidden)]
    pub fn generate(
        ctxf: Option<&Txf>,
        atxf: Option<&Txf>,
        crs: bool,
        ars: bool,
        len: usize,
        vmin: f64,
        vmax: f64,
    ) -> Result<Lut> {
        if len == 0 {
            return Err(Error::new(ErrorKind::Txf, "LUT length must be > 0"));
        }
        if !(vmin.is_finite() && vmax.is_finite() && vmin < vmax) {
            return Err(Error::about(
                ErrorKind::Txf,
                Param::LutDomain,
                alloc::format!("LUT domain needs finite min < max (got {vmin} {vmax})"),
            ));
        }
        if !(vmax - vmin).is_finite() {
            return Err(Error::about(
                ErrorKind::Txf,
                Param::LutDomain,
                alloc::format!("LUT domain [{vmin:e}, {vmax:e}] is wider than a double can hold"),
            ));
        }
        if let Some(c) = ctxf {
            if c.space == TxfSpace::Alpha {
                return Err(Error::new(
                    ErrorKind::Txf,
                    "colour txf must be in space rgb or hsv",
                ));
            }
        } else if crs {
            return Err(Error::new(
                ErrorKind::Txf,
                "can't rescale colour without a colour txf",
            ));
        }
        if let Some(a) = atxf {
            if a.space != TxfSpace::Alpha {
                return Err(Error::new(
                    ErrorKind::Txf,
                    alloc::format!("opacity txf must be in space alpha, not {}", a.space),
                ));
            }
        } else if ars {
            return Err(Error::new(
                ErrorKind::Txf,
                "can't rescale opacity without an opacity txf",
            ));
        }
        let range = |t: Option<&Txf>, rs: bool| match (t, rs) {
            (Some(t), true) => t.domain(),
            _ => (vmin, vmax),
        };
        let (c0, c1) = range(ctxf, crs);
        let (a0, a1) = range(atxf, ars);
        let mut rgba = Vec::new();
        rgba.try_reserve_exact(len)
            .map_err(|_| Error::new(ErrorKind::Memory, "LUT length too large to allocate"))?;
        for i in 0..len {
            let a = (i as f64 + 0.5) / len as f64;
            let rgb = match ctxf {
                Some(t) => t.eval(c0 + a * (c1 - c0)),
                None => [1.0; 3],
            };
            let al = match atxf {
                Some(t) => t.eval(a0 + a * (a1 - a0))[0],
                None => 1.0,
            };
            rgba.push([rgb[0] as f32, rgb[1] as f32, rgb[2] as f32, al as f32]);
        }
        Lut::new(vmin, vmax, rgba)
    }

    /// The first axis's domain minimum.
    pub fn vmin(&self) -> f64 {
        self.axes[0].min
    }
    /// The first axis's domain maximum.
    pub fn vmax(&self) -> f64 {
        self.axes[0].max
    }
    /// The entries (for two axes, entry (i, j) at i + N·j).
    pub fn entries(&self) -> &[[f32; 4]] {
        &self.rgba
    }
    /// The axes (one or two).
    pub fn axes(&self) -> &[LutAxis] {
        &self.axes[..self.dims]
    }
    /// Whether this is a 1-D LUT over the value (opacity a function of the value alone).
    pub fn by_value(&self) -> bool {
        self.dims == 1 && self.axes[0].quantity == Quantity::Value
    }
    /// Whether classifying needs the gradient.
    pub fn needs_gradient(&self) -> bool {
        self.axes().iter().any(|a| a.quantity.needs_gradient())
    }
    /// Whether classifying needs second derivatives (a curvature axis).
    pub fn second_order(&self) -> bool {
        self.axes().iter().any(|a| a.quantity.second_order())
    }

    /// Nearest cell-centred entry for value `v` along the first axis (the entry of a
    /// 1-D LUT): clamped to the domain, no interpolation. NaN maps to entry 0.
    #[inline]
    pub fn lookup(&self, v: f32) -> [f32; 4] {
        self.rgba[self.index(v as f64)]
    }

    /// Entry index for `v` along the first axis (the entry of a 1-D LUT):
    /// floor((v − vmin)/(vmax − vmin)·N) clamped to [0, N − 1]; NaN gives 0.
    #[inline]
    pub fn index(&self, v: f64) -> usize {
        self.axes[0].index(v)
    }

    /// Entry index for a sample where the axes' quantities measure `q` (the second
    /// ignored by a 1-D LUT): i + N·j.
    #[inline]
    pub fn entry(&self, q: [f64; 2]) -> usize {
        let i = self.axes[0].index(q[0]);
        if self.dims == 1 {
            return i;
        }
        i + self.axes[0].len * self.axes[1].index(q[1])
    }
}

/// Levoy iso-contour opacity functions: a set of (isovalue v, thickness r, max opacity a)
/// (after Levoy 1988: contour i gives a·(1 − |f − v|/(r·|∇f|)) where |f − v| < r·|∇f|,
/// else 0; the contours combine as 1 − Π(1 − αᵢ)).
///
/// ```
/// use rnd_core::txf::Levoy;
///
/// // One iso-contour at value 100, two value units thick per unit of gradient, opacity 0.8.
/// let lev = Levoy::new(vec![[100.0, 2.0, 0.8]]).unwrap();
/// assert_eq!(lev.opacity(100.0, 5.0), 0.8); // on the contour
/// // Half way out (width r·|∇f| = 10): 0.4, up to the f32 rounding of 1 − (1 − α).
/// assert!((lev.opacity(105.0, 5.0) - 0.4).abs() < 1e-6);
/// assert_eq!(lev.opacity(120.0, 5.0), 0.0);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Levoy {
    items: Vec<[f32; 3]>,
}

impl Levoy {
    /// From (v, r, a) triples: all finite, r > 0, a ≥ 0, at least one.
    ///
    /// # Errors
    /// [`ErrorKind::Txf`] for non-finite numbers or thickness/opacity out of range.
    pub fn new(items: Vec<[f32; 3]>) -> Result<Levoy> {
        if items.is_empty() {
            return Err(Error::new(ErrorKind::Txf, "Levoy file has no iso-contours"));
        }
        for (i, it) in items.iter().enumerate() {
            if it.iter().any(|x| !x.is_finite()) {
                return Err(Error::new(
                    ErrorKind::Txf,
                    alloc::format!("Levoy row {i}: non-finite number"),
                ));
            }
            if !(it[1] > 0.0) {
                return Err(Error::new(
                    ErrorKind::Txf,
                    alloc::format!("Levoy row {i}: thickness {} must be > 0", it[1]),
                ));
            }
            if it[2] < 0.0 {
                return Err(Error::new(
                    ErrorKind::Txf,
                    alloc::format!("Levoy row {i}: opacity {} must be >= 0", it[2]),
                ));
            }
        }
        Ok(Levoy { items })
    }

    /// The (v, r, a) triples.
    pub fn items(&self) -> &[[f32; 3]] {
        &self.items
    }

    /// Combined opacity 1 − Π(1 − αₖ) at value `f` and gradient magnitude `gm` (may
    /// exceed 1 when some a > 1; clamping is the caller's).
    #[inline]
    pub fn opacity(&self, f: f32, gm: f32) -> f32 {
        let mut transp = 1.0f32;
        for &[v, r, a] in &self.items {
            let ak = if gm == 0.0 {
                if f == v {
                    a
                } else {
                    0.0
                }
            } else {
                let d = (f - v).abs();
                let w = r * gm;
                if d < w {
                    a * (1.0 - d / w)
                } else {
                    0.0
                }
            };
            transp *= 1.0 - ak;
        }
        1.0 - transp
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The entry index is floor((v − vmin)/(vmax − vmin)·len) clamped to [0, len − 1]
    /// (the lookup rule), NaN giving entry 0: checked against that formula at and next to
    /// every entry boundary, outside the domain, and for odd domains.
    #[test]
    fn lut_index_is_the_clamped_floor() {
        for (lo, hi, len) in [
            (0.0, 1.0, 512usize),
            (-5.364, 33.43, 4),
            (0.0, 2000.0, 1024),
            (-1e-3, 7.0, 3),
        ] {
            let lut = Lut::new(lo, hi, alloc::vec![[0.0; 4]; len]).unwrap();
            let want = |v: f64| {
                let f = (v.clamp(lo, hi) - lo) / (hi - lo) * len as f64;
                let i = math::floor(f);
                if i >= 0.0 {
                    (i as usize).min(len - 1)
                } else {
                    0
                }
            };
            let mut vs = alloc::vec![
                f64::NAN,
                f64::INFINITY,
                f64::NEG_INFINITY,
                lo - 1.0,
                hi + 1.0,
                lo,
                hi
            ];
            for e in 0..=len {
                let b = lo + (hi - lo) * e as f64 / len as f64;
                vs.extend([b, b.next_up(), b.next_down(), (b as f32) as f64]);
            }
            for v in vs {
                assert_eq!(lut.index(v), want(v), "v {v} in [{lo}, {hi}] of {len}");
            }
        }
    }

    #[test]
    fn hsv_checks() {
        let a = hsv_to_rgb([0.9, 1.0, 1.0]);
        assert!((a[0] - 1.0).abs() < 1e-12 && a[1].abs() < 1e-12 && (a[2] - 0.6).abs() < 1e-12);
        let b = hsv_to_rgb([0.95, 0.875, 0.95]);
        let w = [0.95, 0.11875, 0.368125];
        for c in 0..3 {
            assert!((b[c] - w[c]).abs() < 1e-12, "{b:?}");
        }
    }

    #[test]
    fn lgen_8_alphas() {
        let rows: [&[f64]; 4] = [&[0.0, 0.0], &[0.8, 0.0], &[0.9, 1.0], &[1.0, 1.0]];
        let a = Txf::new(TxfSpace::Alpha, &rows).unwrap();
        let lut = Lut::generate(None, Some(&a), false, false, 8, 0.0, 1.0).unwrap();
        let al: Vec<f32> = lut.entries().iter().map(|e| e[3]).collect();
        let want = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.125, 1.0];
        for (x, y) in al.iter().zip(want) {
            assert!((x - y).abs() < 1e-6, "{al:?}");
        }
    }

    #[test]
    fn levoy_examples() {
        let l = Levoy::new(alloc::vec![
            [0.6, 0.035, 0.1],
            [0.8, 0.035, 0.2],
            [0.95, 0.035, 1.3]
        ])
        .unwrap();
        let cases = [
            (0.6, 1.0, 0.1),
            (0.62, 1.0, 0.0428571),
            (0.8, 2.0, 0.2),
            (0.95, 1.0, 1.3),
            (0.96, 1.0, 0.928571),
            (0.7, 1.0, 0.0),
        ];
        for (f, g, want) in cases {
            let o = l.opacity(f, g);
            assert!((o - want).abs() < 2e-5, "levoy({f},{g}) = {o}, want {want}");
        }
    }

    #[test]
    fn hue_shorter_arc() {
        let rows: [&[f64]; 2] = [&[0.0, 0.9, 1.0, 1.0], &[1.0, 0.1, 1.0, 1.0]];
        let t = Txf::new(TxfSpace::Hsv, &rows).unwrap();
        let h = t.eval_raw(0.5)[0];
        assert!(h.abs() < 1e-12 || (h - 1.0).abs() < 1e-12, "{h}");
        let rows: [&[f64]; 2] = [&[0.0, 0.0, 1.0, 1.0], &[1.0, 0.5, 1.0, 1.0]];
        let t = Txf::new(TxfSpace::Hsv, &rows).unwrap();
        assert!((t.eval_raw(0.5)[0] - 0.25).abs() < 1e-12);
    }
}
