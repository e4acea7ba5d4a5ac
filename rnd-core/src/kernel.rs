//! Reconstruction kernels (box, tent, quadratic and cubic B-splines, Catmull-Rom and
//! the C4-hexic) and their first and second derivatives.
//!
//! Each kernel is a zero-sized type implementing [`Kernel<S>`] where `S` is its support
//! (samples per axis). The piecewise polynomials are written once, generic over
//! [`num_traits::Float`], and evaluated in f64 for `keval` and in f32 in the convolution
//! loop. [`KernelName`] is the run-time name (parsed case-insensitively).

use core::fmt;
use core::str::FromStr;
/// The float trait the kernel formulas are written over (re-exported from `num-traits`).
pub use num_traits::Float;

use crate::error::{Error, ErrorKind};

#[inline(always)]
fn c<T: Float>(x: f64) -> T {
    // Constant conversion f64 -> T cannot fail for f32/f64.
    T::from(x).unwrap_or_else(T::nan)
}

#[inline(always)]
fn sgn<T: Float>(x: T) -> T {
    if x < T::zero() {
        -T::one()
    } else {
        T::one()
    }
}

/// A separable reconstruction kernel with compile-time support `S`.
///
/// The weight of sample `n + lo + i` (for `i` in `0..S`) at fractional position `alpha`
/// is `K(alpha - lo - i)` where `lo` is [`Kernel::LO`]; `n` and `alpha` are the integer
/// and fractional parts of the index coordinate (of coordinate + ½ for odd supports).
pub trait Kernel<const S: usize>: Copy + Default + Send + Sync + 'static {
    /// The kernel's run-time name.
    const NAME: KernelName;
    /// Offset of the first sample relative to the base index: `1 - S/2` for even S,
    /// `-(S-1)/2` for odd S.
    const LO: i32 = if S.is_multiple_of(2) {
        1 - (S as i32) / 2
    } else {
        -((S as i32 - 1) / 2)
    };

    /// For support-4 kernels whose weights are cubics in `alpha`: the coefficient tables
    /// `[value, first derivative]`, `co[d][i]` the coefficient of alpha^d in weight i (see
    /// [`horner4`]), so that a vector loop can evaluate all four weights at once.
    const CUBIC4: Option<[[[f32; 4]; 4]; 2]> = None;

    /// Kernel value at `x`.
    fn k<T: Float>(x: T) -> T;
    /// First derivative at `x`.
    fn d1<T: Float>(x: T) -> T;
    /// Second derivative at `x`.
    fn d2<T: Float>(x: T) -> T;

    /// Value weights for fractional position `alpha` (lowest index first). By default
    /// evaluated in f64 (c4hexic's high-order pieces cancel badly in f32) and rounded to
    /// f32; the cubic kernels override it with f32 polynomials in `alpha`.
    #[inline(always)]
    fn weights(alpha: f64) -> [f32; S] {
        core::array::from_fn(|i| Self::k(alpha - (Self::LO + i as i32) as f64) as f32)
    }
    /// First-derivative weights for fractional position `alpha`.
    #[inline(always)]
    fn weights_d1(alpha: f64) -> [f32; S] {
        core::array::from_fn(|i| Self::d1(alpha - (Self::LO + i as i32) as f64) as f32)
    }
    /// Kernel value at `x` as the reference-arithmetic mode evaluates it
    /// ([`crate::refarith`]): by default [`Kernel::k`] in f64 rounded to f32.
    #[inline(always)]
    fn k_ref(x: f32) -> f32 {
        Self::k::<f64>(x as f64) as f32
    }
    /// First derivative at `x` for the reference-arithmetic mode (by default
    /// [`Kernel::d1`] in f64 rounded to f32).
    #[inline(always)]
    fn d1_ref(x: f32) -> f32 {
        Self::d1::<f64>(x as f64) as f32
    }
    /// The reference arithmetic's S weights at a sample whose fractional offset is
    /// `al`: `k_ref(al − (LO + i))` for `i` in `0..S`, those bits exactly. A kernel may
    /// override it with a form that, knowing `al` lies in [0, 1) for even supports (in
    /// [−½, ½) for odd ones, as the placement makes it), skips the pieces of `k_ref` a
    /// position can never select.
    #[inline(always)]
    fn ref_weights(al: f32) -> [f32; S] {
        core::array::from_fn(|i| Self::k_ref(al - (Self::LO + i as i32) as f32))
    }
    /// [`Kernel::ref_weights`] of the first derivative (`d1_ref`).
    #[inline(always)]
    fn ref_weights_d1(al: f32) -> [f32; S] {
        core::array::from_fn(|i| Self::d1_ref(al - (Self::LO + i as i32) as f32))
    }
    /// [`Kernel::ref_weights`] (`D1` false) or [`Kernel::ref_weights_d1`] (true) of
    /// every lane, `[i][l]` weight i of lane l, for a kernel whose per-lane loop the
    /// compiler does not vectorize (tent's two interleaved weights): loops it does, the
    /// same bits. None (the default): the lane code calls `ref_weights` lane by lane.
    #[inline(always)]
    fn ref_weights_lanes<const D1: bool, const L: usize>(_al: &[f32; L]) -> Option<[[f32; L]; S]> {
        None
    }
    /// Integer base index and fractional offset for index-space coordinate `x`
    /// (`floor(x)` for even support, `floor(x + 0.5)` for odd).
    #[inline(always)]
    fn base(x: f64) -> (i64, f64) {
        // Callers keep |x| below 2^51, where adding and subtracting 1.5·2^52 rounds to
        // the nearest integer (the sum lies in [2^52, 2^53), spacing 1); one correction
        // makes it the floor. All in floating point: much shorter latency than a round
        // trip through the integer unit, and exact.
        const ROUND: f64 = 6_755_399_441_055_744.0;
        let y = if S.is_multiple_of(2) { x } else { x + 0.5 };
        let r = (y + ROUND) - ROUND;
        let f = r - if r > y { 1.0 } else { 0.0 };
        (crate::simd::trunc_i64(f), x - f)
    }
}

