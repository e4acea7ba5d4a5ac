//! Property tests of the core: affine inverse, kernels, exact reconstruction of linear
//! functions (zramp), fast vs naive convolution.

use proptest::prelude::*;
use rnd_core::affine::Affine4;
use rnd_core::convo::Convo;
use rnd_core::kernel::{Kernel, KernelName};
use rnd_core::render::{dispatch, AnyVolume, ConvoTask};
use rnd_core::sdg::{self, Grid};
use rnd_core::volume::Volume;
use rnd_core::voxel::Voxel;
use rnd_tests::naive_convo;

fn well_conditioned() -> impl Strategy<Value = Affine4> {
    (
        prop::array::uniform9(-2.0f64..2.0),
        prop::array::uniform3(-100.0f64..100.0),
    )
        .prop_filter_map("well conditioned", |(m, t)| {
            // Add a multiple of the identity to keep it far from singular.
            let a = Affine4::from_columns(
                [m[0] + 3.0, m[1], m[2]],
                [m[3], m[4] + 3.0, m[5]],
                [m[6], m[7], m[8] + 3.0],
                t,
            );
            (a.det3().abs() > 1.0).then_some(a)
        })
}

proptest! {
    #[test]
    fn affine_inverse_round_trip(a in well_conditioned()) {
        let i = a.affine_inverse().unwrap();
        // Rounding bounds scale with the norms involved: a product's error is at most a
        // few ulps of |A| |A^-1|, and inverting twice loses up to cond(A) = |A| |A^-1|
        // relative accuracy. (A fixed 1e-12 failed on a translation of 98 whose inverse
        // has norm 1689: the residual was 1.06e-12, well inside 8 eps |A| |A^-1|.)
        let norm = |m: &Affine4| m.m.iter().map(|x| x * x).sum::<f64>().sqrt();
        let cond = norm(&a) * norm(&i);
        let tol = 8.0 * f64::EPSILON * cond;
        let ai = a.mul(&i).frobenius_from_identity();
        let ia = i.mul(&a).frobenius_from_identity();
        prop_assert!(ai < tol, "|A A^-1 - I| = {ai:e}, bound {tol:e}");
        prop_assert!(ia < tol, "|A^-1 A - I| = {ia:e}, bound {tol:e}");
        let ii = i.affine_inverse().unwrap();
        for (x, y) in ii.m.iter().zip(a.m.iter()) {
            prop_assert!((x - y).abs() < tol * norm(&a), "{x} vs {y}");
        }
    }

    #[test]
    fn kernel_partition_of_unity(alpha in 0.0f64..1.0, ki in 1usize..7) {
        let k = KernelName::ALL[ki];
        // For odd support the fraction lies in [-0.5, 0.5).
        let a = if k.support() % 2 == 1 { alpha - 0.5 } else { alpha };
        let lo = k.lo();
        let s = k.support() as i32;
        let sum: f64 = (0..s).map(|i| k.eval(a - (lo + i) as f64, 0)).sum();
        prop_assert!((sum - 1.0).abs() < 1e-12, "{k}: {sum}");
        let d: f64 = (0..s).map(|i| k.eval(a - (lo + i) as f64, 1)).sum();
        prop_assert!(d.abs() < 1e-12, "{k}' sums to {d}");
        let d2: f64 = (0..s).map(|i| k.eval(a - (lo + i) as f64, 2)).sum();
        prop_assert!(d2.abs() < 1e-10, "{k}'' sums to {d2}");
    }

    #[test]
    fn kernel_derivatives_match_finite_differences(x in -3.5f64..3.5, ki in 2usize..7) {
        let k = KernelName::ALL[ki];
        let h = 1e-6;
        // Stay away from the piece boundaries, where the derivative may jump.
        let near_knot = (0..=8).any(|j| (x.abs() - j as f64 * 0.5).abs() < 1e-4);
        prop_assume!(!near_knot);
        let fd = (k.eval(x + h, 0) - k.eval(x - h, 0)) / (2.0 * h);
        prop_assert!((fd - k.eval(x, 1)).abs() < 1e-5, "{k}'({x}): {} vs fd {fd}", k.eval(x, 1));
        let fd2 = (k.eval(x + h, 1) - k.eval(x - h, 1)) / (2.0 * h);
        if k != KernelName::Tent {
            prop_assert!((fd2 - k.eval(x, 2)).abs() < 1e-4, "{k}''({x})");
        }
    }

    #[test]
    fn kernels_vanish_outside_support(t in 0.0f64..10.0, ki in 0usize..7, neg in any::<bool>()) {
        let k = KernelName::ALL[ki];
        let half = k.support() as f64 / 2.0;
        let x = if neg { -(half + t) } else { half + t };
        // box is half-open: box(-0.5) = 1.
        prop_assume!(!(k == KernelName::Box && x == -0.5));
        for d in 0..3 {
            prop_assert_eq!(k.eval(x, d), 0.0, "{}^({}) at {}", k, d, x);
        }
    }
}

