//! How the samples of one ray are reduced to a pixel: a statistic of the counted
//! samples (maximum, minimum, sum, mean, root of the sum of squares, variance, standard
//! deviation, median), or front-to-back `over` compositing of premultiplied colours.
//!
//! Every statistic is taken per channel over the ray's counted samples x₁ … x_N (the
//! samples where the probe is defined: inside the volume for the convolved probes):
//!
//! | blend | pixel |
//! |---|---|
//! | `max`, `min` | the largest, smallest x (NaN samples ignored) |
//! | `sum` | Σ x (summed in f32, in sample order) |
//! | `mean` | Σ x / N |
//! | `l2` | √(Σ x²) (summed in f64) |
//! | `variance` | Σ x² / N − (Σ x / N)², the population variance (f64, at least 0) |
//! | `sd` | √variance |
//! | `median` | the middle of the sorted x; for even N the mean of the two middle ones (NaN sorts above +∞) |
//!
//! These are Teem's `nrrdMeasure` definitions (`teem-mrender -m min|l2|variance|stdv|median`).
//! A ray with no counted sample gets the outside value.

use core::fmt;
use core::str::FromStr;

use alloc::vec::Vec;

use crate::error::{Error, ErrorKind};

/// A blend: how the values a ray probes become its pixel (see the
/// [module docs](self) for each one's definition).
///
/// ```
/// use rnd_core::blend::Blend;
///
/// assert_eq!("over".parse::<Blend>().unwrap(), Blend::Over);
/// assert_eq!(Blend::Max.to_string(), "max");
/// assert_eq!("median".parse::<Blend>().unwrap(), Blend::Median);
/// assert!("mode".parse::<Blend>().is_err());
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
    /// Per-component minimum.
    Min,
    /// Root of the sum of squares.
    L2,
    /// Population variance (divided by the number of samples).
    Variance,
    /// Standard deviation: the root of [`Blend::Variance`].
    Sd,
    /// Median (the mean of the two middle samples for an even count).
    Median,
}

impl Blend {
    /// Every blend.
    pub const ALL: [Blend; 9] = [
        Blend::Max,
        Blend::Sum,
        Blend::Mean,
        Blend::Over,
        Blend::Min,
        Blend::L2,
        Blend::Variance,
        Blend::Sd,
        Blend::Median,
    ];
    /// Name.
    pub fn as_str(self) -> &'static str {
        match self {
            Blend::Max => "max",
            Blend::Sum => "sum",
            Blend::Mean => "mean",
            Blend::Over => "over",
            Blend::Min => "min",
            Blend::L2 => "l2",
            Blend::Variance => "variance",
            Blend::Sd => "sd",
            Blend::Median => "median",
        }
    }
    /// Whether the pixel needs every sample kept until the ray ends (the median).
    pub fn keeps_samples(self) -> bool {
        self == Blend::Median
    }
    /// Whether sums of the samples and their squares are kept in f64 (l2, variance, sd).
    fn squares(self) -> bool {
        matches!(self, Blend::L2 | Blend::Variance | Blend::Sd)
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
        let l = s.to_ascii_lowercase();
        // Teem's name for the standard deviation is also accepted.
        let l = if l == "stdv" { "sd" } else { l.as_str() };
        Blend::ALL
            .into_iter()
            .find(|b| b.as_str() == l)
            .ok_or_else(|| {
                Error::new(
                    ErrorKind::Name,
                    alloc::format!(
                        "unknown blend \"{s}\" (known: max min sum mean l2 variance sd median over)"
                    ),
                )
            })
    }
}

/// Most channels a probe has (the Hessian's 9).
pub const MAX_CHANNELS: usize = 9;

