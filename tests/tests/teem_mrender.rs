//! The ray measures (`-b max min sum mean l2 variance sd median`) against
//! `teem-mrender -m max min sum mean L2 variance stdv median`: same volume, same camera,
//! same sampling planes, value probe, with both arithmetics.
//!
//! Where the two programs sample alike: mrender (hoover + gage) counts a sample when its
//! position is inside the volume's bounds and probes it with padding, while our inside
//! rule needs the kernel's whole support inside. So the views below keep every ray, near
//! to far, well inside the volume, where both count the same samples. mrender's image
//! rows run upwards (v increases with the up vector) and ours downwards: its image is
//! compared flipped. mrender computes in f64 from f64 samples, we in f32 (l2, variance
//! and sd in f64 from f32 samples), so the bound is relative to the image's largest value or the volume's (whichever is
//! larger: a sample's f32 error is relative to the volume's values).

use std::path::Path;

use rnd_core::blend::Blend;
use rnd_core::camera::CameraSpec;
use rnd_core::kernel::KernelName;
use rnd_core::probe::Probe;
use rnd_core::render::{RenderParams, RenderSpec};
use rnd_std::nrrd;
use rnd_std::volume_io::load_volume;

/// teem-mrender's name for each measure.
const MEASURES: [(Blend, &str); 8] = [
    (Blend::Max, "max"),
    (Blend::Min, "min"),
    (Blend::Sum, "sum"),
    (Blend::Mean, "mean"),
    (Blend::L2, "L2"),
    (Blend::Variance, "variance"),
    (Blend::Sd, "stdv"),
    (Blend::Median, "median"),
];

/// A view: look-from, look-at, near/far relative to look-at, fov, size, orthographic.
struct View {
    from: [f64; 3],
    at: [f64; 3],
    near: f64,
    far: f64,
    fov: f64,
    size: [u32; 2],
    ortho: bool,
    step: f64,
}

/// What is probed and how it is compared.
struct Probing<'c> {
    probe: Probe,
    /// gage's name of the quantity.
    query: &'c str,
    kernels: &'c [KernelName],
    measures: &'c [(Blend, &'c str)],
    /// The curvatures' gradient threshold (`-gmc`).
    gmc: f64,
    /// The bound, relative to the image's (or for values the volume's) largest value.
    rel: f64,
}

fn mrender(
    vol: &Path,
    v: &View,
    kernel: &str,
    pr: &Probing<'_>,
    measure: &str,
    out: &Path,
) -> Vec<f64> {
    let f = |x: &[f64]| x.iter().map(|c| c.to_string()).collect::<Vec<_>>();
    let mut args: Vec<String> = vec!["-i".into(), vol.to_str().unwrap().into()];
    args.extend(["-k", "scalar", "-fr"].map(String::from));
    args.extend(f(&v.from));
    args.push("-at".into());
    args.extend(f(&v.at));
    args.extend(["-up", "0", "0", "1", "-ar", "-di", "0"].map(String::from));
    args.extend([
        "-dn".into(),
        v.near.to_string(),
        "-df".into(),
        v.far.to_string(),
    ]);
    args.extend(["-fv".into(), v.fov.to_string()]);
    args.extend(["-is".into(), v.size[0].to_string(), v.size[1].to_string()]);
    if v.ortho {
        args.push("-or".into());
    }
    args.extend([
        "-k00".into(),
        kernel.into(),
        "-k11".into(),
        format!("{kernel}d"),
    ]);
    // (Teem has no second derivative of tent; the value probes do not use it.)
    let k22 = match kernel {
        "tent" => "zero".to_string(),
        k => format!("{k}dd"),
    };
    args.extend(["-k22".into(), k22, "-gmc".into(), pr.gmc.to_string()]);
    args.extend(["-q", pr.query, "-m", measure, "-step"].map(String::from));
    args.push(v.step.to_string());
    args.extend(["-o".into(), out.to_str().unwrap().into()]);
    let a: Vec<&str> = args.iter().map(String::as_str).collect();
    rnd_tests::run("teem-mrender", &a);
    let img = nrrd::read(out).unwrap();
    assert_eq!(
        img.header.sizes,
        vec![v.size[0] as usize, v.size[1] as usize]
    );
    img.data.to_f64()
}