#[test]
fn box_is_half_open() {
    assert_eq!(KernelName::Box.eval(-0.5, 0), 1.0);
    assert_eq!(KernelName::Box.eval(0.5, 0), 0.0);
}

/// Evaluates a convolution through the real dispatch.
struct At(pub [f64; 3]);
impl ConvoTask for At {
    type Output = rnd_core::convo::ConvoSample;
    fn run<V: Voxel, K: Kernel<S>, const S: usize>(self, vol: Volume<'_, V>) -> Self::Output {
        Convo::<V, K, S>::new(vol).eval_world(self.0, true)
    }
}

/// Float round-off bound for a world gradient: f32 epsilon times the support, the data
/// magnitude and 1/(smallest spacing) (index-space derivatives are divided by spacing).
fn grad_tol(grid: &Grid, vals: &[f64], k: KernelName) -> f32 {
    let maxabs = vals.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let hmin = (0..3)
        .map(|a| grid.lengths[a] / grid.sizes[a] as f64)
        .fold(f64::INFINITY, f64::min);
    (16.0 * f32::EPSILON as f64 * k.support() as f64 * (1.0 + maxabs) / hmin) as f32
}

fn grid_strategy() -> impl Strategy<Value = Grid> {
    (
        prop::array::uniform3(8usize..16),
        prop::array::uniform3(1.0f64..6.0),
        prop::array::uniform3(-0.3f64..0.3),
        prop::array::uniform3(-1.0f64..1.0),
        prop::array::uniform3(-1.0f64..1.0),
    )
        .prop_map(|(sizes, lengths, shear, rot, centre)| Grid {
            sizes,
            lengths,
            shear,
            rot,
            centre,
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, .. ProptestConfig::default() })]

    /// Every kernel but box reproduces f = -z and its gradient (0,0,-1), on float and on
    /// short volumes (scaled by sval/fval = 2500 as `-vs 4 10000`).
    #[test]
    fn zramp_exact(grid in grid_strategy(), u in prop::array::uniform3(0.0f64..1.0), ki in 2usize..7) {
        let k = KernelName::ALL[ki];
        let (vals, itow) = sdg::generate(0, &grid).unwrap();
        let f32s: Vec<f32> = vals.iter().map(|&v| v as f32).collect();
        let i16s: Vec<i16> = vals.iter().map(|&v| (v * 10000.0 / 4.0).round() as i16).collect();
        // A point well inside: index coordinates within the kernel's reach.
        let s = k.support() as f64;
        let pi: [f64; 3] = std::array::from_fn(|a| s / 2.0 + u[a] * (grid.sizes[a] as f64 - 1.0 - s));
        let pw = itow.point(pi);
        let fv = Volume::new(&f32s, grid.sizes, itow).unwrap();
        let r = dispatch(AnyVolume::F32(fv), k, At(pw));
        prop_assert!(r.inside);
        let scale = 1.0 + pw[2].abs();
        prop_assert!((r.value as f64 + pw[2]).abs() < 2e-5 * scale, "{k}: {} vs {}", r.value, -pw[2]);
        let g = r.grad_w;
        let gt = grad_tol(&grid, &vals, k);
        prop_assert!(g[0].abs() < gt && g[1].abs() < gt && (g[2] + 1.0).abs() < gt, "{k}: {g:?} tol {gt}");
        // Short data: the stored values are rounded to integers, so the reconstruction
        // is exact up to that rounding (0.5 / 2500 in f units).
        let sv = Volume::new(&i16s, grid.sizes, itow).unwrap();
        let r = dispatch(AnyVolume::I16(sv), k, At(pw));
        prop_assert!(r.inside);
        prop_assert!((r.value as f64 / 2500.0 + pw[2]).abs() < 1e-3, "{k} short: {}", r.value);
        let g = r.grad_w;
        prop_assert!((g[2] as f64 / 2500.0 + 1.0).abs() < 0.02, "{k} short grad {g:?}");
    }

    /// The fast separable convolution agrees with the naive per-voxel one.
    #[test]
    fn fast_matches_naive(grid in grid_strategy(), u in prop::array::uniform3(-0.2f64..1.2), ki in 0usize..7, which in prop::sample::select(vec![1u32, 2, 9, 10, 12])) {
        let k = KernelName::ALL[ki];
        let (vals, itow) = sdg::generate(which, &grid).unwrap();
        let f32s: Vec<f32> = vals.iter().map(|&v| v as f32).collect();
        let vol = Volume::new(&f32s, grid.sizes, itow).unwrap();
        let pi: [f64; 3] = std::array::from_fn(|a| u[a] * (grid.sizes[a] as f64 - 1.0));
        let pw = itow.point(pi);
        let fast = dispatch(AnyVolume::F32(vol), k, At(pw));
        let (inside, v, g) = naive_convo(&vol, k, pw);
        prop_assert_eq!(fast.inside, inside);
        if inside {
            let mag = vals.iter().fold(0.0f64, |m, v| m.max(v.abs())) + 1.0;
            prop_assert!((fast.value as f64 - v).abs() < 1e-5 * mag, "{k}: {} vs {v}", fast.value);
            let gm = 1e-4 * mag * (1.0 + g.iter().fold(0.0f64, |m, x| m.max(x.abs())));
            for a in 0..3 {
                prop_assert!((fast.grad_w[a] as f64 - g[a]).abs() < gm, "{k} grad {:?} vs {g:?}", fast.grad_w);
            }
        }
    }

    /// bspln3 and ctmr reproduce a linear function of all three coordinates exactly;
    /// c4hexic, tent and bspln2 too (all reproduce linears); ctmr also reproduces
    /// quadratics exactly, bspln3 only up to a constant bias of h^2/3 * f''/2.
    #[test]
    fn linear_reproduction(grid in grid_strategy(), u in prop::array::uniform3(0.0f64..1.0), ki in 2usize..7) {
        let k = KernelName::ALL[ki];
        let (vals, itow) = sdg::generate(3, &grid).unwrap(); // f = x
        let f32s: Vec<f32> = vals.iter().map(|&v| v as f32).collect();
        let vol = Volume::new(&f32s, grid.sizes, itow).unwrap();
        let s = k.support() as f64;
        let pi: [f64; 3] = std::array::from_fn(|a| s / 2.0 + u[a] * (grid.sizes[a] as f64 - 1.0 - s));
        let pw = itow.point(pi);
        let r = dispatch(AnyVolume::F32(vol), k, At(pw));
        prop_assert!(r.inside);
        prop_assert!((r.value as f64 - pw[0]).abs() < 2e-5 * (1.0 + pw[0].abs()));
        let gt = grad_tol(&grid, &vals, k);
        prop_assert!((r.grad_w[0] - 1.0).abs() < gt && r.grad_w[1].abs() < gt && r.grad_w[2].abs() < gt, "{:?}", r.grad_w);
    }
}

