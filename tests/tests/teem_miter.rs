//! 2-D LUTs against `teem-miter -txf` with the same LUT file: value × gradient
//! magnitude (an arch and a box) and value × κ1 (a surface coloured by curvature), on
//! the CT, bspln3, unlit (`-p rgba`; miter with ambient light 1 only), `over` with early
//! termination at 0.99, both arithmetics.
//!
//! The view keeps every sample well inside the volume (miter pads at the border, we
//! need the kernel's support inside), and miter's right-handed frame (`-rh`) puts its
//! rows in our order. miter samples the same planes in f64 and classifies with the
//! same cell-centred lookup, so only a sample whose quantity lies within rounding of a
//! LUT cell boundary may take the neighbouring entry: the images agree to 1e-3 on
//! average per channel, and almost every pixel to 0.01.

use std::path::Path;

use rnd_core::blend::Blend;
use rnd_core::camera::CameraSpec;
use rnd_core::classify::{LutAxis, Primitive, Quantity, Shape};
use rnd_core::kernel::KernelName;
use rnd_core::probe::Probe;
use rnd_core::render::{RenderParams, RenderSpec};
use rnd_core::txf::Lut;
use rnd_std::nrrd;
use rnd_std::volume_io::load_volume;

fn boxed(x: [f64; 2], y: [f64; 2], rgb: [f64; 3], alpha: f64) -> Primitive {
    Primitive {
        shape: Shape::Box {
            lo: [x[0], y[0]],
            hi: [x[1], y[1]],
        },
        rgb,
        alpha,
    }
}

/// The LUTs compared: a tissue boundary's arch and dense material over v × gm, and
/// the surface v ≥ 400 coloured by the sign of κ1 over v × κ1.
fn luts() -> Vec<(&'static str, Lut)> {
    let v = LutAxis::new(Quantity::Value, 0.0, 2000.0, 200);
    let arch = Primitive {
        shape: Shape::Arch {
            va: 50.0,
            vb: 450.0,
            top: 150.0,
            width: 60.0,
        },
        rgb: [1.0, 0.5, 0.2],
        alpha: 0.3,
    };
    let dense = boxed([500.0, 2000.0], [30.0, 2000.0], [0.9, 0.9, 1.0], 0.5);
    let gm = LutAxis::new(Quantity::GradMag, 0.0, 400.0, 100);
    let k1 = LutAxis::new(Quantity::K1, -0.5, 0.5, 100);
    let s = [400.0, 2000.0];
    vec![
        (
            "v x gm",
            Lut::from_primitives([v, gm], &[arch, dense]).unwrap(),
        ),
        (
            "v x k1",
            Lut::from_primitives(
                [v, k1],
                &[
                    boxed(s, [-1.0, -0.02], [0.2, 0.4, 1.0], 0.6),
                    boxed(s, [-0.02, 0.02], [1.0, 1.0, 1.0], 0.6),
                    boxed(s, [0.02, 1.0], [1.0, 0.3, 0.2], 0.6),
                ],
            )
            .unwrap(),
        ),
    ]
}

fn miter(ct: &Path, txf: &Path, size: u32, out: &Path) -> Vec<f64> {
    let s = size.to_string();
    let args = [
        "-i",
        ct.to_str().unwrap(),
        "-txf",
        txf.to_str().unwrap(),
        "-fr",
        "63.5",
        "-336.5",
        "127.5",
        "-at",
        "63.5",
        "63.5",
        "127.5",
        "-up",
        "0",
        "0",
        "1",
        "-rh",
        "-or",
        "-ar",
        "-dn",
        "-60",
        "-di",
        "0",
        "-df",
        "60",
        "-ur",
        "-60",
        "60",
        "-vr",
        "-60",
        "60",
        "-is",
        &s,
        &s,
        "-k00",
        "bspln3",
        "-k11",
        "bspln3d",
        "-k22",
        "bspln3dd",
        "-step",
        "1",
        "-ref",
        "1",
        "-n1",
        "0.99",
        "-ads",
        "1",
        "0",
        "0",
        "-nt",
        "2",
        "-o",
        out.to_str().unwrap(),
    ];
    rnd_tests::run("teem-miter", &args);
    let img = nrrd::read(out).expect("read teem-miter's image");
    assert_eq!(img.header.sizes, vec![5, size as usize, size as usize]);
    img.data.to_f64()
}

#[test]
fn two_d_luts_match_teem_miter() {
    if !rnd_tests::teem("teem_miter", "teem-miter") {
        return;
    }
    let dir = rnd_tests::tmpdir("teem_miter");
    let Some(ct) = rnd_tests::ct_in_space("teem_miter", &dir) else {
        return;
    };
    let vol = load_volume(&ct).unwrap();
    let size = 96u32;
    let fov = 2.0 * 60f64.atan2(400.0).to_degrees();
    for (name, lut) in luts() {
        let txf = dir.join("txf.nrrd");
        let n = rnd_std::files::lut_to_nrrd(&lut, None).unwrap();
        nrrd::write(&n, &txf, Default::default()).unwrap();
        // The file reads back as the same LUT.
        assert_eq!(rnd_std::files::load_lut(&txf).unwrap(), lut, "{name}");
        let teem = miter(&ct, &txf, size, &dir.join("t.nrrd"));
        for reference in [true, false] {
            let cam = CameraSpec::looking_at([63.5, -336.5, 127.5], [63.5, 63.5, 127.5])
                .up([0.0, 0.0, 1.0])
                .fov(fov)
                .clip(-60.0, 60.0)
                .size(size, size)
                .orthographic(true);
            let mut p = RenderParams::new(cam);
            (
                p.probe,
                p.blend,
                p.plane_sep,
                p.unit_step,
                p.alpha_near1,
                p.reference,
            ) = (Probe::Rgba, Blend::Over, 1.0, 1.0, 0.99, reference);
            let spec = RenderSpec::new(p, Some(&lut), None, &[]).unwrap();
            let ours = rnd_std::parallel::render(&spec, vol.view(), KernelName::Bspln3, 2).unwrap();
            let npx = (size * size) as usize;
            let mut sum = [0.0f64; 4];
            let mut off = 0;
            for i in 0..npx {
                let d: Vec<f64> = (0..4)
                    .map(|c| (f64::from(ours[4 * i + c]) - teem[5 * i + c]).abs())
                    .collect();
                for c in 0..4 {
                    sum[c] += d[c];
                }
                off += usize::from(d.iter().any(|&x| x > 0.01));
            }
            let alpha: f64 = (0..npx).map(|i| teem[5 * i + 3]).sum::<f64>() / npx as f64;
            assert!(
                alpha > 0.1,
                "{name}: miter's image is almost empty ({alpha})"
            );
            for (c, s) in sum.iter().enumerate() {
                let mean = s / npx as f64;
                assert!(
                    mean < 1e-3,
                    "{name} -ref {reference} channel {c}: mean |diff| {mean}"
                );
            }
            assert!(
                off * 100 <= npx,
                "{name} -ref {reference}: {off} of {npx} pixels differ by > 0.01"
            );
        }
    }
}