fn check(name: &str, file: &Path, views: &[View], pr: &Probing<'_>, dir: &Path) {
    let vol = load_volume(file).unwrap();
    let (lo, hi) = vol.min_max();
    // The samples' magnitude: f32 reconstruction errors are relative to it.
    let vmax = lo.abs().max(hi.abs());
    for (vi, v) in views.iter().enumerate() {
        for &kernel in pr.kernels {
            for &(blend, m) in pr.measures {
                let teem = mrender(file, v, kernel.as_str(), pr, m, &dir.join("mr.nrrd"));
                let [w, h] = v.size.map(|x| x as usize);
                let scale = teem.iter().fold(0.0f64, |a, x| a.max(x.abs()));
                // A sample's error δ moves the variance by up to about 2·sd·δ.
                let tol = pr.rel
                    * match (pr.probe, blend) {
                        (Probe::Value, Blend::Variance) => scale.max(vmax * scale.sqrt()),
                        (Probe::Value, _) => scale.max(vmax),
                        _ => scale,
                    };
                // (Every CT ray crosses air, so its tent minimum is 0 everywhere.)
                assert!(
                    scale > 0.0 || blend == Blend::Min,
                    "{name} view {vi} {kernel} {m}: Teem's image is all 0"
                );
                for reference in [true, false] {
                    let cam = CameraSpec::looking_at(v.from, v.at)
                        .up([0.0, 0.0, 1.0])
                        .fov(v.fov)
                        .clip(v.near, v.far)
                        .size(v.size[0], v.size[1])
                        .orthographic(v.ortho);
                    let mut p = RenderParams::new(cam);
                    (p.probe, p.blend, p.plane_sep, p.reference) =
                        (pr.probe, blend, v.step, reference);
                    p.curv_min_grad = pr.gmc;
                    let spec = RenderSpec::new(p, None, None, &[]).unwrap();
                    let ours = rnd_std::parallel::render(&spec, vol.view(), kernel, 2).unwrap();
                    assert_eq!(ours.len(), w * h);
                    for y in 0..h {
                        for x in 0..w {
                            let (o, t) = (ours[x + w * y] as f64, teem[x + w * (h - 1 - y)]);
                            assert!(
                                (o - t).abs() <= tol,
                                "{name} view {vi} {kernel} {} {blend} (ref {reference}) pixel \
                                 ({x}, {y}): ours {o}, teem-mrender -q {} -m {m} {t} (scale \
                                 {scale})",
                                pr.probe,
                                pr.query
                            );
                        }
                    }
                }
            }
        }
    }
}

#[test]
fn measures_agree_with_mrender() {
    if !rnd_tests::teem("measures_agree_with_mrender", "teem-mrender") {
        return;
    }
    let dir = rnd_tests::tmpdir("mrender");
    // 1. The bundled head MRI (2×2×3 mm, permuted axes with a flip): views along world y
    //    from the centre of its bounding box, every ray inside it.
    let head = rnd_tests::root().join("data/itk-t1-head.nrrd");
    let hv = load_volume(&head).unwrap();
    let corners = hv.view().world_corners();
    let lo: [f64; 3] =
        std::array::from_fn(|a| corners.iter().map(|c| c[a]).fold(f64::MAX, f64::min));
    let hi: [f64; 3] =
        std::array::from_fn(|a| corners.iter().map(|c| c[a]).fold(f64::MIN, f64::max));
    let at: [f64; 3] = std::array::from_fn(|a| 0.5 * (lo[a] + hi[a]));
    let half: [f64; 3] = std::array::from_fn(|a| 0.5 * (hi[a] - lo[a]));
    let d = 400.0;
    let from = [at[0], at[1] - d, at[2]];
    // Image half-height within 70% of the box on x and z (square image), rays from
    // −60% to +60% of its depth.
    let h_ortho = 0.7 * half[0].min(half[2]);
    let views = [
        View {
            from,
            at,
            near: -0.6 * half[1],
            far: 0.6 * half[1] + 0.013,
            fov: 2.0 * (h_ortho / d).atan().to_degrees(),
            size: [36, 36],
            ortho: true,
            step: 0.9,
        },
        View {
            from,
            at,
            near: -0.6 * half[1],
            far: 0.6 * half[1] + 0.013,
            // The far plane is the widest part of a perspective view.
            fov: 2.0 * (h_ortho / (d + 0.6 * half[1])).atan().to_degrees(),
            size: [36, 36],
            ortho: false,
            step: 0.9,
        },
    ];
    let values = Probing {
        probe: Probe::Value,
        query: "v",
        kernels: &[KernelName::Tent, KernelName::Bspln3],
        measures: &MEASURES,
        gmc: 0.0,
        rel: 2e-5,
    };
    check("head", &head, &views, &values, &dir);
    // 2. The CT (index space; given identity space directions for gage).
    if let Some(ct) = rnd_tests::ct_in_space("measures_agree_with_mrender (CT part)", &dir) {
        let (from, at) = ([63.5, -236.5, 127.5], [63.5, 63.5, 127.5]);
        let views = [
            View {
                from,
                at,
                near: -40.25,
                far: 40.1,
                fov: 20.0,
                size: [48, 40],
                ortho: true,
                step: 0.7,
            },
            View {
                from,
                at,
                near: -40.25,
                far: 40.1,
                fov: 14.0,
                size: [40, 40],
                ortho: false,
                step: 0.7,
            },
        ];
        check("stent-ct", &ct, &views, &values, &dir);
    }
}