/// The reference's bspln3 piece for |x| in [0, 1): 2/3 + t²(−1 + t/2), nested as the
/// course program nests it.
#[inline(always)]
fn bspln3_near(t: f32) -> f32 {
    2.0 / 3.0 + t * t * (-1.0 + t / 2.0)
}

/// The reference's bspln3 piece for |x| in [1, 2), in u = |x| − 1.
#[inline(always)]
fn bspln3_far(t: f32) -> f32 {
    let u = t - 1.0;
    1.0 / 6.0 + u * (-0.5 + u * (0.5 - u / 6.0))
}

/// |x| of the four support positions at fractional offset `al` (x = al − (LO + i),
/// LO = −1), as the reference computes them.
#[inline(always)]
fn bspln3_positions(al: f32) -> [f32; 4] {
    [
        (al + 1.0).abs(),
        al.abs(),
        (al - 1.0).abs(),
        (al - 2.0).abs(),
    ]
}

/// [`bspln3_near`]'s derivative (for positive x).
#[inline(always)]
fn bspln3_near_d1(t: f32) -> f32 {
    t * (-2.0 + t * 1.5)
}

/// [`bspln3_far`]'s derivative (for positive x).
#[inline(always)]
fn bspln3_far_d1(t: f32) -> f32 {
    let u = t - 1.0;
    -0.5 + u * (1.0 - u / 2.0)
}

