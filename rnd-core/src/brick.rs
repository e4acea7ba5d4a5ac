//! Splitting a volume into bricks, for sort-last rendering on several processes: each
//! process holds one brick (plus the ghost layers its kernel's support reaches) and
//! renders the stretch of every ray inside it.
//!
//! The decomposition is k-d: the volume (with N parts to make) is cut across its longest
//! axis (the lowest such axis on a tie) into two boxes that get ⌊N/2⌋ and ⌈N/2⌉ parts,
//! the cut placed in proportion to those counts; each box is cut the same way until every
//! box has one part. The bricks tile the volume exactly, in the order of a depth-first
//! walk (the lower side of every cut first).
//!
//! **Which brick casts which sample.** Each ray is a straight line `c(k) = s + k d` in
//! the grid's index space (computed in f64 from the camera alone, the same on every
//! process), and sample k belongs to the brick whose box `lo <= c < hi` holds c(k) on
//! every axis (the bricks on the grid's faces extended to infinity, so samples outside
//! the grid belong somewhere too). Since c is monotone in k on each axis, a brick owns
//! one stretch `[first, end)` of every ray ([`Own::window`]), and the stretches of all
//! bricks partition the ray. The positions an arithmetic convolves at lie within half a
//! voxel of c(k) (checked per ray), so a brick grown by [`ghosts`] holds every sample
//! its samples' kernel supports reach: a brick's stretch convolved from a
//! [`crate::volume::Volume::region`] gives the bits of the whole volume's render for
//! those samples, and [`Partial`]s of the stretches composited in ray order give the
//! pixel (`max`, `min`: the same bits; sums and `over`: the same up to the association
//! of the float additions).

use alloc::vec::Vec;

use crate::blend::{Accum, Blend};
use crate::error::{Error, ErrorKind, Result};
use crate::kernel::KernelName;

/// A box of voxel indices: `lo[a] <= i < hi[a]` on each axis `a`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Brick {
    /// First index per axis.
    pub lo: [usize; 3],
    /// One past the last index per axis.
    pub hi: [usize; 3],
}

impl Brick {
    /// The whole volume of `sizes` voxels.
    pub fn whole(sizes: [usize; 3]) -> Brick {
        Brick {
            lo: [0; 3],
            hi: sizes,
        }
    }

    /// Voxels per axis.
    pub fn sizes(&self) -> [usize; 3] {
        core::array::from_fn(|a| self.hi[a].saturating_sub(self.lo[a]))
    }

    /// Number of voxels (saturating).
    pub fn voxels(&self) -> usize {
        self.sizes()
            .iter()
            .fold(1usize, |n, &s| n.saturating_mul(s))
    }

    /// Whether voxel `i` is in the brick.
    pub fn contains(&self, i: [usize; 3]) -> bool {
        (0..3).all(|a| self.lo[a] <= i[a] && i[a] < self.hi[a])
    }

    /// The brick grown by `below` voxels under `lo` and `above` voxels over `hi` on every
    /// axis, clipped to a volume of `sizes` (the ghost layers a kernel reaches).
    pub fn grown(&self, below: usize, above: usize, sizes: [usize; 3]) -> Brick {
        Brick {
            lo: self.lo.map(|l| l.saturating_sub(below)),
            hi: core::array::from_fn(|a| self.hi[a].saturating_add(above).min(sizes[a])),
        }
    }
}

/// The ghost layers a brick needs below and above its box for `kernel` (see the
/// [module](self)): with sample positions within half a voxel of the exact line, the
/// supports of a brick's samples reach `1 − LO` voxels below and `LO + S` above, for a
/// kernel of support S whose lowest offset is LO.
pub fn ghosts(kernel: KernelName) -> (usize, usize) {
    let (s, lo) = (kernel.support() as i64, i64::from(kernel.lo()));
    ((1 - lo).max(0) as usize, (lo + s).max(0) as usize)
}

/// The part of every ray one brick casts: samples whose exact index-space position c has
/// `lo <= c < hi` on every axis (±∞ on the grid's faces).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Own {
    /// Lower bounds per axis (inclusive).
    pub lo: [f64; 3],
    /// Upper bounds per axis (exclusive).
    pub hi: [f64; 3],
}

