//! Classification over one or two quantities: what a LUT axis measures
//! ([`Quantity`]), the axes of a LUT ([`LutAxis`]), and 2-D LUTs made of simple
//! primitives ([`Primitive`], [`Lut::from_primitives`]).
//!
//! A 2-D LUT classifies a sample by a pair of quantities, e.g. value × gradient
//! magnitude, where material boundaries show as arches (Kniss, Kindlmann and Hansen
//! 2001), or the principal curvatures κ1 × κ2 (Kindlmann, Whitaker, Tasdizen and
//! Möller 2003). Entry (i, j) of an N × M LUT is entry i + N·j of
//! [`Lut::entries`]; each axis picks its index as a 1-D LUT does (the clamped floor of
//! the quantity's place in [min, max] times the axis length).

use alloc::vec::Vec;
use core::fmt;
use core::str::FromStr;

use crate::error::{Error, ErrorKind, Result};
use crate::math;
use crate::txf::Lut;

/// A quantity a LUT axis classifies by, measured at each sample as the probe of the
/// same name measures it (`v`, `gm`, `k1`, `k2`, `meancurv`, `gausscurv`).
///
/// ```
/// use rnd_core::classify::Quantity;
///
/// assert_eq!("gm".parse::<Quantity>().unwrap(), Quantity::GradMag);
/// // Teem's txf labels name the same quantities.
/// assert_eq!(Quantity::from_label("gage(scalar:k1)"), Some(Quantity::K1));
/// assert_eq!(Quantity::from_label("gage(mc)"), Some(Quantity::MeanCurv));
/// assert_eq!(Quantity::GaussCurv.teem_label(), "gage(scalar:gausscurv)");
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Quantity {
    /// The reconstructed value.
    Value,
    /// The world-space gradient magnitude.
    GradMag,
    /// The larger principal curvature κ1.
    K1,
    /// The smaller principal curvature κ2.
    K2,
    /// Mean curvature (κ1 + κ2)/2.
    MeanCurv,
    /// Gaussian curvature κ1·κ2.
    GaussCurv,
}

impl Quantity {
    /// Every quantity.
    pub const ALL: [Quantity; 6] = [
        Quantity::Value,
        Quantity::GradMag,
        Quantity::K1,
        Quantity::K2,
        Quantity::MeanCurv,
        Quantity::GaussCurv,
    ];

    /// Name (the probe's name).
    pub fn as_str(self) -> &'static str {
        match self {
            Quantity::Value => "v",
            Quantity::GradMag => "gm",
            Quantity::K1 => "k1",
            Quantity::K2 => "k2",
            Quantity::MeanCurv => "meancurv",
            Quantity::GaussCurv => "gausscurv",
        }
    }

    /// The axis label Teem's `miter` reads for this quantity (`gage(scalar:NAME)`).
    pub fn teem_label(self) -> &'static str {
        match self {
            Quantity::Value => "gage(scalar:v)",
            Quantity::GradMag => "gage(scalar:gm)",
            Quantity::K1 => "gage(scalar:k1)",
            Quantity::K2 => "gage(scalar:k2)",
            Quantity::MeanCurv => "gage(scalar:meancurv)",
            Quantity::GaussCurv => "gage(scalar:gausscurv)",
        }
    }

    /// The quantity an axis label names: a name ([`Quantity::as_str`], or Teem's `mc`,
    /// `gc`, `val`, `value`, `gmag`, `kappa1`, `kappa2`), bare or as Teem writes it,
    /// `gage(NAME)` or `gage(scalar:NAME)`; any case.
    pub fn from_label(label: &str) -> Option<Quantity> {
        let s = label.trim();
        let inner = match (s.get(..5), s.strip_suffix(')')) {
            (Some(g), Some(rest)) if g.eq_ignore_ascii_case("gage(") => rest.get(5..)?,
            _ => s,
        };
        let name = match inner.split_once(':') {
            Some((kind, name)) if kind.trim().eq_ignore_ascii_case("scalar") => name,
            Some(_) => return None,
            None => inner,
        };
        let name = name.trim();
        let is = |names: &[&str]| names.iter().any(|n| n.eq_ignore_ascii_case(name));
        Quantity::ALL.into_iter().find(|q| {
            name.eq_ignore_ascii_case(q.as_str())
                || match q {
                    Quantity::Value => is(&["val", "value"]),
                    Quantity::GradMag => is(&["gmag", "gradmag"]),
                    Quantity::K1 => is(&["kappa1"]),
                    Quantity::K2 => is(&["kappa2"]),
                    Quantity::MeanCurv => is(&["mc"]),
                    Quantity::GaussCurv => is(&["gc"]),
                }
        })
    }

    /// Whether measuring it needs the gradient (all but `v`).
    pub fn needs_gradient(self) -> bool {
        self != Quantity::Value
    }

    /// Whether measuring it needs second derivatives (the curvatures).
    pub fn second_order(self) -> bool {
        !matches!(self, Quantity::Value | Quantity::GradMag)
    }

    /// This quantity at a sample of value `v`, gradient magnitude `gm` and principal
    /// curvatures `k` (what the sample measures; curvatures unused by `v` and `gm`).
    #[inline]
    pub fn of(self, v: f64, gm: f64, k: [f64; 2]) -> f64 {
        match self {
            Quantity::Value => v,
            Quantity::GradMag => gm,
            Quantity::K1 => k[0],
            Quantity::K2 => k[1],
            Quantity::MeanCurv => 0.5 * (k[0] + k[1]),
            Quantity::GaussCurv => k[0] * k[1],
        }
    }
}