macro_rules! kernel_type {
    ($(#[$m:meta])* $ty:ident, $s:expr) => {
        $(#[$m])*
        #[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
        pub struct $ty;
        impl $ty {
            /// Support (samples per axis).
            pub const SUPPORT: usize = $s;
        }
    };
}

kernel_type!(
    /// The zero kernel (support 1): everything is 0; its derivative is itself.
    Zero, 1);
kernel_type!(
    /// Box (support 1): 1 on [−0.5, 0.5), else 0. Derivative: zero.
    BoxK, 1);
kernel_type!(
    /// Tent (support 2): linear interpolation.
    Tent, 2);
kernel_type!(
    /// Quadratic B-spline (support 3).
    Bspln2, 3);
kernel_type!(
    /// Cubic B-spline (support 4): C², approximating.
    Bspln3, 4);
kernel_type!(
    /// Catmull-Rom cubic spline (support 4): interpolating, C¹.
    Ctmr, 4);
kernel_type!(
    /// Teem's C4 hexic (support 6): C⁴, partition of unity, not interpolating.
    C4Hexic, 6);

impl Kernel<1> for Zero {
    const NAME: KernelName = KernelName::Zero;
    fn k<T: Float>(_x: T) -> T {
        T::zero()
    }
    fn d1<T: Float>(_x: T) -> T {
        T::zero()
    }
    fn d2<T: Float>(_x: T) -> T {
        T::zero()
    }
}

impl Kernel<1> for BoxK {
    const NAME: KernelName = KernelName::Box;
    fn k<T: Float>(x: T) -> T {
        if x >= c(-0.5) && x < c(0.5) {
            T::one()
        } else {
            T::zero()
        }
    }
    fn d1<T: Float>(_x: T) -> T {
        T::zero()
    }
    fn d2<T: Float>(_x: T) -> T {
        T::zero()
    }
}

impl Kernel<2> for Tent {
    const NAME: KernelName = KernelName::Tent;
    fn k<T: Float>(x: T) -> T {
        let t = x.abs();
        if t < T::one() {
            T::one() - t
        } else {
            T::zero()
        }
    }
    fn d1<T: Float>(x: T) -> T {
        // Half-open pieces so that the weights of one convolution sum to exactly 0.
        if x >= T::zero() && x < T::one() {
            -T::one()
        } else if x >= -T::one() && x < T::zero() {
            T::one()
        } else {
            T::zero()
        }
    }
    fn d2<T: Float>(_x: T) -> T {
        T::zero()
    }
    /// With `al` in [0, 1): `k_ref(al)` is `1 − al`, and `k_ref(al − 1)` is `1 − |al − 1|`
    /// with `|al − 1|` the same rounding of `1 − al`. Each is one f32 subtraction: an
    /// operation whose f64 result is rounded to f32 gives the f32 operation's bits, as
    /// f64 carries more than 2·24 + 2 bits. No f64 round trip and no branch (test
    /// `ref_weight_shortcuts_are_k_ref`).
    #[inline(always)]
    fn ref_weights(al: f32) -> [f32; 2] {
        debug_assert!((0.0..1.0).contains(&al));
        let w0 = 1.0 - al;
        [w0, 1.0 - w0]
    }
    /// `d1` is −1 on [0, 1) and 1 on [−1, 0), where `al` and `al − 1` lie.
    #[inline(always)]
    fn ref_weights_d1(al: f32) -> [f32; 2] {
        debug_assert!((0.0..1.0).contains(&al));
        [-1.0, 1.0]
    }
    /// One loop per weight.
    #[inline(always)]
    fn ref_weights_lanes<const D1: bool, const L: usize>(al: &[f32; L]) -> Option<[[f32; L]; 2]> {
        if D1 {
            return Some([[-1.0; L], [1.0; L]]);
        }
        let mut w = [[0.0f32; L]; 2];
        for l in 0..L {
            w[0][l] = 1.0 - al[l];
        }
        for l in 0..L {
            w[1][l] = 1.0 - w[0][l];
        }
        Some(w)
    }
    #[inline(always)]
    fn weights(a: f64) -> [f32; 2] {
        [(1.0 - a) as f32, a as f32]
    }
    #[inline(always)]
    fn weights_d1(_a: f64) -> [f32; 2] {
        [-1.0, 1.0]
    }
}

impl Kernel<3> for Bspln2 {
    const NAME: KernelName = KernelName::Bspln2;
    fn k<T: Float>(x: T) -> T {
        let t = x.abs();
        if t < c(0.5) {
            c::<T>(0.75) - t * t
        } else if t < c(1.5) {
            let a = t - c(1.5);
            a * a / c(2.0)
        } else {
            T::zero()
        }
    }
    fn d1<T: Float>(x: T) -> T {
        let t = x.abs();
        if t < c(0.5) {
            c::<T>(-2.0) * x
        } else if t < c(1.5) {
            sgn(x) * (t - c(1.5))
        } else {
            T::zero()
        }
    }
    fn d2<T: Float>(x: T) -> T {
        let t = x.abs();
        if t < c(0.5) {
            c(-2.0)
        } else if t < c(1.5) {
            T::one()
        } else {
            T::zero()
        }
    }
}

impl Kernel<4> for Bspln3 {
    const NAME: KernelName = KernelName::Bspln3;
    fn k<T: Float>(x: T) -> T {
        let t = x.abs();
        if t < T::one() {
            c::<T>(2.0 / 3.0) + t * t * (c::<T>(-1.0) + t / c(2.0))
        } else if t < c(2.0) {
            let a = c::<T>(2.0) - t;
            a * a * a / c(6.0)
        } else {
            T::zero()
        }
    }
    fn d1<T: Float>(x: T) -> T {
        let t = x.abs();
        if t < T::one() {
            x * (c::<T>(-2.0) + c::<T>(1.5) * t)
        } else if t < c(2.0) {
            let a = c::<T>(2.0) - t;
            -sgn(x) * a * a / c(2.0)
        } else {
            T::zero()
        }
    }
    fn d2<T: Float>(x: T) -> T {
        let t = x.abs();
        if t < T::one() {
            c::<T>(-2.0) + c::<T>(3.0) * t
        } else if t < c(2.0) {
            c::<T>(2.0) - t
        } else {
            T::zero()
        }
    }
    const CUBIC4: Option<[[[f32; 4]; 4]; 2]> = Some(BSPLN3_CUBICS);
    /// The course reference's f32 form: nested in |x| on [0, 1) and in |x| − 1 on
    /// [1, 2) (shown bit for bit against `cube-rgb.nrrd`, see `refarith`).
    #[inline(always)]
    fn k_ref(x: f32) -> f32 {
        // Both pieces computed, one selected: the same operations as branching on |x|
        // for the piece used, and vectorizable across samples.
        let t = x.abs();
        let r = if t < 2.0 { bspln3_far(t) } else { 0.0 };
        if t < 1.0 {
            bspln3_near(t)
        } else {
            r
        }
    }
    #[inline(always)]
    fn d1_ref(x: f32) -> f32 {
        let t = x.abs();
        let r = if t < 2.0 { bspln3_far_d1(t) } else { 0.0 };
        let r = if t < 1.0 { bspln3_near_d1(t) } else { r };
        if x < 0.0 {
            -r
        } else {
            r
        }
    }
    /// With `al` in [0, 1) the four positions' |x| lie in [1, 2], [0, 1), (0, 1] and
    /// (1, 2]: each needs one piece, the second's other piece only at |x| = 1 exactly
    /// (`al` = 0), where it is a constant. Half the arithmetic of `k_ref` four times
    /// (the far piece's division included), the same bits (test
    /// `ref_weight_shortcuts_are_k_ref`).
    #[inline(always)]
    fn ref_weights(al: f32) -> [f32; 4] {
        debug_assert!((0.0..1.0).contains(&al));
        let [t0, t1, t2, t3] = bspln3_positions(al);
        [
            if t0 < 2.0 { bspln3_far(t0) } else { 0.0 },
            bspln3_near(t1),
            if t2 < 1.0 {
                bspln3_near(t2)
            } else {
                bspln3_far(1.0)
            },
            if t3 < 2.0 { bspln3_far(t3) } else { 0.0 },
        ]
    }
    /// [`Kernel::ref_weights`]' shortcut for `d1_ref` (the sign is that of `x`:
    /// positive for the first two positions, negative for the last two).
    #[inline(always)]
    fn ref_weights_d1(al: f32) -> [f32; 4] {
        debug_assert!((0.0..1.0).contains(&al));
        let [t0, t1, t2, t3] = bspln3_positions(al);
        [
            if t0 < 2.0 { bspln3_far_d1(t0) } else { 0.0 },
            bspln3_near_d1(t1),
            -(if t2 < 1.0 {
                bspln3_near_d1(t2)
            } else {
                bspln3_far_d1(1.0)
            }),
            -(if t3 < 2.0 { bspln3_far_d1(t3) } else { 0.0 }),
        ]
    }
    #[inline(always)]
    fn weights(a: f64) -> [f32; 4] {
        horner4(&BSPLN3_CUBICS[0], a as f32)
    }
    #[inline(always)]
    fn weights_d1(a: f64) -> [f32; 4] {
        horner4(&BSPLN3_CUBICS[1], a as f32)
    }
}

const S6: f32 = 1.0 / 6.0;
/// bspln3's K(a + 1), K(a), K(a - 1), K(a - 2) for a in [0, 1) and their derivatives, in
/// powers of a (coefficients exact in binary except 1/6 and 2/3).
const BSPLN3_CUBICS: [[[f32; 4]; 4]; 2] = [
    [
        [S6, 2.0 / 3.0, S6, 0.0],
        [-0.5, 0.0, 0.5, 0.0],
        [0.5, -1.0, 0.5, 0.0],
        [-S6, 0.5, -0.5, S6],
    ],
    [
        [-0.5, 0.0, 0.5, 0.0],
        [1.0, -2.0, 1.0, 0.0],
        [-0.5, 1.5, -1.5, 0.5],
        [0.0; 4],
    ],
];

impl Kernel<4> for Ctmr {
    const NAME: KernelName = KernelName::Ctmr;
    fn k<T: Float>(x: T) -> T {
        let t = x.abs();
        if t < T::one() {
            T::one() + t * t * (c::<T>(-2.5) + c::<T>(1.5) * t)
        } else if t < c(2.0) {
            c::<T>(2.0) + t * (c::<T>(-4.0) + t * (c::<T>(2.5) - t / c(2.0)))
        } else {
            T::zero()
        }
    }
    fn d1<T: Float>(x: T) -> T {
        let t = x.abs();
        if t < T::one() {
            x * (c::<T>(-5.0) + c::<T>(4.5) * t)
        } else if t < c(2.0) {
            sgn(x) * (c::<T>(-4.0) + t * (c::<T>(5.0) - c::<T>(1.5) * t))
        } else {
            T::zero()
        }
    }
    fn d2<T: Float>(x: T) -> T {
        let t = x.abs();
        if t < T::one() {
            c::<T>(-5.0) + c::<T>(9.0) * t
        } else if t < c(2.0) {
            c::<T>(5.0) - c::<T>(3.0) * t
        } else {
            T::zero()
        }
    }
    // Closed forms of K(a + 1), K(a), K(a - 1), K(a - 2) for a in [0, 1).
    const CUBIC4: Option<[[[f32; 4]; 4]; 2]> = Some(CTMR_CUBICS);
    #[inline(always)]
    fn weights(a: f64) -> [f32; 4] {
        horner4(&CTMR_CUBICS[0], a as f32)
    }
    #[inline(always)]
    fn weights_d1(a: f64) -> [f32; 4] {
        horner4(&CTMR_CUBICS[1], a as f32)
    }
}

/// ctmr's K(a + 1), K(a), K(a - 1), K(a - 2) for a in [0, 1) and their derivatives, in
/// powers of a (all coefficients exact in binary).
const CTMR_CUBICS: [[[f32; 4]; 4]; 2] = [
    [
        [0.0, 1.0, 0.0, 0.0],
        [-0.5, 0.0, 0.5, 0.0],
        [1.0, -2.5, 2.0, -0.5],
        [-0.5, 1.5, -1.5, 0.5],
    ],
    [
        [-0.5, 0.0, 0.5, 0.0],
        [2.0, -5.0, 4.0, -1.0],
        [-1.5, 4.5, -4.5, 1.5],
        [0.0; 4],
    ],
];

/// Four cubic weight polynomials at once, in f32: `co[d][i]` is the coefficient of a^d
/// in weight i. Horner's rule lane by lane (the four lanes vectorize); the cubics of
/// the support-4 kernels are well conditioned on [0, 1), so f32 keeps them within a few
/// ulps of 1.
#[inline(always)]
pub fn horner4(co: &[[f32; 4]; 4], a: f32) -> [f32; 4] {
    core::array::from_fn(|i| ((co[3][i] * a + co[2][i]) * a + co[1][i]) * a + co[0][i])
}

/// Evaluates the polynomial with coefficients `co` (constant first) at `t` (Horner).
#[inline(always)]
fn poly<T: Float, const N: usize>(co: [f64; N], t: T) -> T {
    let mut acc = T::zero();
    for &k in co.iter().rev() {
        acc = acc * t + c(k);
    }
    acc
}

impl Kernel<6> for C4Hexic {
    const NAME: KernelName = KernelName::C4hexic;
    fn k<T: Float>(x: T) -> T {
        let t = x.abs();
        if t < T::one() {
            poly(
                [
                    69. / 80.,
                    0.,
                    -23. / 16.,
                    0.,
                    19. / 16.,
                    -7. / 12.,
                    1. / 16.,
                ],
                t,
            )
        } else if t < c(2.0) {
            poly(
                [
                    3. / 160.,
                    35. / 8.,
                    -341. / 32.,
                    10.,
                    -147. / 32.,
                    25. / 24.,
                    -3. / 32.,
                ],
                t,
            )
        } else if t < c(3.0) {
            poly(
                [
                    1539. / 160.,
                    -189. / 8.,
                    747. / 32.,
                    -12.,
                    109. / 32.,
                    -61. / 120.,
                    1. / 32.,
                ],
                t,
            )
        } else {
            T::zero()
        }
    }
    fn d1<T: Float>(x: T) -> T {
        let t = x.abs();
        let d = if t < T::one() {
            poly([0., -23. / 8., 0., 19. / 4., -35. / 12., 3. / 8.], t)
        } else if t < c(2.0) {
            poly(
                [
                    35. / 8.,
                    -341. / 16.,
                    30.,
                    -147. / 8.,
                    125. / 24.,
                    -9. / 16.,
                ],
                t,
            )
        } else if t < c(3.0) {
            poly(
                [
                    -189. / 8.,
                    747. / 16.,
                    -36.,
                    109. / 8.,
                    -61. / 24.,
                    3. / 16.,
                ],
                t,
            )
        } else {
            T::zero()
        };
        sgn(x) * d
    }
    fn d2<T: Float>(x: T) -> T {
        let t = x.abs();
        if t < T::one() {
            poly([-23. / 8., 0., 57. / 4., -35. / 3., 15. / 8.], t)
        } else if t < c(2.0) {
            poly([-341. / 16., 60., -441. / 8., 125. / 6., -45. / 16.], t)
        } else if t < c(3.0) {
            poly([747. / 16., -72., 327. / 8., -61. / 6., 15. / 16.], t)
        } else {
            T::zero()
        }
    }
}

/// Work to run with a kernel type known at compile time; see [`KernelName::with`].
pub trait KernelTask {
    /// What the task returns.
    type Output;
    /// Runs with kernel `K` of support `S`.
    fn run<K: Kernel<S>, const S: usize>(self) -> Self::Output;
}

/// The one table of kernels: each entry gives the run-time name's variant, the type
/// (with its formulas and [`Kernel`] impl above), the support, the `-k` name, the
/// display name and the `klist` description. Everything that goes from a name to a
/// kernel is generated from it; a new kernel is one entry plus its formulas.
macro_rules! kernel_table {
    ($($var:ident => $ty:ident, $s:literal, $name:literal, $title:literal, $desc:literal;)*) => {
        /// Run-time kernel names (the `-k` option). Parsed case-insensitively.
        ///
        /// ```
        /// use rnd_core::kernel::KernelName;
        ///
        /// let k: KernelName = "BSpln3".parse().unwrap();
        /// assert_eq!(k, KernelName::Bspln3);
        /// assert_eq!(k.support(), 4);
        /// assert_eq!(KernelName::Tent.support(), 2);
        /// assert!(KernelName::ALL.len() >= 6);
        /// assert!("gauss".parse::<KernelName>().is_err());
        /// ```
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum KernelName {
            $(#[doc = concat!("[`", stringify!($ty), "`]: ", $desc)] $var,)*
        }

        impl KernelName {
            /// Every kernel, in `klist` order.
            pub const ALL: [KernelName; [$(stringify!($var)),*].len()] = [$(KernelName::$var),*];

            /// Canonical lower-case name (what `-k` accepts).
            pub fn as_str(self) -> &'static str {
                match self { $(KernelName::$var => $name,)* }
            }

            /// Display name with a capital, as `klist`/`keval` print it (`Bspln3`).
            pub fn title(self) -> &'static str {
                match self { $(KernelName::$var => $title,)* }
            }

            /// Support (samples per axis).
            pub fn support(self) -> usize {
                match self { $(KernelName::$var => $s,)* }
            }

            /// One-line description for `klist`.
            pub fn description(self) -> &'static str {
                match self { $(KernelName::$var => $desc,)* }
            }

            /// Runs `task` with this kernel's type: the one run-time → compile-time
            /// switch on the kernel.
            pub fn with<T: KernelTask>(self, task: T) -> T::Output {
                match self { $(KernelName::$var => task.run::<$ty, $s>(),)* }
            }
        }
    };
}