impl Own {
    /// What `brick` of a grid of `grid` samples owns.
    pub fn of(brick: &Brick, grid: [usize; 3]) -> Own {
        Own {
            lo: core::array::from_fn(|a| match brick.lo[a] {
                0 => f64::NEG_INFINITY,
                l => l as f64,
            }),
            hi: core::array::from_fn(|a| {
                if brick.hi[a] >= grid[a] {
                    f64::INFINITY
                } else {
                    brick.hi[a] as f64
                }
            }),
        }
    }

    /// The stretch `[first, end)` of samples `0 .. kend` of the line `s + k d` (per axis;
    /// computed as `s + (k as f64) * d`, monotone in k) that this brick owns; empty
    /// (first == end) when it owns none.
    pub fn window(&self, s: [f64; 3], d: [f64; 3], kend: u32) -> (u32, u32) {
        let (mut first, mut end) = (0u32, kend);
        for a in 0..3 {
            let (s, d, lo, hi) = (s[a], d[a], self.lo[a], self.hi[a]);
            let c = |k: u32| s + k as f64 * d;
            let guess = |t: f64| crate::math::ceil((t - s) / d);
            let (f, e) = if d > 0.0 {
                (
                    crate::arith::first_true_near(0, kend, guess(lo), |k| c(k) >= lo),
                    crate::arith::first_true_near(0, kend, guess(hi), |k| c(k) >= hi),
                )
            } else if d < 0.0 {
                (
                    crate::arith::first_true_near(0, kend, guess(hi), |k| c(k) < hi),
                    crate::arith::first_true_near(0, kend, guess(lo), |k| c(k) < lo),
                )
            } else if lo <= s && s < hi {
                (0, kend)
            } else {
                (0, 0)
            };
            first = first.max(f);
            end = end.min(e);
        }
        (first, end.max(first))
    }
}

/// One pixel's blend over one brick's stretch `[first, end)` of its ray: what sort-last
/// compositing combines ([`Partial::composite`]) and finishes into the pixel
/// ([`Partial::finish`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Partial {
    /// The running blend (for `over`: premultiplied colour and opacity).
    pub acc: Accum,
    /// The transparency under `over` in the reference arithmetic (which composites on
    /// it); 1 otherwise.
    pub transp: f32,
    /// The stretch of samples blended (first == end: none).
    pub first: u32,
    /// One past the last sample of the stretch.
    pub end: u32,
    /// Milliseconds spent on the stretch (the time channel, `-t`; 0 when not timed).
    pub time: f32,
}

impl Partial {
    /// Nothing blended.
    pub fn empty(blend: Blend, len: usize) -> Partial {
        Partial {
            acc: Accum::new(blend, len),
            transp: 1.0,
            first: 0,
            end: 0,
            time: 0.0,
        }
    }

    /// Whether no stretch is covered.
    pub fn is_empty(&self) -> bool {
        self.first >= self.end
    }

    /// The partial of the union of two adjacent stretches of one ray, whichever comes
    /// first along the ray in front (`over` composites the nearer over the farther; `by_
    /// transparency` as the reference arithmetic does, on the transparency). An empty
    /// partial changes nothing.
    ///
    /// Under `median` only the count is combined: the pixel needs the samples of every
    /// stretch ([`Partial::finish`]).
    ///
    /// # Errors
    /// [`ErrorKind::Render`] when the blends or channel counts differ or the stretches
    /// overlap.
    pub fn composite(&self, other: &Partial, by_transparency: bool) -> Result<Partial> {
        if (self.acc.blend, self.acc.len) != (other.acc.blend, other.acc.len) {
            return Err(Error::new(
                ErrorKind::Render,
                "partials of different blends or channel counts",
            ));
        }
        if other.is_empty() {
            return Ok(*self);
        }
        if self.is_empty() {
            return Ok(*other);
        }
        let (f, b) = if self.end <= other.first {
            (self, other)
        } else if other.end <= self.first {
            (other, self)
        } else {
            return Err(Error::new(
                ErrorKind::Render,
                alloc::format!(
                    "partials of overlapping stretches {}..{} and {}..{}",
                    self.first,
                    self.end,
                    other.first,
                    other.end
                ),
            ));
        };
        let mut out = *f;
        out.end = b.end;
        out.time = f.time + b.time;
        let (fa, ba) = (&f.acc, &b.acc);
        let len = fa.len.min(crate::blend::MAX_CHANNELS);
        let acc = &mut out.acc;
        acc.count = fa.count.saturating_add(ba.count);
        match fa.blend {
            Blend::Median => {}
            Blend::Max | Blend::Min if fa.count == 0 => acc.acc = ba.acc,
            Blend::Max | Blend::Min if ba.count == 0 => {}
            Blend::Max => {
                for c in 0..len {
                    acc.acc[c] = crate::blend::max_first(fa.acc[c], ba.acc[c]);
                }
            }
            Blend::Min => {
                for c in 0..len {
                    acc.acc[c] = fa.acc[c].min(ba.acc[c]);
                }
            }
            Blend::Sum | Blend::Mean => {
                for c in 0..len {
                    acc.acc[c] = fa.acc[c] + ba.acc[c];
                }
            }
            Blend::L2 | Blend::Variance | Blend::Sd => {
                for c in 0..len {
                    acc.sums[c] = [fa.sums[c][0] + ba.sums[c][0], fa.sums[c][1] + ba.sums[c][1]];
                }
            }
            Blend::Over if by_transparency => {
                // A front stretch that ended its ray (opacity set to 1) hides the rest.
                let t = if fa.acc[3] >= 1.0 { 0.0 } else { f.transp };
                for c in 0..3 {
                    acc.acc[c] = fa.acc[c] + t * ba.acc[c];
                }
                out.transp = t * b.transp;
                acc.acc[3] = 1.0 - out.transp;
            }
            Blend::Over => {
                let t = 1.0 - fa.acc[3];
                for c in 0..4 {
                    acc.acc[c] = fa.acc[c] + t * ba.acc[c];
                }
            }
        }
        Ok(out)
    }