impl fmt::Display for Quantity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl FromStr for Quantity {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        Quantity::from_label(s).ok_or_else(|| {
            Error::new(
                ErrorKind::Name,
                alloc::format!("unknown quantity \"{s}\" (known: v gm k1 k2 meancurv gausscurv)"),
            )
        })
    }
}

/// One axis of a LUT: the quantity it classifies by, its domain [min, max] and its
/// number of cell-centred entries.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LutAxis {
    /// What the axis measures.
    pub quantity: Quantity,
    /// Domain minimum.
    pub min: f64,
    /// Domain maximum.
    pub max: f64,
    /// Number of entries along the axis.
    pub len: usize,
}

impl LutAxis {
    /// An axis of `len` entries over [min, max] for `quantity`.
    pub fn new(quantity: Quantity, min: f64, max: f64, len: usize) -> Self {
        LutAxis {
            quantity,
            min,
            max,
            len,
        }
    }

    /// Fails unless min < max are finite with a finite width and len ≥ 1.
    pub(crate) fn check(&self) -> Result<()> {
        let (lo, hi) = (self.min, self.max);
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(Error::new(
                ErrorKind::Txf,
                alloc::format!(
                    "LUT {} axis domain [{lo}, {hi}] needs finite min < max",
                    self.quantity
                ),
            ));
        }
        if !(hi - lo).is_finite() {
            return Err(Error::new(
                ErrorKind::Txf,
                alloc::format!(
                    "LUT {} axis domain [{lo:e}, {hi:e}] is wider than a double can hold",
                    self.quantity
                ),
            ));
        }
        if self.len == 0 {
            return Err(Error::new(
                ErrorKind::Txf,
                alloc::format!("LUT {} axis has no entries", self.quantity),
            ));
        }
        Ok(())
    }

    /// The entry along this axis for `x`: floor((x − min)/(max − min)·len) clamped to
    /// [0, len − 1]; NaN gives 0.
    #[inline]
    pub fn index(&self, x: f64) -> usize {
        let x = x.clamp(self.min, self.max);
        let f = (x - self.min) / (self.max - self.min) * self.len as f64;
        // f is in [0, len] (or NaN, for a NaN value): below 1 (and NaN) the entry is
        // 0, above it truncation is the floor.
        let i = if f >= 1.0 {
            crate::simd::trunc_i64(f) as usize
        } else {
            0
        };
        i.min(self.len - 1)
    }

    /// The centre of entry `i`: min + (i + ½)(max − min)/len.
    pub fn centre(&self, i: usize) -> f64 {
        self.min + (i as f64 + 0.5) * (self.max - self.min) / self.len as f64
    }
}