/// `max` as every ray loop takes it: `b` when it is greater than `a` or `a` is NaN,
/// otherwise `a`. So of equal values (+0 and −0 among them) the earlier stays, NaNs are
/// passed over, and a NaN results only when every value is one (the last). It is what
/// `f32::max` compiles to on x86-64, written out so that its result does not depend on
/// the compiler's choice for equal zeros; and it is associative, so a tree of it
/// ([`max_first_of`]) gives the same bits as a chain.
#[inline(always)]
pub(crate) fn max_first(a: f32, b: f32) -> f32 {
    if b > a || a.is_nan() {
        b
    } else {
        a
    }
}

/// [`max_first`] of `xs` in order (`xs` not empty), by a tree over sixteen at a time:
/// the same bits as the chain `max_first(max_first(xs[0], xs[1]), xs[2])...`, with a
/// quarter of its dependent steps. A group shorter than sixteen is filled up with
/// copies of its last value, which cannot change the result (equal bits, later).
#[inline(always)]
pub(crate) fn max_first_of(xs: &[f32]) -> f32 {
    const N: usize = 16;
    let mut m = f32::NAN;
    for (i, group) in xs.chunks(N).enumerate() {
        let last = group[group.len() - 1];
        let mut t = [last; N];
        t[..group.len()].copy_from_slice(group);
        let mut n = N;
        while n > 1 {
            n /= 2;
            for j in 0..n {
                t[j] = max_first(t[2 * j], t[2 * j + 1]);
            }
        }
        m = if i == 0 { t[0] } else { max_first(m, t[0]) };
    }
    m
}

