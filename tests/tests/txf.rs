//! Transfer functions: the seed's `lgen` cases and properties of LUTs and Levoy opacity.

use proptest::prelude::*;
use rnd_core::txf::{Levoy, Lut, Txf, TxfSpace};

fn txf(space: TxfSpace, rows: &[&[f64]]) -> Txf {
    Txf::new(space, rows).unwrap()
}

/// The seed's five `lgen` runs, for the RGB and the HSV colour maps, with the seed's
/// stated relations between them.
#[test]
fn seed_lgen_cases() {
    let atxf = txf(TxfSpace::Alpha, &[&[0.0, 0.0], &[1.0, 1.0]]);
    let rgb = txf(
        TxfSpace::Rgb,
        &[&[0.0, 0.0, 1.0, 0.0], &[1.0, 1.0, 0.0, 1.0]],
    );
    let hsv = txf(
        TxfSpace::Hsv,
        &[
            &[0.0, 0.0, 1.0, 1.0],
            &[0.33, 0.33, 1.0, 1.0],
            &[0.66, 0.66, 1.0, 1.0],
            &[1.0, 1.0, 1.0, 1.0],
        ],
    );
    for ctxf in [&rgb, &hsv] {
        let g = |lo, hi, crs, ars| {
            Lut::generate(Some(ctxf), Some(&atxf), crs, ars, 512, lo, hi).unwrap()
        };
        let lut0 = g(0.0, 1.0, false, false);
        let lut1 = g(-2.0, 3.0, true, true);
        let lut2 = g(-2.0, 3.0, false, true);
        let lut3 = g(-2.0, 3.0, true, false);
        let lut4 = g(-2.0, 3.0, false, false);
        // lut-0 and lut-1: same contents, different domain metadata.
        assert_eq!(lut0.entries(), lut1.entries());
        assert_ne!((lut0.vmin(), lut0.vmax()), (lut1.vmin(), lut1.vmax()));
        let alpha = |l: &Lut| l.entries().iter().map(|e| e[3]).collect::<Vec<_>>();
        let colour = |l: &Lut| {
            l.entries()
                .iter()
                .map(|e| [e[0], e[1], e[2]])
                .collect::<Vec<_>>()
        };
        // lut-2 vs lut-1: same opacities, different colours.
        assert_eq!(alpha(&lut2), alpha(&lut1));
        assert_ne!(colour(&lut2), colour(&lut1));
        // lut-3 vs lut-1: same colours, different opacities.
        assert_eq!(colour(&lut3), colour(&lut1));
        assert_ne!(alpha(&lut3), alpha(&lut1));
        // lut-4: the variation is compressed into the middle fifth ([0,1] of [-2,3]):
        // constant below entry 512*2/5, constant above 512*3/5, lut-1's ends there.
        let a4 = alpha(&lut4);
        let c4 = colour(&lut4);
        let (i0, i1) = (204, 308);
        assert!(a4[..i0].iter().all(|&a| a == 0.0) && a4[i1..].iter().all(|&a| a == 1.0));
        assert!(c4[..i0].iter().all(|c| *c == c4[0]) && c4[i1..].iter().all(|c| *c == c4[511]));
        // Below the txf's domain the colour is clamped to the first control point.
        let first = ctxf.eval(-2.0);
        assert!((0..3).all(|c| (c4[0][c] as f64 - first[c]).abs() < 1e-6));
        // In the middle lut-4 follows the txf itself.
        for i in (i0 + 2..i1 - 2).step_by(7) {
            let v = -2.0 + 5.0 * (i as f64 + 0.5) / 512.0;
            let want = ctxf.eval(v);
            for c in 0..3 {
                assert!((c4[i][c] as f64 - want[c]).abs() < 1e-6);
            }
            assert!((a4[i] as f64 - v).abs() < 1e-6);
        }
    }
    // HSV end colours: hue 0 and hue 1 are both red; the middle passes through green
    // (hue 1/3) and blue (hue 2/3).
    let l = Lut::generate(Some(&hsv), None, false, false, 300, 0.0, 1.0).unwrap();
    let e = l.entries();
    assert!(e[0][0] > 0.99 && e[0][1] < 0.05 && e[299][0] > 0.99);
    assert!(e[100][1] > 0.95 && e[100][0] < 0.1);
    assert!(e[199][2] > 0.95 && e[199][1] < 0.1);
}

