//! What each ray sample measures: positions, value, gradient, colour from a LUT, or
//! lit colour.

use core::fmt;
use core::str::FromStr;

use crate::error::{Error, ErrorKind};

/// A probe: the quantity computed at each ray sample. Ordered: a higher probe depends
/// only on lower ones.
///
/// ```
/// use rnd_core::probe::Probe;
///
/// let p: Probe = "gm".parse().unwrap(); // gradient magnitude
/// assert_eq!(p, Probe::GradMag);
/// assert_eq!(p.length(), 1);
/// assert_eq!(Probe::RgbaLit.length(), 4);
/// assert!(Probe::Rgba.is_colour());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Probe {
    /// View-space position (3).
    PosView,
    /// World-space position (3).
    PosWorld,
    /// Index-space position (3).
    PosIndex,
    /// 1 when the convolution is inside the volume, else 0 (1).
    Inside,
    /// Reconstructed value (1).
    Value,
    /// World-space gradient (3).
    GradVec,
    /// Gradient magnitude (1).
    GradMag,
    /// World-space Hessian, row-major (9), from the kernel's second derivative.
    Hess,
    /// First principal curvature κ1 of the isosurface (1); see
    /// [`SecondOrder::curvatures`](crate::convo::SecondOrder::curvatures).
    K1,
    /// Second principal curvature κ2 ≤ κ1 (1).
    K2,
    /// Mean curvature (κ1 + κ2) / 2 (1).
    MeanCurv,
    /// Gaussian curvature κ1 κ2 (1).
    GaussCurv,
    /// LUT colour and corrected opacity (4).
    Rgba,
    /// Rgba lit by Blinn-Phong and depth-cued (4).
    RgbaLit,
}

impl Probe {
    /// Every probe in order.
    pub const ALL: [Probe; 14] = [
        Probe::PosView,
        Probe::PosWorld,
        Probe::PosIndex,
        Probe::Inside,
        Probe::Value,
        Probe::GradVec,
        Probe::GradMag,
        Probe::Hess,
        Probe::K1,
        Probe::K2,
        Probe::MeanCurv,
        Probe::GaussCurv,
        Probe::Rgba,
        Probe::RgbaLit,
    ];
    /// Short name.
    pub fn as_str(self) -> &'static str {
        match self {
            Probe::PosView => "pv",
            Probe::PosWorld => "pw",
            Probe::PosIndex => "pi",
            Probe::Inside => "in",
            Probe::Value => "v",
            Probe::GradVec => "gv",
            Probe::GradMag => "gm",
            Probe::Hess => "hess",
            Probe::K1 => "k1",
            Probe::K2 => "k2",
            Probe::MeanCurv => "meancurv",
            Probe::GaussCurv => "gausscurv",
            Probe::Rgba => "rgba",
            Probe::RgbaLit => "rgbalit",
        }
    }
    /// Every accepted spelling.
    pub fn aliases(self) -> &'static [&'static str] {
        match self {
            Probe::PosView => &["pv", "posview"],
            Probe::PosWorld => &["pw", "posworld"],
            Probe::PosIndex => &["pi", "posindex"],
            Probe::Inside => &["in", "inside"],
            Probe::Value => &["v", "val", "value"],
            Probe::GradVec => &["gv", "gradvec"],
            Probe::GradMag => &["gm", "gradmag"],
            Probe::Hess => &["hess", "hessian"],
            Probe::K1 => &["k1", "kappa1"],
            Probe::K2 => &["k2", "kappa2"],
            Probe::MeanCurv => &["meancurv", "mc"],
            Probe::GaussCurv => &["gausscurv", "gc"],
            Probe::Rgba => &["c", "rgba"],
            Probe::RgbaLit => &["cl", "rgbalit"],
        }
    }
    /// Number of output channels.
    pub fn length(self) -> usize {
        match self {
            Probe::PosView | Probe::PosWorld | Probe::PosIndex | Probe::GradVec => 3,
            Probe::Hess => 9,
            Probe::Inside
            | Probe::Value
            | Probe::GradMag
            | Probe::K1
            | Probe::K2
            | Probe::MeanCurv
            | Probe::GaussCurv => 1,
            Probe::Rgba | Probe::RgbaLit => 4,
        }
    }
    /// True for the probes defined at every sample (positions and inside); the others
    /// count only where the convolution is inside (the kernel's support lies in the
    /// volume).
    pub fn everywhere(self) -> bool {
        self <= Probe::Inside
    }
    /// Whether a convolution is needed.
    pub fn needs_convo(self) -> bool {
        self >= Probe::Inside
    }
    /// Whether it needs second derivatives (the Hessian and the curvatures, computed in
    /// f64 at each sample: see [`Convo::second_order_world`](crate::convo::Convo::second_order_world)).
    pub fn second_order(self) -> bool {
        (Probe::Hess..=Probe::GaussCurv).contains(&self)
    }
    /// Whether it is a colour probe (needs a LUT).
    pub fn is_colour(self) -> bool {
        self >= Probe::Rgba
    }
}

impl fmt::Display for Probe {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl FromStr for Probe {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self, Error> {
        let l = s.to_ascii_lowercase();
        Probe::ALL
            .into_iter()
            .find(|p| p.aliases().contains(&l.as_str()))
            .ok_or_else(|| {
                Error::new(
                    ErrorKind::Name,
                    alloc::format!(
                        "unknown probe \"{s}\" (known: pv pw pi in v gv gm hess k1 k2 meancurv \
                         gausscurv rgba rgbalit)"
                    ),
                )
            })
    }
}