/// The curvature probes (`-p k1 k2 meancurv gausscurv`) against mrender's `-q k1 k2
/// meancurv gausscurv` on the CT, ray mean and maximum. Curvature is 1/|∇f| times
/// second derivatives, so where the gradient nearly vanishes it is ill-conditioned and
/// gage's f32 sums part from our f64 ones: both programs take it as 0 below the same
/// threshold (`-gmc 50`, a few percent of the CT's typical edge gradients).
#[test]
fn curvature_probes_agree_with_mrender() {
    if !rnd_tests::teem("curvature_probes_agree_with_mrender", "teem-mrender") {
        return;
    }
    let dir = rnd_tests::tmpdir("mrender-curv");
    let Some(ct) = rnd_tests::ct_in_space("curvature_probes_agree_with_mrender", &dir) else {
        return;
    };
    let (from, at) = ([63.5, -236.5, 127.5], [63.5, 63.5, 127.5]);
    let views = [
        View {
            from,
            at,
            near: -40.25,
            far: 40.1,
            fov: 20.0,
            size: [40, 40],
            ortho: true,
            step: 0.7,
        },
        View {
            from,
            at,
            near: -30.25,
            far: 30.1,
            fov: 16.0,
            size: [32, 32],
            ortho: false,
            step: 0.9,
        },
    ];
    for (probe, query) in [
        (Probe::K1, "k1"),
        (Probe::K2, "k2"),
        (Probe::MeanCurv, "meancurv"),
        (Probe::GaussCurv, "gausscurv"),
    ] {
        let pr = Probing {
            probe,
            query,
            kernels: &[KernelName::Bspln3, KernelName::C4hexic],
            measures: &[(Blend::Mean, "mean"), (Blend::Max, "max")],
            gmc: 50.0,
            rel: 5e-4,
        };
        check("stent-ct", &ct, &views, &pr, &dir);
    }
}

/// 2-D LUTs against teem-miter (in this test binary, so that CI builds one fewer).
mod miter {
    // 2-D LUTs against `teem-miter -txf` with the same LUT file: value × gradient
    // magnitude (an arch and a box) and value × κ1 (a surface coloured by curvature), on
    // the CT, bspln3, unlit (`-p rgba`; miter with ambient light 1 only), `over` with early
    // termination at 0.99, both arithmetics.
    //
    // The view keeps every sample well inside the volume (miter pads at the border, we
    // need the kernel's support inside), and miter's right-handed frame (`-rh`) puts its
    // rows in our order. miter samples the same planes in f64 and classifies with the
    // same cell-centred lookup, so only a sample whose quantity lies within rounding of a
    // LUT cell boundary may take the neighbouring entry: the images agree to 1e-3 on
    // average per channel, and almost every pixel to 0.01.

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
                let ours =
                    rnd_std::parallel::render(&spec, vol.view(), KernelName::Bspln3, 2).unwrap();
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
}