/// The shape of a 2-D LUT primitive, in the LUT's (first quantity, second quantity)
/// plane, written (x, y); its opacity factor at a point is in [0, 1].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// 1 inside [x0, x1] × [y0, y1] (closed), else 0.
    Box {
        /// Corner with the smaller coordinates.
        lo: [f64; 2],
        /// Corner with the larger coordinates.
        hi: [f64; 2],
    },
    /// exp(−((x − cx)²/sx² + (y − cy)²/sy²)/2).
    Gaussian {
        /// Centre.
        centre: [f64; 2],
        /// Standard deviations along each axis (> 0).
        sigma: [f64; 2],
    },
    /// Kniss's triangle over value × gradient magnitude: the region where
    /// |v − v0| < w·gm/g1 and g0 ≤ gm, opacity falling linearly from 1 on the line
    /// v = v0 to 0 at its sides (the half-width grows with gm: w at gm = g1).
    Triangle {
        /// The boundary's value.
        v0: f64,
        /// Half-width in value at gm = g1.
        w: f64,
        /// The gradient magnitude where the half-width is w (> 0).
        g1: f64,
        /// Smallest gradient magnitude classified (cuts off the noise near gm = 0).
        g0: f64,
    },
    /// The arch a blurred boundary between materials of values va < vb draws in value ×
    /// gradient magnitude: gm climbs from 0 at va and vb to `top` midway, modelled as
    /// the parabola g(v) = 4·top·t(1 − t), t = (v − va)/(vb − va); opacity
    /// 1 − |gm − g(v)|/width within `width` of it, for va < v < vb.
    Arch {
        /// The two materials' values (va < vb).
        va: f64,
        /// See `va`.
        vb: f64,
        /// Peak gradient magnitude, midway.
        top: f64,
        /// Half-thickness of the band in gradient magnitude (> 0).
        width: f64,
    },
    /// Levoy's (1988) iso-contour over value × gradient magnitude: 1 − |v − v0|/(r·gm)
    /// where |v − v0| < r·gm; at gm = 0, 1 where v = v0 (the opacity of
    /// [`crate::txf::Levoy`]).
    Levoy {
        /// Isovalue.
        v0: f64,
        /// Thickness in value per unit of gradient magnitude (> 0).
        r: f64,
    },
}

impl Shape {
    /// The opacity factor at (x, y), when the plane's axes are `qs` (the value ×
    /// gradient-magnitude shapes take their value and gm from whichever axis holds
    /// them).
    pub fn at(&self, p: [f64; 2], qs: [Quantity; 2]) -> f64 {
        let (x, y) = (p[0], p[1]);
        let vg = || {
            if qs[0] == Quantity::GradMag {
                (y, x)
            } else {
                (x, y)
            }
        };
        match *self {
            Shape::Box { lo, hi } => f64::from(u8::from(
                lo[0] <= x && x <= hi[0] && lo[1] <= y && y <= hi[1],
            )),
            Shape::Gaussian { centre, sigma } => {
                let (dx, dy) = ((x - centre[0]) / sigma[0], (y - centre[1]) / sigma[1]);
                math::exp(-0.5 * (dx * dx + dy * dy))
            }
            Shape::Triangle { v0, w, g1, g0 } => {
                let (v, gm) = vg();
                let half = w * gm / g1;
                let d = (v - v0).abs();
                if gm >= g0 && d < half {
                    1.0 - d / half
                } else {
                    0.0
                }
            }
            Shape::Arch { va, vb, top, width } => {
                let (v, gm) = vg();
                if !(va < v && v < vb) {
                    return 0.0;
                }
                let t = (v - va) / (vb - va);
                let d = (gm - 4.0 * top * t * (1.0 - t)).abs();
                (1.0 - d / width).max(0.0)
            }
            Shape::Levoy { v0, r } => {
                let (v, gm) = vg();
                let d = (v - v0).abs();
                if gm == 0.0 {
                    f64::from(u8::from(d == 0.0))
                } else if d < r * gm {
                    1.0 - d / (r * gm)
                } else {
                    0.0
                }
            }
        }
    }