/// Quadratic reproduction in index space: ctmr and c4hexic reproduce i^2 exactly (their
/// second moments sum_i i^2 K(i) vanish: for c4hexic 2(K(1) + 4 K(2)) = 0), while
/// bspln3 has the known constant bias +1/3 (its second moment) and bspln2 +1/4.
#[test]
fn quadratic_reproduction_and_bias() {
    let n = 16;
    let data: Vec<f32> = (0..n * n * n).map(|i| ((i % n) as f32).powi(2)).collect();
    let vol = Volume::new(&data, [n, n, n], Affine4::IDENTITY).unwrap();
    for x in [5.0, 5.25, 7.5, 8.9] {
        let p = [x, 7.0, 7.0];
        let want = x * x;
        let ctmr = dispatch(AnyVolume::F32(vol), KernelName::Ctmr, At(p)).value as f64;
        assert!((ctmr - want).abs() < 1e-4, "ctmr({x}) = {ctmr}");
        let b3 = dispatch(AnyVolume::F32(vol), KernelName::Bspln3, At(p)).value as f64;
        assert!((b3 - want - 1.0 / 3.0).abs() < 1e-4, "bspln3({x}) = {b3}");
        let c4 = dispatch(AnyVolume::F32(vol), KernelName::C4hexic, At(p)).value as f64;
        assert!((c4 - want).abs() < 1e-4, "c4hexic({x}) = {c4}");
        let b2 = dispatch(AnyVolume::F32(vol), KernelName::Bspln2, At(p)).value as f64;
        assert!((b2 - want - 0.25).abs() < 1e-4, "bspln2({x}) = {b2}");
    }
}