/// The running state of one ray's blend, for up to [`MAX_CHANNELS`] channels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Accum {
    /// Which blend.
    pub blend: Blend,
    /// Number of channels in use.
    pub len: usize,
    /// Accumulated values: the running maximum or minimum, the f32 sum (`sum`, `mean`),
    /// or for `over` premultiplied rgb and alpha; unused by the f64 statistics.
    pub acc: [f32; MAX_CHANNELS],
    /// For `l2`, `variance` and `sd`: the f64 sums of the samples and of their squares.
    pub sums: [[f64; 2]; MAX_CHANNELS],
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
            acc: [0.0; MAX_CHANNELS],
            sums: [[0.0; 2]; MAX_CHANNELS],
            count: 0,
        }
    }

    /// Blends one counted sample `x` (for `over`: un-premultiplied rgb and corrected α).
    /// The median's samples are kept by the caller ([`Blend::keeps_samples`]); here they
    /// are only counted.
    #[inline(always)]
    pub fn add(&mut self, x: &[f32; MAX_CHANNELS]) {
        let first = self.count == 0;
        self.count += 1;
        let len = self.len.min(MAX_CHANNELS);
        // The common blends here (inlined into the ray loops), the others out of line so
        // that they do not crowd the loops' code.
        match self.blend {
            Blend::Max => self.pick_channels(x, first, max_first),
            Blend::Sum | Blend::Mean => {
                for c in 0..len {
                    self.acc[c] += x[c];
                }
            }
            Blend::Median => {}
            Blend::Over => {
                let t = (1.0 - self.acc[3]) * x[3];
                self.acc[0] += t * x[0];
                self.acc[1] += t * x[1];
                self.acc[2] += t * x[2];
                self.acc[3] += t;
            }
            Blend::Min | Blend::L2 | Blend::Variance | Blend::Sd => self.add_other(x, first),
        }
    }

    /// [`Accum::add`] under `min`, `l2`, `variance` and `sd`.
    #[inline(never)]
    fn add_other(&mut self, x: &[f32; MAX_CHANNELS], first: bool) {
        if self.blend == Blend::Min {
            self.pick_channels(x, first, f32::min);
        } else if self.blend.squares() {
            for c in 0..self.len.min(MAX_CHANNELS) {
                let v = f64::from(x[c]);
                self.sums[c][0] += v;
                self.sums[c][1] += v * v;
            }
        }
    }

    /// [`Accum::add`] of one-channel samples `xs` in order (the same arithmetic, so the
    /// same result), for every blend but `over` with a probe of length 1.
    #[inline(always)]
    pub fn add_scalars(&mut self, xs: &[f32]) {
        debug_assert!(self.len == 1 && self.blend != Blend::Over);
        if xs.is_empty() {
            return;
        }
        match self.blend {
            // `max` and the f32 sums inline into the loop; `min` and the f64 sums out of
            // line, as in `add`.
            // The ray's first batch starts the maximum.
            Blend::Max if self.count == 0 => self.acc[0] = max_first_of(xs),
            Blend::Max => {
                // Most later batches lie wholly below the maximum (NaNs are not below it)
                // and leave it as it is; the others take the tree.
                let m0 = self.acc[0];
                if !xs.iter().fold(true, |all, &x| all & (x < m0)) {
                    self.acc[0] = max_first(m0, max_first_of(xs));
                }
            }
            Blend::Sum | Blend::Mean => {
                let mut s = self.acc[0];
                for &x in xs {
                    s += x;
                }
                self.acc[0] = s;
            }
            Blend::Median | Blend::Over => {}
            Blend::Min | Blend::L2 | Blend::Variance | Blend::Sd => self.add_scalars_other(xs),
        }
        self.count += xs.len() as u32;
    }

    /// [`Accum::add_scalars`] of at least one sample under `min`, `l2`, `variance` and
    /// `sd` (the count is the caller's).
    #[inline(never)]
    fn add_scalars_other(&mut self, xs: &[f32]) {
        let Some((&x0, rest)) = xs.split_first() else {
            return;
        };
        if self.blend == Blend::Min {
            self.acc[0] = self.picked(x0, rest, f32::min);
        } else if self.blend.squares() {
            let [mut s1, mut s2] = self.sums[0];
            for &x in xs {
                let v = f64::from(x);
                s1 += v;
                s2 += v * v;
            }
            self.sums[0] = [s1, s2];
        }
    }

    /// `max` or `min` (`pick`) of one sample `x` into every channel in use; the ray's
    /// first sample starts them.
    #[inline(always)]
    fn pick_channels(
        &mut self,
        x: &[f32; MAX_CHANNELS],
        first: bool,
        pick: impl Fn(f32, f32) -> f32,
    ) {
        for c in 0..self.len.min(MAX_CHANNELS) {
            self.acc[c] = if first { x[c] } else { pick(self.acc[c], x[c]) };
        }
    }

    /// The running `max` or `min` (`pick`) of channel 0 after one-channel samples `x0`,
    /// `rest...` in order; the ray's first sample starts it.
    #[inline(always)]
    fn picked(&self, x0: f32, rest: &[f32], pick: impl Fn(f32, f32) -> f32) -> f32 {
        let mut m = if self.count == 0 {
            x0
        } else {
            pick(self.acc[0], x0)
        };
        for &x in rest {
            m = pick(m, x);
        }
        m
    }

    /// Blends `n` samples of opacity 0 under `over`: only the count changes (what
    /// [`Accum::add`] of zeros does `n` times).
    #[inline(always)]
    pub fn add_transparent(&mut self, n: u32) {
        debug_assert_eq!(self.blend, Blend::Over);
        self.count += n;
    }

    /// Whether every one-channel sample of value at most `bound` leaves this `max`
    /// blend's bits as they are: after a first sample, below the maximum or equal to a
    /// non-zero one. (Equal zeros would leave them too, as the loops' `max` keeps the
    /// earlier of equal values; letting them pass was measured no quicker, run 51.)
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

    /// Final values into the front of `out` (`len` of them, `over` its four; as many as
    /// `out` holds); `outside` when nothing was blended. `kept` holds
    /// the median's samples (reordered here; without them the median is NaN); the other
    /// blends ignore it.
    #[inline(always)]
    pub fn finish(&self, outside: f32, kept: Option<&mut Kept>, out: &mut [f32]) {
        let len = self.len.min(MAX_CHANNELS).min(out.len());
        if self.count == 0 {
            out[..len].fill(outside);
            return;
        }
        // The common blends here (inlined into every ray's end), the statistics apart.
        match self.blend {
            Blend::Max | Blend::Min | Blend::Sum => out[..len].copy_from_slice(&self.acc[..len]),
            Blend::Mean => {
                let n = self.count as f32;
                for c in 0..len {
                    out[c] = self.acc[c] / n;
                }
            }
            Blend::Over => {
                let a = self.acc[3];
                let rgb = |c: usize| if a > 0.0 { self.acc[c] / a } else { 0.0 };
                let px = [rgb(0), rgb(1), rgb(2), a];
                let n = out.len().min(4);
                out[..n].copy_from_slice(&px[..n]);
            }
            _ => self.finish_statistic(kept, &mut out[..len]),
        }
    }

    /// [`Accum::finish`] of `l2`, `variance`, `sd` and `median` (at least one sample).
    #[inline(never)]
    fn finish_statistic(&self, mut kept: Option<&mut Kept>, out: &mut [f32]) {
        let (n, len) = (self.count as f64, out.len());
        match self.blend {
            Blend::L2 => {
                for c in 0..len {
                    out[c] = crate::math::sqrt(self.sums[c][1]) as f32;
                }
            }
            Blend::Variance | Blend::Sd => {
                for c in 0..len {
                    let [s1, s2] = self.sums[c];
                    let m = s1 / n;
                    let var = (s2 / n - m * m).max(0.0);
                    out[c] = if self.blend == Blend::Sd {
                        crate::math::sqrt(var) as f32
                    } else {
                        var as f32
                    };
                }
            }
            Blend::Median => {
                for c in 0..len {
                    out[c] = kept
                        .as_deref_mut()
                        .map_or(f32::NAN, |k| median(&mut k.chans[c]));
                }
            }
            _ => {}
        }
    }
}