    /// Whether the shape takes a value axis and a gradient-magnitude axis.
    pub fn needs_value_and_gm(&self) -> bool {
        !matches!(self, Shape::Box { .. } | Shape::Gaussian { .. })
    }

    /// Fails for parameters that are not finite or out of range.
    fn check(&self) -> Result<()> {
        let bad = |what: &str| {
            Err(Error::new(
                ErrorKind::Txf,
                alloc::format!("{} primitive: {what}", self.name()),
            ))
        };
        let finite = |xs: &[f64]| xs.iter().all(|x| x.is_finite());
        match *self {
            Shape::Box { lo, hi } => {
                if !finite(&[lo[0], lo[1], hi[0], hi[1]]) {
                    return bad("corners must be finite");
                }
                if !(lo[0] <= hi[0] && lo[1] <= hi[1]) {
                    return bad("needs lo <= hi on both axes");
                }
            }
            Shape::Gaussian { centre, sigma } => {
                if !finite(&[centre[0], centre[1], sigma[0], sigma[1]]) {
                    return bad("centre and widths must be finite");
                }
                if !(sigma[0] > 0.0 && sigma[1] > 0.0) {
                    return bad("widths must be > 0");
                }
            }
            Shape::Triangle { v0, w, g1, g0 } => {
                if !(finite(&[v0, w, g1, g0]) && w > 0.0 && g1 > 0.0) {
                    return bad("needs finite numbers, half-width > 0 and gm > 0");
                }
            }
            Shape::Arch { va, vb, top, width } => {
                if !(finite(&[va, vb, top, width]) && va < vb && width > 0.0) {
                    return bad("needs finite numbers, va < vb and width > 0");
                }
            }
            Shape::Levoy { v0, r } => {
                if !finite(&[v0, r]) || !(r > 0.0) {
                    return bad("needs a finite isovalue and thickness > 0");
                }
            }
        }
        Ok(())
    }

    /// The name a primitive file uses for this shape.
    pub fn name(&self) -> &'static str {
        match self {
            Shape::Box { .. } => "box",
            Shape::Gaussian { .. } => "gauss",
            Shape::Triangle { .. } => "triangle",
            Shape::Arch { .. } => "arch",
            Shape::Levoy { .. } => "levoy",
        }
    }
}

/// A shape with a colour and a peak opacity: where the shape's factor is s, the
/// primitive has colour `rgb` and opacity `alpha`·s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Primitive {
    /// Where, and how strongly.
    pub shape: Shape,
    /// Colour (each finite).
    pub rgb: [f64; 3],
    /// Peak opacity in [0, 1].
    pub alpha: f64,
}