kernel_table! {
    Zero => Zero, 1, "zero", "Zero", "always zero (its own derivative)";
    Box => BoxK, 1, "box", "Box", "nearest neighbour: 1 on [-0.5, 0.5), else 0";
    Tent => Tent, 2, "tent", "Tent", "linear interpolation";
    Bspln2 => Bspln2, 3, "bspln2", "Bspln2", "quadratic B-spline, C1, approximating";
    Bspln3 => Bspln3, 4, "bspln3", "Bspln3", "cubic B-spline, C2, approximating";
    Ctmr => Ctmr, 4, "ctmr", "Ctmr", "Catmull-Rom cubic spline, C1, interpolating";
    C4hexic => C4Hexic, 6, "c4hexic", "C4hexic", "C4 hexic (Teem), C4, reproduces quadratics approximately";
}

impl KernelName {
    /// Evaluates derivative `deriv` (0, 1 or 2) at `x` in f64; higher derivatives are 0
    /// only for kernels whose second derivative is piecewise constant, so callers limit
    /// `deriv` to 0..=2.
    pub fn eval(self, x: f64, deriv: u32) -> f64 {
        struct Eval(f64, u32);
        impl KernelTask for Eval {
            type Output = f64;
            fn run<K: Kernel<S>, const S: usize>(self) -> f64 {
                match self.1 {
                    0 => K::k(self.0),
                    1 => K::d1(self.0),
                    _ => K::d2(self.0),
                }
            }
        }
        self.with(Eval(x, deriv))
    }

