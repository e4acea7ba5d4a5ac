//! Splitting a volume into bricks, for sort-last rendering on several processes: each
//! process holds one brick (plus the ghost layers its kernel's support reaches) and
//! renders the stretch of every ray inside it.
//!
//! The decomposition is k-d: the volume (with N parts to make) is cut across its longest
//! axis (the lowest such axis on a tie) into two boxes that get ⌊N/2⌋ and ⌈N/2⌉ parts,
//! the cut placed in proportion to those counts; each box is cut the same way until every
//! box has one part. The bricks tile the volume exactly, in the order of a depth-first
//! walk (the lower side of every cut first).

use alloc::vec::Vec;

use crate::error::{Error, ErrorKind, Result};

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
        assert_eq!(
            decompose([10, 20, 5], 1).unwrap(),
            [Brick::whole([10, 20, 5])]
        );
        let two = decompose([10, 20, 5], 2).unwrap();
        assert_eq!(
            two[0],
            Brick {
                lo: [0, 0, 0],
                hi: [10, 10, 5]
            }
        );
        assert_eq!(
            two[1],
            Brick {
                lo: [0, 10, 0],
                hi: [10, 20, 5]
            }
        );
        // Three parts: one third below the cut, two thirds above (cut again).
        let three = decompose([30, 8, 8], 3).unwrap();
        assert_eq!(
            three[0],
            Brick {
                lo: [0, 0, 0],
                hi: [10, 8, 8]
            }
        );
        assert_eq!(
            three[1],
            Brick {
                lo: [10, 0, 0],
                hi: [20, 8, 8]
            }
        );
        assert_eq!(
            three[2],
            Brick {
                lo: [20, 0, 0],
                hi: [30, 8, 8]
            }
        );
        // Four parts of a cube: halves along x, then each along y.
        let four = decompose([8, 8, 8], 4).unwrap();
        assert_eq!(
            four[0],
            Brick {
                lo: [0, 0, 0],
                hi: [4, 4, 8]
            }
        );
        assert_eq!(
            four[3],
            Brick {
                lo: [4, 4, 0],
                hi: [8, 8, 8]
            }
        );
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