impl Lut {
    /// A 2-D LUT over `axes` from `prims`, composited in order, each over the ones
    /// before it: every entry starts transparent black, and at the entry's centre a
    /// primitive of colour c and opacity a turns (C, A) into
    /// (a·c + (1 − a)·A·C)/A′, A′ = a + (1 − a)·A (un-premultiplied colour, `over`).
    /// So opacities combine as 1 − Π(1 − aₖ), as Levoy's iso-contours do.
    ///
    /// ```
    /// use rnd_core::classify::{LutAxis, Primitive, Quantity, Shape};
    /// use rnd_core::txf::Lut;
    ///
    /// let axes = [
    ///     LutAxis::new(Quantity::Value, 0.0, 100.0, 100),
    ///     LutAxis::new(Quantity::GradMag, 0.0, 50.0, 50),
    /// ];
    /// // A red box of opacity 0.5 under a blue one of opacity 0.5 where they overlap.
    /// let red = Primitive {
    ///     shape: Shape::Box { lo: [10.0, 0.0], hi: [60.0, 50.0] },
    ///     rgb: [1.0, 0.0, 0.0],
    ///     alpha: 0.5,
    /// };
    /// let blue = Primitive { shape: Shape::Box { lo: [40.0, 0.0], hi: [90.0, 50.0] }, rgb: [0.0, 0.0, 1.0], ..red };
    /// let lut = Lut::from_primitives(axes, &[red, blue]).unwrap();
    /// assert_eq!(lut.entries()[20], [1.0, 0.0, 0.0, 0.5]); // (20.5, 0.5): red only
    /// let both = lut.entries()[50 + 100 * 10]; // (50.5, 10.5): blue over red
    /// assert_eq!(both[3], 0.75);
    /// assert!((both[0] - 1.0 / 3.0).abs() < 1e-6 && (both[2] - 2.0 / 3.0).abs() < 1e-6);
    /// ```
    ///
    /// # Errors
    /// [`ErrorKind::Txf`] for a bad axis (as [`Lut::with_axes`]), both axes of one
    /// quantity, a primitive with bad parameters or one needing value and gradient
    /// magnitude axes the LUT does not have; [`ErrorKind::Memory`] when the entries
    /// cannot be allocated.
    pub fn from_primitives(axes: [LutAxis; 2], prims: &[Primitive]) -> Result<Lut> {
        for a in &axes {
            a.check()?;
        }
        let qs = [axes[0].quantity, axes[1].quantity];
        let vg = qs.contains(&Quantity::Value) && qs.contains(&Quantity::GradMag);
        for p in prims {
            p.shape.check()?;
            if !p.rgb.iter().all(|c| c.is_finite()) {
                return Err(Error::new(
                    ErrorKind::Txf,
                    alloc::format!("{} primitive: colour must be finite", p.shape.name()),
                ));
            }
            if !(0.0..=1.0).contains(&p.alpha) {
                return Err(Error::new(
                    ErrorKind::Txf,
                    alloc::format!(
                        "{} primitive: opacity {} must be in [0, 1]",
                        p.shape.name(),
                        p.alpha
                    ),
                ));
            }
            if p.shape.needs_value_and_gm() && !vg {
                return Err(Error::new(
                    ErrorKind::Txf,
                    alloc::format!(
                        "{} primitive needs axes v and gm (the LUT's are {} and {})",
                        p.shape.name(),
                        qs[0],
                        qs[1]
                    ),
                ));
            }
        }
        let n = Lut::entry_count(&axes)?;
        let mut rgba = Vec::new();
        rgba.try_reserve_exact(n)
            .map_err(|_| Error::new(ErrorKind::Memory, "LUT too large to allocate"))?;
        for j in 0..axes[1].len {
            let y = axes[1].centre(j);
            for i in 0..axes[0].len {
                let x = axes[0].centre(i);
                let (mut c, mut a) = ([0.0f64; 3], 0.0f64);
                for p in prims {
                    let pa = p.alpha * p.shape.at([x, y], qs);
                    if pa <= 0.0 {
                        continue;
                    }
                    let na = pa + (1.0 - pa) * a;
                    for (ch, &pc) in c.iter_mut().zip(&p.rgb) {
                        *ch = (pa * pc + (1.0 - pa) * a * *ch) / na;
                    }
                    a = na;
                }
                rgba.push([c[0] as f32, c[1] as f32, c[2] as f32, a as f32]);
            }
        }
        Lut::with_axes(&axes, rgba)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_name_quantities() {
        for q in Quantity::ALL {
            assert_eq!(Quantity::from_label(q.as_str()), Some(q));
            assert_eq!(Quantity::from_label(q.teem_label()), Some(q));
            let g = alloc::format!("gage({})", q.as_str().to_ascii_uppercase());
            assert_eq!(Quantity::from_label(&g), Some(q));
        }
        for bad in [
            "",
            "gage()",
            "gage(vector:v)",
            "gage(v",
            "hess",
            "gage(scalar:)",
        ] {
            assert_eq!(Quantity::from_label(bad), None, "{bad}");
        }
    }

    #[test]
    fn shapes_at_known_points() {
        let vg = [Quantity::Value, Quantity::GradMag];
        let gv = [Quantity::GradMag, Quantity::Value];
        let lev = Shape::Levoy { v0: 100.0, r: 2.0 };
        // Half way out at gm 5 (width 10), on either axis order.
        assert_eq!(lev.at([105.0, 5.0], vg), 0.5);
        assert_eq!(lev.at([5.0, 105.0], gv), 0.5);
        assert_eq!(lev.at([100.0, 0.0], vg), 1.0);
        assert_eq!(lev.at([100.5, 0.0], vg), 0.0);
        let arch = Shape::Arch {
            va: 0.0,
            vb: 100.0,
            top: 40.0,
            width: 10.0,
        };
        assert_eq!(arch.at([50.0, 40.0], vg), 1.0);
        assert_eq!(arch.at([25.0, 30.0 + 5.0], vg), 0.5); // g(25) = 30
        assert_eq!(arch.at([0.0, 0.0], vg), 0.0);
        let tri = Shape::Triangle {
            v0: 10.0,
            w: 4.0,
            g1: 8.0,
            g0: 1.0,
        };
        assert_eq!(tri.at([11.0, 4.0], vg), 0.5); // half-width 2 at gm 4
        assert_eq!(tri.at([10.0, 0.5], vg), 0.0); // below g0
        let g = Shape::Gaussian {
            centre: [1.0, 2.0],
            sigma: [1.0, 2.0],
        };
        assert!((g.at([2.0, 4.0], vg) - math::exp(-1.0)).abs() < 1e-15);
    }

    /// Levoy's iso-contours as primitives give the opacity `txf::Levoy` computes at the
    /// entries' centres (both are 1 − Π(1 − aₖ·shape)).
    #[test]
    fn levoy_primitives_match_levoy_opacity() {
        let items = [[0.6f32, 0.035, 0.1], [0.8, 0.035, 0.2], [0.95, 0.035, 0.9]];
        let lev = crate::txf::Levoy::new(items.to_vec()).unwrap();
        let axes = [
            LutAxis::new(Quantity::Value, 0.0, 1.0, 64),
            LutAxis::new(Quantity::GradMag, 0.0, 4.0, 16),
        ];
        let prims: Vec<Primitive> = items
            .iter()
            .map(|&[v, r, a]| Primitive {
                shape: Shape::Levoy {
                    v0: v.into(),
                    r: r.into(),
                },
                rgb: [1.0; 3],
                alpha: a.into(),
            })
            .collect();
        let lut = Lut::from_primitives(axes, &prims).unwrap();
        for j in 0..16 {
            for i in 0..64 {
                let (v, g) = (axes[0].centre(i), axes[1].centre(j));
                let want = lev.opacity(v as f32, g as f32);
                let got = lut.entries()[i + 64 * j][3];
                assert!((got - want).abs() < 1e-5, "({v}, {g}): {got} vs {want}");
            }
        }
    }

    #[test]
    fn bad_primitives_are_refused() {
        let axes = [
            LutAxis::new(Quantity::K1, -1.0, 1.0, 8),
            LutAxis::new(Quantity::K2, -1.0, 1.0, 8),
        ];
        let p = |shape, alpha| Primitive {
            shape,
            rgb: [1.0; 3],
            alpha,
        };
        let lev = Shape::Levoy { v0: 0.0, r: 1.0 };
        let e = Lut::from_primitives(axes, &[p(lev, 1.0)]).unwrap_err();
        assert!(alloc::format!("{e}").contains("needs axes v and gm"), "{e}");
        let b = Shape::Box {
            lo: [1.0, 0.0],
            hi: [0.0, 1.0],
        };
        assert!(Lut::from_primitives(axes, &[p(b, 1.0)]).is_err());
        let b = Shape::Box {
            lo: [0.0, 0.0],
            hi: [1.0, 1.0],
        };
        assert!(Lut::from_primitives(axes, &[p(b, 1.5)]).is_err());
        let mut same = axes;
        same[1].quantity = Quantity::K1;
        assert!(Lut::from_primitives(same, &[p(b, 1.0)]).is_err());
    }
}