    /// Offset of the lowest sample for this support (see [`Kernel::LO`]).
    pub fn lo(self) -> i32 {
        let s = self.support() as i32;
        if s % 2 == 0 {
            1 - s / 2
        } else {
            -((s - 1) / 2)
        }
    }
}

impl fmt::Display for KernelName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl FromStr for KernelName {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self, Error> {
        KernelName::ALL
            .into_iter()
            .find(|k| k.as_str().eq_ignore_ascii_case(s))
            .ok_or_else(|| {
                let known: alloc::vec::Vec<&str> =
                    KernelName::ALL.iter().map(|k| k.as_str()).collect();
                Error::new(
                    ErrorKind::Name,
                    alloc::format!("unknown kernel \"{s}\" (known: {})", known.join(", ")),
                )
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The course reference's bspln3 forms, branching on |x| as written there.
    fn bspln3_ref_branching(x: f32) -> (f32, f32) {
        let mut t = x.abs();
        let (k, d) = if t < 1.0 {
            (2.0 / 3.0 + t * t * (-1.0 + t / 2.0), t * (-2.0 + t * 1.5))
        } else if t < 2.0 {
            t -= 1.0;
            (
                1.0 / 6.0 + t * (-0.5 + t * (0.5 - t / 6.0)),
                -0.5 + t * (1.0 - t / 2.0),
            )
        } else {
            (0.0, 0.0)
        };
        (k, if x < 0.0 { -d } else { d })
    }

    #[test]
    fn bspln3_ref_select_form_is_the_branching_form() {
        let check = |x: f32| {
            let (k, d) = bspln3_ref_branching(x);
            assert_eq!(Bspln3::k_ref(x).to_bits(), k.to_bits(), "k({x:e})");
            assert_eq!(Bspln3::d1_ref(x).to_bits(), d.to_bits(), "d1({x:e})");
        };
        // Every float within 4096 ulps of each piece boundary, then a stride through
        // [-3, 3], and the special values.
        for b in [0.0f32, 1.0, 2.0, -1.0, -2.0] {
            for d in 0..4096u32 {
                check(f32::from_bits(b.to_bits().wrapping_add(d)));
                check(f32::from_bits(b.to_bits().wrapping_sub(d)));
            }
        }
        let mut x = -3.0f32;
        while x < 3.0 {
            check(x);
            x += 1.0e-5;
        }
        for x in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -0.0] {
            check(x);
        }
    }

    #[test]
    fn ref_weight_shortcuts_are_k_ref() {
        // The per-position shortcuts (bspln3's and tent's) against the trait's definition
        // (`k_ref` and `d1_ref` at al − (LO + i)), bit for bit: every float of [0, 1)
        // within 2^16 ulps of its ends and of ½, every 97th float in between (about 11
        // M), so every exponent.
        fn general<K: Kernel<S>, const S: usize>(al: f32) -> ([f32; S], [f32; S]) {
            let x = |i: usize| al - (K::LO + i as i32) as f32;
            (
                core::array::from_fn(|i| K::k_ref(x(i))),
                core::array::from_fn(|i| K::d1_ref(x(i))),
            )
        }
        fn check<K: Kernel<S>, const S: usize>(al: f32) {
            let (w, d) = general::<K, S>(al);
            let bits = |a: [f32; S]| a.map(f32::to_bits);
            let name = K::NAME;
            assert_eq!(
                bits(K::ref_weights(al)),
                bits(w),
                "{name:?} weights at {al:e}"
            );
            assert_eq!(
                bits(K::ref_weights_d1(al)),
                bits(d),
                "{name:?} d1 weights at {al:e}"
            );
        }
        let both = |al: f32| {
            check::<Bspln3, 4>(al);
            check::<Tent, 2>(al);
        };
        let one = 1.0f32.to_bits();
        for d in 0..1u32 << 16 {
            both(f32::from_bits(d));
            both(f32::from_bits(one - 1 - d));
            both(f32::from_bits(0.5f32.to_bits() - d));
            both(f32::from_bits(0.5f32.to_bits() + d));
        }
        let mut b = 0u32;
        while b < one {
            both(f32::from_bits(b));
            b += 97;
        }
        both(-0.0);
    }
    #[test]
    fn spec_13_3_values() {
        let e = |k: KernelName, x, d| k.eval(x, d);
        use KernelName::*;
        assert_eq!(e(Box, 0.25, 0), 1.0);
        assert_eq!(e(Box, 0.5, 0), 0.0);
        assert_eq!(e(Box, -0.5, 0), 1.0);
        assert_eq!(e(Tent, 0.25, 0), 0.75);
        assert_eq!(e(Tent, 0.0, 1), -1.0);
        assert_eq!(e(Tent, -1.0, 1), 1.0);
        assert_eq!(e(Tent, 1.0, 1), 0.0);
        assert_eq!(e(Bspln2, 0.25, 0), 0.6875);
        assert_eq!(e(Bspln2, 1.0, 0), 0.125);
        assert_eq!(e(Bspln2, 0.75, 1), -0.75);
        assert!((e(Bspln3, 0.0, 0) - 2.0 / 3.0).abs() < 1e-15);
        assert!((e(Bspln3, 0.3, 0) - 0.590166667).abs() < 1e-8);
        assert!((e(Bspln3, 0.3, 1) + 0.465).abs() < 1e-12);
        assert!((e(Bspln3, 1.5, 0) - 0.0208333333).abs() < 1e-9);
        assert!((e(Bspln3, 0.25, 2) + 1.25).abs() < 1e-12);
        assert_eq!(e(Ctmr, 0.5, 0), 0.5625);
        assert_eq!(e(Ctmr, 0.5, 1), -1.375);
        assert_eq!(e(Ctmr, 0.5, 2), -0.5);
        assert_eq!(e(Ctmr, 1.5, 0), -0.0625);
        assert_eq!(e(Ctmr, 1.5, 1), 0.125);
        assert!((e(C4hexic, 0.0, 0) - 0.8625).abs() < 1e-12);
        assert!((e(C4hexic, 0.5, 0) - 0.560091).abs() < 1e-6);
        assert!((e(C4hexic, 1.0, 0) - 0.0916667).abs() < 1e-6);
        assert!((e(C4hexic, 2.0, 0) + 0.0229167).abs() < 1e-6);
    }

    #[test]
    fn keval_a_order() {
        let w = Bspln3::weights(0.3);
        let want = [0.0571667, 0.590167, 0.348167, 0.0045];
        for (a, b) in w.iter().zip(want) {
            assert!((a - b).abs() < 1e-6, "{w:?}");
        }
    }

    /// The closed-form weights of tent, bspln3 and ctmr equal the piecewise definitions
    /// (to a few f32 ulps).
    #[test]
    fn closed_form_weights_match_definition() {
        fn generic<K: Kernel<S>, const S: usize>(a: f64, d: u32) -> [f32; S] {
            core::array::from_fn(|i| {
                let x = a - (K::LO + i as i32) as f64;
                (if d == 0 { K::k(x) } else { K::d1(x) }) as f32
            })
        }
        fn check<K: Kernel<S>, const S: usize>() {
            for j in 0..1000 {
                let a = j as f64 / 1000.0;
                for (fast, slow) in [
                    (K::weights(a), generic::<K, S>(a, 0)),
                    (K::weights_d1(a), generic::<K, S>(a, 1)),
                ] {
                    for i in 0..S {
                        // Cubic kernels evaluate in f32: within a few ulps of the f64
                        // definition rounded to f32.
                        let tol = 4.0 * f32::EPSILON * slow[i].abs().max(1.0);
                        assert!(
                            (fast[i] - slow[i]).abs() <= tol,
                            "{:?} a={a}: {fast:?} vs {slow:?}",
                            K::NAME
                        );
                    }
                }
            }
        }
        check::<Tent, 2>();
        check::<Bspln3, 4>();
        check::<Ctmr, 4>();
    }

    /// Each table entry's type is the kernel of that name, with the entry's support and
    /// first offset.
    #[test]
    fn table_entries_agree_with_their_types() {
        struct Check(KernelName);
        impl KernelTask for Check {
            type Output = ();
            fn run<K: Kernel<S>, const S: usize>(self) {
                assert_eq!(K::NAME, self.0);
                assert_eq!(S, self.0.support());
                assert_eq!(K::LO, self.0.lo());
            }
        }
        for k in KernelName::ALL {
            k.with(Check(k));
        }
        assert_eq!(
            "nope".parse::<KernelName>().unwrap_err().msg,
            "unknown kernel \"nope\" (known: zero, box, tent, bspln2, bspln3, ctmr, c4hexic)"
        );
    }

    #[test]
    fn names_round_trip() {
        for k in KernelName::ALL {
            assert_eq!(k.as_str().parse::<KernelName>().unwrap(), k);
            assert_eq!(k.title().parse::<KernelName>().unwrap(), k);
            assert_eq!(k.lo(), k.lo());
        }
        assert!("cubic".parse::<KernelName>().is_err());
    }
}