/// The samples a `median` ray keeps, one list per channel (reused from ray to ray).
#[derive(Debug, Clone, Default)]
pub struct Kept {
    chans: [Vec<f32>; MAX_CHANNELS],
}

impl Kept {
    /// Empty lists.
    pub fn new() -> Self {
        Self::default()
    }
    /// Forgets every sample (keeps the memory).
    #[inline]
    pub fn clear(&mut self) {
        self.chans.iter_mut().for_each(Vec::clear);
    }
    /// Keeps the first `len` channels of sample `x` (out of line: only `median` keeps
    /// samples, and the ray loops stay small).
    #[inline(never)]
    pub fn push(&mut self, x: &[f32; MAX_CHANNELS], len: usize) {
        for (ch, &v) in self.chans.iter_mut().zip(x).take(len) {
            ch.push(v);
        }
    }
    /// Keeps one-channel samples `xs`.
    #[inline(never)]
    pub fn push_scalars(&mut self, xs: &[f32]) {
        self.chans[0].extend_from_slice(xs);
    }
    /// Keeps samples `xs` of channel `c` (e.g. those another process kept).
    pub fn extend(&mut self, c: usize, xs: &[f32]) {
        if let Some(ch) = self.chans.get_mut(c) {
            ch.extend_from_slice(xs);
        }
    }
    /// The samples kept of channel `c`.
    pub fn channel(&self, c: usize) -> &[f32] {
        self.chans.get(c).map_or(&[], |v| v.as_slice())
    }
}

/// The median of `v` (reordered): the middle value in the total order of f32 (NaN above
/// +∞), for an even count the mean of the two middle ones; NaN when `v` is empty.
fn median(v: &mut [f32]) -> f32 {
    let n = v.len();
    if n == 0 {
        return f32::NAN;
    }
    let (below, &mut hi, _) = v.select_nth_unstable_by(n / 2, f32::total_cmp);
    if n % 2 == 1 {
        return hi;
    }
    // The largest of the lower half is the other middle value.
    let lo = below.iter().copied().max_by(f32::total_cmp).unwrap_or(hi);
    ((f64::from(lo) + f64::from(hi)) / 2.0) as f32
}