    /// The partials of one pixel from every brick (any order) composited in ray order:
    /// the pixel's [`Partial`] for the whole ray.
    ///
    /// # Errors
    /// As [`Partial::composite`]; also when the non-empty stretches leave a gap.
    pub fn composite_all(parts: &mut [Partial], by_transparency: bool) -> Result<Partial> {
        let Some(first) = parts.first().copied() else {
            return Err(Error::new(ErrorKind::Render, "no partials to composite"));
        };
        parts.sort_unstable_by_key(|p| (p.is_empty(), p.first));
        let mut acc = Partial::empty(first.acc.blend, first.acc.len);
        for p in parts.iter().filter(|p| !p.is_empty()) {
            if !acc.is_empty() && acc.end != p.first {
                return Err(Error::new(
                    ErrorKind::Render,
                    alloc::format!("partials leave samples {}..{} out", acc.end, p.first),
                ));
            }
            acc = acc.composite(p, by_transparency)?;
        }
        Ok(acc)
    }

    /// Bytes [`Partial::encode`] writes for a partial of `blend` with `len` channels (and
    /// under `median`, 4 more for each channel of each sample).
    pub fn record_len(blend: Blend, len: usize) -> usize {
        let len = len.min(crate::blend::MAX_CHANNELS);
        20 + 4 * len + if squares(blend) { 16 * len } else { 0 }
    }

    /// Appends the partial to `out` (little-endian: first, end, count, transparency,
    /// time, the accumulated channels, for `l2`, `variance` and `sd` their f64 sums, and
    /// under `median` the `count · len` samples, channel by channel), for sending to
    /// another process.
    pub fn encode(&self, samples: &[f32], out: &mut Vec<u8>) {
        let len = self.acc.len.min(crate::blend::MAX_CHANNELS);
        let words = [
            self.first,
            self.end,
            self.acc.count,
            self.transp.to_bits(),
            self.time.to_bits(),
        ];
        for w in words {
            out.extend_from_slice(&w.to_le_bytes());
        }
        for c in 0..len {
            out.extend_from_slice(&self.acc.acc[c].to_le_bytes());
        }
        if squares(self.acc.blend) {
            for c in 0..len {
                for x in self.acc.sums[c] {
                    out.extend_from_slice(&x.to_le_bytes());
                }
            }
        }
        if self.acc.blend.keeps_samples() {
            let n = self.acc.count as usize * len;
            for x in samples.iter().take(n) {
                out.extend_from_slice(&x.to_le_bytes());
            }
            // (A list shorter than the count is padded, so the record stays readable.)
            for _ in samples.len()..n {
                out.extend_from_slice(&f32::NAN.to_le_bytes());
            }
        }
    }

