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
}

/// An error from `rnd-core`: a kind and a one-line human message.
#[derive(Debug, Clone, PartialEq)]
pub struct Error {
    /// Broad category.
    pub kind: ErrorKind,
    /// One-line description, naming the offending quantity.
    pub msg: String,
}

impl Error {
    /// Builds an error from a kind and a message.
    pub fn new(kind: ErrorKind, msg: impl Into<String>) -> Self {
        Error {
            kind,
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

/// Shorthand for `Err(Error::new(kind, format!(...)))`.
#[macro_export]
macro_rules! bail {
    ($kind:ident, $($arg:tt)*) => {
        return Err($crate::error::Error::new(
            $crate::error::ErrorKind::$kind,
            alloc::format!($($arg)*),
        ))
    };
}