#[cfg(test)]
mod tests {
    use super::{max_first, max_first_of, Accum, Blend, MAX_CHANNELS};
    use proptest::prelude::*;

    /// Values where the order of a `max` chain shows: zeros of both signs, NaNs with
    /// different payloads and signs, infinities, equal numbers.
    const POOL: [u32; 10] = [
        0x0000_0000, // +0
        0x8000_0000, // −0
        0x7FC0_0000, // quiet NaN
        0x7FC0_0001, // NaN, another payload
        0xFFC0_0002, // NaN, negative
        0x3F80_0000, // 1
        0xBF80_0000, // −1
        0x7F80_0000, // +inf
        0xFF80_0000, // −inf
        0x0000_0001, // the least subnormal
    ];

    proptest! {
        /// The tree gives the chain's bits for any sequence of these values (and any
        /// length, groups of sixteen and their remainders).
        #[test]
        fn max_tree_is_the_chain(ix in proptest::collection::vec(0usize..10, 1..40)) {
            let xs: alloc::vec::Vec<f32> = ix.iter().map(|&i| f32::from_bits(POOL[i])).collect();
            let chain = xs[1..].iter().fold(xs[0], |m, &x| max_first(m, x));
            prop_assert_eq!(max_first_of(&xs).to_bits(), chain.to_bits(), "{:?}", xs);
            // A running maximum taken in two parts, as the loops take batches.
            let cut = xs.len() / 2;
            if cut > 0 {
                let two = max_first(max_first_of(&xs[..cut]), max_first_of(&xs[cut..]));
                prop_assert_eq!(two.to_bits(), chain.to_bits());
            }
        }
    }

    proptest! {
        /// `max` blended in batches of any lengths (`add_scalars`: a batch wholly below
        /// the maximum leaves it, the others take the tree) gives the one-sample loop's
        /// bits (`add`) and count.
        #[test]
        fn max_batches_are_the_one_sample_loop(
            ix in proptest::collection::vec(0usize..10, 1..60),
            cuts in proptest::collection::vec(1usize..20, 1..8),
        ) {
            let xs: alloc::vec::Vec<f32> = ix.iter().map(|&i| f32::from_bits(POOL[i])).collect();
            let mut one = Accum::new(Blend::Max, 1);
            for &x in &xs {
                let mut a = [0.0f32; MAX_CHANNELS];
                a[0] = x;
                one.add(&a);
            }
            let mut batched = Accum::new(Blend::Max, 1);
            let (mut at, mut c) = (0, cuts.iter().cycle());
            while at < xs.len() {
                let n = c.next().map_or(1, |&n| n.min(xs.len() - at));
                batched.add_scalars(&xs[at..at + n]);
                at += n;
            }
            prop_assert_eq!(batched.acc[0].to_bits(), one.acc[0].to_bits(), "{:?}", xs);
            prop_assert_eq!(batched.count, one.count);
        }
    }

    #[test]
    fn max_first_keeps_the_earlier_of_equals_and_passes_nans_over() {
        let (z, nz, nan) = (0.0f32, -0.0f32, f32::NAN);
        assert_eq!(max_first(z, nz).to_bits(), z.to_bits());
        assert_eq!(max_first(nz, z).to_bits(), nz.to_bits());
        assert_eq!(max_first(nan, -1.0), -1.0);
        assert_eq!(max_first(-1.0, nan), -1.0);
        assert_eq!(max_first(2.0, 3.0), 3.0);
        let last = f32::from_bits(0x7FC0_0001);
        assert_eq!(max_first_of(&[nan, last]).to_bits(), last.to_bits());
    }
}
