//! How the samples of one ray are reduced to a pixel: the maximum, the sum, the mean of
//! the counted samples, or front-to-back `over` compositing of premultiplied colours.

use core::fmt;
use core::str::FromStr;

use crate::error::{Error, ErrorKind};

/// A blend: how the values a ray probes become its pixel.
///
/// ```
/// use rnd_core::blend::Blend;
///
/// assert_eq!("over".parse::<Blend>().unwrap(), Blend::Over);
/// assert_eq!(Blend::Max.to_string(), "max");
/// assert!("median".parse::<Blend>().is_err());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Blend {
    /// Per-component maximum.
    Max,
    /// Per-component sum.
    Sum,
    /// Sum divided by the number of counted samples.
    Mean,
    /// Front-to-back compositing (colour probes only).
    Over,
}

impl Blend {
    /// Every blend.
    pub const ALL: [Blend; 4] = [Blend::Max, Blend::Sum, Blend::Mean, Blend::Over];
    /// Name.
    pub fn as_str(self) -> &'static str {
        match self {
            Blend::Max => "max",
            Blend::Sum => "sum",
            Blend::Mean => "mean",
            Blend::Over => "over",
        }
    }
}

impl fmt::Display for Blend {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl FromStr for Blend {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self, Error> {
        Blend::ALL
            .into_iter()
            .find(|b| b.as_str().eq_ignore_ascii_case(s))
            .ok_or_else(|| {
                Error::new(
                    ErrorKind::Name,
                    alloc::format!("unknown blend \"{s}\" (known: max sum mean over)"),
                )
            })
    }
}

/// The running state of one ray's blend, for up to 4 channels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Accum {
    /// Which blend.
    pub blend: Blend,
    /// Number of channels in use.
    pub len: usize,
    /// Accumulated values (for `over`: premultiplied rgb and alpha).
    pub acc: [f32; 4],
    /// Number of samples blended.
    pub count: u32,
}

impl Accum {
    /// Empty accumulator.
    #[inline]
    pub fn new(blend: Blend, len: usize) -> Self {
        Accum {
            blend,
            len,
            acc: [0.0; 4],
            count: 0,
        }
    }

    /// Blends one counted sample `x` (for `over`: un-premultiplied rgb and corrected α).
    #[inline(always)]
    pub fn add(&mut self, x: &[f32; 4]) {
        let first = self.count == 0;
        self.count += 1;
        match self.blend {
            Blend::Max => {
                for c in 0..self.len {
                    self.acc[c] = if first { x[c] } else { self.acc[c].max(x[c]) };
                }
            }
            Blend::Sum | Blend::Mean => {
                for c in 0..self.len {
                    self.acc[c] += x[c];
                }
            }
            Blend::Over => {
                let t = (1.0 - self.acc[3]) * x[3];
                self.acc[0] += t * x[0];
                self.acc[1] += t * x[1];
                self.acc[2] += t * x[2];
                self.acc[3] += t;
            }
        }
    }

    /// [`Accum::add`] of one-channel samples `xs` in order (the same arithmetic, so the
    /// same result), for `max`, `sum` and `mean` with a probe of length 1.
    #[inline(always)]
    pub fn add_scalars(&mut self, xs: &[f32]) {
        debug_assert!(self.len == 1 && self.blend != Blend::Over);
        let Some((&x0, rest)) = xs.split_first() else {
            return;
        };
        match self.blend {
            Blend::Max => {
                let mut m = if self.count == 0 {
                    x0
                } else {
                    self.acc[0].max(x0)
                };
                for &x in rest {
                    m = m.max(x);
                }
                self.acc[0] = m;
            }
            _ => {
                let mut s = self.acc[0];
                for &x in xs {
                    s += x;
                }
                self.acc[0] = s;
            }
        }
        self.count += xs.len() as u32;
    }

    /// Blends `n` samples of opacity 0 under `over`: only the count changes (what
    /// [`Accum::add`] of `[0.0; 4]` does `n` times).
    #[inline(always)]
    pub fn add_transparent(&mut self, n: u32) {
        debug_assert_eq!(self.blend, Blend::Over);
        self.count += n;
    }

    /// Whether every one-channel sample of value at most `bound` leaves this `max`
    /// blend's bits as they are: after a first sample, below the maximum or equal to a
    /// non-zero one (f32 `max` of +0 and −0 may give either).
    #[inline(always)]
    pub fn below_max(&self, bound: f32) -> bool {
        let m = self.acc[0];
        self.count > 0 && (bound < m || (bound <= m && m != 0.0))
    }

    /// Opacity so far (`over` only).
    #[inline(always)]
    pub fn alpha(&self) -> f32 {
        self.acc[3]
    }

    /// Final values into `out[..len]`; `outside` when nothing was blended.
    #[inline]
    pub fn finish(&self, outside: f32, out: &mut [f32]) {
        if self.count == 0 {
            out[..self.len].fill(outside);
            return;
        }
        match self.blend {
            Blend::Max | Blend::Sum => out[..self.len].copy_from_slice(&self.acc[..self.len]),
            Blend::Mean => {
                let n = self.count as f32;
                for c in 0..self.len {
                    out[c] = self.acc[c] / n;
                }
            }
            Blend::Over => {
                let a = self.acc[3];
                for c in 0..3 {
                    out[c] = if a > 0.0 { self.acc[c] / a } else { 0.0 };
                }
                out[3] = a;
            }
        }
    }
}
