//! The crate's one error type.

use alloc::string::String;
use core::fmt;

/// What went wrong, broadly; the message says exactly what.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum ErrorKind {
    /// A camera parameter is impossible (FOV, sizes, fr = at, ...).
    Camera,
    /// A matrix could not be inverted or is not affine.
    Matrix,
    /// An unknown name (kernel, probe, blend, space) or a bad kernel use.
    Name,
    /// Volume data or geometry is unusable.
    Volume,
    /// A transfer function, LUT or Levoy description is invalid.
    Txf,
    /// A light description is invalid.
    Light,
    /// The combination of render parameters is invalid.
    Render,
    /// A synthetic-data request is invalid.
    Sdg,
    /// Memory for a result could not be had.
    Memory,
    /// The caller stopped the work (a cancelled render).
    Cancelled,
}

/// The parameter an error is about, by its library name. A front end that spells
/// parameters its own way (the `rendr` CLI: `-s`, `-sz`, ...) maps it to its spelling
/// and puts that before the message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Param {
    /// [`crate::camera::CameraSpec::from`], the look-from point.
    CameraFrom,
    /// [`crate::camera::CameraSpec::at`], the look-at point.
    CameraAt,
    /// [`crate::camera::CameraSpec::up`], the up vector.
    CameraUp,
    /// [`crate::camera::CameraSpec::near`], the near clipping plane.
    CameraNear,
    /// [`crate::camera::CameraSpec::far`], the far clipping plane.
    CameraFar,
    /// [`crate::camera::CameraSpec::fov`], the field of view.
    CameraFov,
    /// [`crate::camera::CameraSpec::size`], the image size.
    ImageSize,
    /// [`crate::render::RenderParams::plane_sep`], the distance between sampling planes.
    PlaneSep,
    /// [`crate::render::RenderParams::unit_step`], the unit of opacity correction.
    UnitStep,
    /// [`crate::render::RenderParams::alpha_near1`], the early-termination opacity.
    AlphaNear1,
    /// [`crate::render::RenderParams::phong`], the Blinn-Phong parameters.
    Phong,
    /// [`crate::render::RenderParams::dcn`] / [`crate::render::RenderParams::dcf`], the
    /// depth-cue colours.
    DepthCue,
    /// [`crate::render::RenderParams::probe`], what is measured.
    Probe,
    /// [`crate::render::RenderParams::blend`], how samples are combined.
    Blend,
    /// The colour-and-opacity lookup table ([`crate::txf::Lut`]).
    Lut,
    /// The domain of a lookup table.
    LutDomain,
    /// The lights ([`crate::light::Light`]).
    Lights,
    /// [`crate::render::RenderParams::reference`], the choice of arithmetic.
    Reference,
    /// The volume.
    Volume,
    /// Sizes of a synthetic volume ([`crate::sdg`]).
    SdgSizes,
    /// Edge lengths of a synthetic volume.
    SdgLengths,
    /// Which synthetic function.
    SdgFunction,
    /// [`crate::render::RenderParams::curv_min_grad`], the curvatures' gradient
    /// threshold.
    CurvMinGrad,
}

impl Param {
    /// The library name (a field name, as in the docs).
    pub fn as_str(self) -> &'static str {
        match self {
            Param::CameraFrom => "camera look-from",
            Param::CameraAt => "camera look-at",
            Param::CameraUp => "camera up",
            Param::CameraNear => "camera near plane",
            Param::CameraFar => "camera far plane",
            Param::CameraFov => "camera field of view",
            Param::ImageSize => "image size",
            Param::PlaneSep => "plane separation",
            Param::UnitStep => "unit step",
            Param::AlphaNear1 => "alpha_near1",
            Param::Phong => "phong",
            Param::DepthCue => "depth cue",
            Param::Probe => "probe",
            Param::Blend => "blend",
            Param::Lut => "lut",
            Param::LutDomain => "lut domain",
            Param::Lights => "lights",
            Param::Reference => "reference arithmetic",
            Param::Volume => "volume",
            Param::SdgSizes => "sizes",
            Param::SdgLengths => "edge lengths",
            Param::SdgFunction => "function",
            Param::CurvMinGrad => "curvature gradient threshold",
        }
    }
}

/// An error from `rnd-core`: a kind, the parameter it is about (when one is), and a
/// one-line message in the library's terms.
///
/// ```
/// use rnd_core::camera::{Camera, CameraSpec};
/// use rnd_core::{ErrorKind, Param};
///
/// let spec = CameraSpec::looking_at([0.0, 0.0, 10.0], [0.0; 3]).fov(200.0);
/// let e = Camera::new(spec).unwrap_err();
/// assert_eq!(e.kind, ErrorKind::Camera);
/// assert_eq!(e.param, Some(Param::CameraFov));
/// assert!(e.to_string().contains("field of view"));
/// ```
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct Error {
    /// Broad category.
    pub kind: ErrorKind,
    /// The parameter at fault, if the error is about one.
    pub param: Option<Param>,
    /// One-line description, naming the offending quantity.
    pub msg: String,
}

impl Error {
    /// Builds an error from a kind and a message.
    pub fn new(kind: ErrorKind, msg: impl Into<String>) -> Self {
        Error {
            kind,
            param: None,
            msg: msg.into(),
        }
    }
    /// An error about parameter `param`.
    pub fn about(kind: ErrorKind, param: Param, msg: impl Into<String>) -> Self {
        Error {
            kind,
            param: Some(param),
            msg: msg.into(),
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.msg)
    }
}

impl core::error::Error for Error {}

/// A number for a message: as written (`0.1`, `-2.5`) unless that takes more than 16
/// characters (`1e-300` would be 300 digits), then in exponent form.
#[derive(Debug, Clone, Copy)]
pub struct Num(pub f64);

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let a = self.0.abs();
        if self.0 == 0.0 || !self.0.is_finite() || (1e-5..1e12).contains(&a) {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}

/// Result alias for the crate.
pub type Result<T> = core::result::Result<T, Error>;