    /// The partial of `blend` with `len` channels at the start of `b` (as
    /// [`Partial::encode`] wrote it), its samples (under `median`) and the bytes it took;
    /// `None` when `b` is too short.
    pub fn decode(b: &[u8], blend: Blend, len: usize) -> Option<(Partial, Vec<f32>, usize)> {
        let n = Partial::record_len(blend, len);
        let all = b;
        let b = b.get(..n)?;
        let word = |i: usize| u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
        let mut p = Partial::empty(blend, len);
        (p.first, p.end, p.acc.count) = (word(0), word(4), word(8));
        p.transp = f32::from_bits(word(12));
        p.time = f32::from_bits(word(16));
        let len = len.min(crate::blend::MAX_CHANNELS);
        for c in 0..len {
            p.acc.acc[c] = f32::from_bits(word(20 + 4 * c));
        }
        if squares(blend) {
            let at = 20 + 4 * len;
            for c in 0..len {
                for (h, x) in p.acc.sums[c].iter_mut().enumerate() {
                    let i = at + 16 * c + 8 * h;
                    let lo = u64::from(word(i));
                    let hi = u64::from(word(i + 4));
                    *x = f64::from_bits(lo | hi << 32);
                }
            }
        }
        let mut samples = Vec::new();
        let mut used = n;
        if blend.keeps_samples() {
            let k = (p.acc.count as usize).checked_mul(len)?;
            let bytes = all.get(n..n.checked_add(k.checked_mul(4)?)?)?;
            samples = bytes
                .chunks_exact(4)
                .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect();
            used += bytes.len();
        }
        Some((p, samples, used))
    }

    /// The pixel: the blend's result into `out[..len]`, `outside` when nothing was
    /// blended (see [`Accum::finish`]). Under `median`, `samples` holds the samples of
    /// every stretch of the ray (each stretch's channel by channel, as
    /// [`crate::render::RenderSpec::render_part_rows`] gives them), in any order of
    /// stretches.
    pub fn finish(&self, outside: f32, samples: &[&[f32]], out: &mut [f32]) {
        if !self.acc.blend.keeps_samples() {
            return self.acc.finish(outside, None, out);
        }
        let len = self.acc.len.min(crate::blend::MAX_CHANNELS);
        let mut kept = crate::blend::Kept::new();
        for s in samples {
            let n = s.len() / len.max(1);
            for c in 0..len {
                kept.extend(c, &s[c * n..(c + 1) * n]);
            }
        }
        self.acc.finish(outside, Some(&mut kept), out);
    }
}

/// Whether `blend` keeps f64 sums (`l2`, `variance`, `sd`).
fn squares(blend: Blend) -> bool {
    matches!(blend, Blend::L2 | Blend::Variance | Blend::Sd)
}

/// Splits a volume of `sizes` voxels into `n` bricks (see the [module](self) for the
/// rule).
///
/// # Errors
/// [`ErrorKind::Volume`] when `n` is 0 or the volume cannot be cut into `n` non-empty
/// bricks (an axis shorter than the parts it must be cut into).
pub fn decompose(sizes: [usize; 3], n: usize) -> Result<Vec<Brick>> {
    if n == 0 {
        return Err(Error::new(
            ErrorKind::Volume,
            "cannot split a volume into 0 bricks",
        ));
    }
    let mut out = Vec::new();
    out.try_reserve(n)
        .map_err(|_| Error::new(ErrorKind::Memory, "no memory for the list of bricks"))?;
    split(Brick::whole(sizes), n, &mut out)?;
    Ok(out)
}