proptest! {
    /// A LUT built with rescale over the txf's own domain, looked up at a control point's
    /// position, returns that point's value (to the LUT's resolution).
    #[test]
    fn rescaled_lut_hits_control_points(
        xs in prop::collection::btree_set(-1000i32..1000, 2..6),
        vals in prop::collection::vec(0.0f64..1.0, 6),
        len in 64usize..2048,
    ) {
        let xs: Vec<f64> = xs.into_iter().map(|x| x as f64 / 10.0).collect();
        let rows: Vec<Vec<f64>> = xs.iter().zip(&vals).map(|(&x, &a)| vec![x, a]).collect();
        let refs: Vec<&[f64]> = rows.iter().map(Vec::as_slice).collect();
        let t = Txf::new(TxfSpace::Alpha, &refs).unwrap();
        let (lo, hi) = t.domain();
        // The LUT's own domain is unrelated; rescaling maps the txf domain onto it.
        let lut = Lut::generate(None, Some(&t), false, true, len, 5.0, 7.0).unwrap();
        for (i, &x) in xs.iter().enumerate() {
            let v = 5.0 + 2.0 * (x - lo) / (hi - lo);
            let got = lut.lookup(v as f32)[3] as f64;
            // One LUT cell away from x the txf changes by at most slope * cell width.
            let cell = (hi - lo) / len as f64;
            let slope = rows.windows(2).map(|w| ((w[1][1] - w[0][1]) / (w[1][0] - w[0][0])).abs()).fold(0.0, f64::max);
            prop_assert!((got - vals[i]).abs() <= slope * cell + 1e-6, "x {x}: {got} vs {}", vals[i]);
        }
    }

    /// Levoy opacity: a at f = v, linear fall-off to 0 at |f - v| = r |g|; the band is
    /// r |g| wide in value, so r in space whatever |g| is.
    #[test]
    fn levoy_profile(v in -10.0f32..10.0, r in 0.01f32..2.0, a in 0.0f32..1.0, g in 0.01f32..100.0, t in 0.0f32..1.5) {
        let l = Levoy::new(vec![[v, r, a]]).unwrap();
        prop_assert!((l.opacity(v, g) - a).abs() < 1e-6);
        let f = v + t * r * g;
        let want = if t < 1.0 { a * (1.0 - t) } else { 0.0 };
        prop_assert!((l.opacity(f, g) - want).abs() < 1e-4, "t {t}");
        // Constant spatial thickness: for f(x) = v + g x, opacity as a function of the
        // spatial offset x = t r is independent of g.
        let g2 = g * 3.0;
        prop_assert!((l.opacity(v + t * r * g2, g2) - want).abs() < 1e-4);
    }
}

#[test]
fn bad_txfs_and_luts() {
    assert!(Txf::new(TxfSpace::Alpha, &[&[0.0, 1.0], &[0.0, 0.5]])
        .unwrap_err()
        .msg
        .contains("strictly increasing"));
    assert!(Txf::new(TxfSpace::Rgb, &[&[0.0, 1.0]])
        .unwrap_err()
        .msg
        .contains("columns"));
    assert!(Txf::new(TxfSpace::Alpha, &[&[0.0, f64::NAN]])
        .unwrap_err()
        .msg
        .contains("non-finite"));
    assert!(Lut::new(1.0, 1.0, vec![[0.0; 4]]).is_err());
    assert!(Lut::generate(None, None, false, false, 4, 2.0, 1.0).is_err());
    assert!(Lut::generate(None, None, true, false, 4, 0.0, 1.0).is_err());
    assert!(Levoy::new(vec![[0.5, 0.0, 1.0]]).is_err());
    assert!("cmyk".parse::<TxfSpace>().is_err());
}