/// The inside rule at the exact borders (SPEC §7.2): tent needs floor(x) and
/// floor(x)+1, so x = size-1 is outside; box needs round-half-up(x) in range.
#[test]
fn inside_rule_at_borders() {
    let n = 8usize;
    let data = vec![1.0f32; n * n * n];
    let vol = Volume::new(&data, [n, n, n], Affine4::IDENTITY).unwrap();
    let inside = |k: KernelName, x: f64| dispatch(AnyVolume::F32(vol), k, At([x, 3.0, 3.0])).inside;
    let last = (n - 1) as f64;
    assert!(inside(KernelName::Tent, 0.0));
    assert!(!inside(KernelName::Tent, last));
    assert!(inside(KernelName::Tent, last - 1e-9));
    assert!(!inside(KernelName::Tent, -1e-9));
    assert!(inside(KernelName::Box, -0.5));
    assert!(!inside(KernelName::Box, -0.5 - 1e-9));
    assert!(inside(KernelName::Box, last + 0.5 - 1e-9));
    assert!(!inside(KernelName::Box, last + 0.5));
    // bspln2 (odd, S = 3): needs round(x) - 1 .. round(x) + 1.
    assert!(inside(KernelName::Bspln2, 0.5));
    assert!(!inside(KernelName::Bspln2, 0.5 - 1e-9));
    assert!(inside(KernelName::Bspln2, last - 0.5 - 1e-9));
    assert!(!inside(KernelName::Bspln2, last - 0.5));
    // bspln3/ctmr (S = 4): floor(x) - 1 .. floor(x) + 2.
    for k in [KernelName::Bspln3, KernelName::Ctmr] {
        assert!(inside(k, 1.0));
        assert!(!inside(k, 1.0 - 1e-9));
        assert!(inside(k, last - 2.0 + 0.999));
        assert!(!inside(k, last - 1.0));
    }
    // c4hexic (S = 6): floor(x) - 2 .. floor(x) + 3.
    assert!(inside(KernelName::C4hexic, 2.0));
    assert!(!inside(KernelName::C4hexic, 1.999));
    assert!(!inside(KernelName::C4hexic, last - 2.0));
    // Non-finite positions are outside, not a panic.
    assert!(!inside(KernelName::Tent, f64::NAN));
    assert!(!inside(KernelName::Tent, f64::INFINITY));
}

#[test]
fn names_round_trip() {
    use rnd_core::blend::Blend;
    use rnd_core::probe::Probe;
    for k in KernelName::ALL {
        assert_eq!(k.to_string().parse::<KernelName>().unwrap(), k);
        assert_eq!(
            k.to_string().to_uppercase().parse::<KernelName>().unwrap(),
            k
        );
    }
    for p in Probe::ALL {
        assert_eq!(p.to_string().parse::<Probe>().unwrap(), p);
        for a in p.aliases() {
            assert_eq!(a.parse::<Probe>().unwrap(), p);
        }
    }
    for b in Blend::ALL {
        assert_eq!(b.to_string().parse::<Blend>().unwrap(), b);
    }
    assert!("cubic".parse::<KernelName>().is_err());
    assert!("value2".parse::<Probe>().is_err());
    assert!("mode".parse::<Blend>().is_err());
    assert_eq!("STDV".parse::<Blend>().unwrap(), Blend::Sd);
}