fn split(b: Brick, n: usize, out: &mut Vec<Brick>) -> Result<()> {
    if n == 1 {
        if b.voxels() == 0 {
            return Err(Error::new(ErrorKind::Volume, "a brick would be empty"));
        }
        out.push(b);
        return Ok(());
    }
    let s = b.sizes();
    let axis = (0..3).fold(0, |best, a| if s[a] > s[best] { a } else { best });
    let (left, right) = (n / 2, n - n / 2);
    if s[axis] < n {
        return Err(Error::new(
            ErrorKind::Volume,
            alloc::format!(
                "cannot cut {} x {} x {} voxels into {n} non-empty bricks",
                s[0],
                s[1],
                s[2]
            ),
        ));
    }
    // In proportion to the parts on each side, at least one voxel per part.
    let cut = b.lo[axis] + (s[axis] * left / n).max(left);
    let (mut lower, mut upper) = (b, b);
    lower.hi[axis] = cut;
    upper.lo[axis] = cut;
    split(lower, left, out)?;
    split(upper, right, out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tiles(sizes: [usize; 3], bricks: &[Brick]) {
        let total: usize = bricks.iter().map(Brick::voxels).sum();
        assert_eq!(total, sizes[0] * sizes[1] * sizes[2], "{bricks:?}");
        for k in 0..sizes[2] {
            for j in 0..sizes[1] {
                for i in 0..sizes[0] {
                    let n = bricks.iter().filter(|b| b.contains([i, j, k])).count();
                    assert_eq!(n, 1, "voxel {i} {j} {k} in {n} bricks");
                }
            }
        }
    }

    #[test]
    fn partials_decode_what_they_encode() {
        for blend in Blend::ALL {
            for len in [1, 4, 9] {
                let mut p = Partial::empty(blend, len);
                (p.first, p.end, p.acc.count, p.transp, p.time) = (3, 17, 11, 0.25, 1.5);
                for c in 0..len {
                    p.acc.acc[c] = c as f32 * 1.5 - 2.0;
                    if squares(blend) {
                        p.acc.sums[c] = [c as f64 / 3.0, -1e300];
                    }
                }
                let samples: Vec<f32> = (0..11 * len).map(|i| i as f32 * 0.5).collect();
                let mut b = Vec::new();
                p.encode(&samples, &mut b);
                let median = blend.keeps_samples();
                let n = Partial::record_len(blend, len) + if median { 44 * len } else { 0 };
                assert_eq!(b.len(), n);
                let kept = if median { samples.clone() } else { Vec::new() };
                assert_eq!(
                    Partial::decode(&b, blend, len),
                    Some((p, kept, n)),
                    "{blend} {len}"
                );
                assert_eq!(Partial::decode(&b[..n - 1], blend, len), None);
            }
        }
    }

    #[test]
    fn bricks_tile_the_volume_for_every_count() {
        for sizes in [[7, 5, 3], [16, 16, 16], [30, 4, 9], [1, 1, 12]] {
            for n in 1..=12 {
                match decompose(sizes, n) {
                    Ok(b) => {
                        assert_eq!(b.len(), n);
                        tiles(sizes, &b);
                    }
                    Err(e) => assert!(
                        sizes.iter().max().unwrap() < &n || sizes == [1, 1, 12] && n > 12,
                        "{sizes:?} into {n}: {e}"
                    ),
                }
            }
        }
    }

    #[test]
    fn cuts_go_across_the_longest_axis_in_proportion() {
        let b = |lo, hi| Brick { lo, hi };
        assert_eq!(
            decompose([10, 20, 5], 1).unwrap(),
            [Brick::whole([10, 20, 5])]
        );
        assert_eq!(
            decompose([10, 20, 5], 2).unwrap(),
            [b([0, 0, 0], [10, 10, 5]), b([0, 10, 0], [10, 20, 5])]
        );
        // Three parts: one third below the cut, two thirds above (cut again).
        assert_eq!(
            decompose([30, 8, 8], 3).unwrap(),
            [
                b([0, 0, 0], [10, 8, 8]),
                b([10, 0, 0], [20, 8, 8]),
                b([20, 0, 0], [30, 8, 8])
            ]
        );
        // Four parts of a cube: halves along x, then each along y.
        let four = decompose([8, 8, 8], 4).unwrap();
        assert_eq!(four[0], b([0, 0, 0], [4, 4, 8]));
        assert_eq!(four[3], b([4, 4, 0], [8, 8, 8]));
    }

    #[test]
    fn impossible_splits_are_errors() {
        assert_eq!(decompose([4, 4, 4], 0).unwrap_err().kind, ErrorKind::Volume);
        assert_eq!(decompose([2, 1, 1], 3).unwrap_err().kind, ErrorKind::Volume);
        assert_eq!(decompose([0, 5, 5], 1).unwrap_err().kind, ErrorKind::Volume);
    }

    #[test]
    fn ghost_layers_are_clipped_to_the_volume() {
        let b = Brick {
            lo: [0, 3, 5],
            hi: [4, 6, 8],
        };
        let g = b.grown(1, 2, [10, 7, 8]);
        assert_eq!(
            g,
            Brick {
                lo: [0, 2, 4],
                hi: [6, 7, 8]
            }
        );
        assert_eq!(g.sizes(), [6, 5, 4]);
    }
}
