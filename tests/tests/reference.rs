//! Reproduces the reference program's outputs in `../shared/rendr-data/`.

use std::path::Path;

use rnd_core::blend::Blend;
use rnd_core::camera::CameraSpec;
use rnd_core::kernel::KernelName;
use rnd_core::probe::Probe;
use rnd_core::render::{RenderParams, RenderSpec, SampleInfo};
use rnd_core::txf::Lut;
use rnd_core::volume::Volume;
use rnd_std::{files, nrrd, parallel, volume_io};

fn cube_params() -> RenderParams {
    // rrendr go -i cube.nrrd -fr 6 12 5 -at 0 0 0 -up 0 0 1 -nc -2.3 -fc 2.3 -fov 14
    //   -sz 320 280 -us 0.03 -s 0.03 -k bspln3 -p rgbalit -b over -nt 2 -lut lut.nrrd
    //   -lit rgb.txt -o cube-rgb.nrrd
    let cam = CameraSpec {
        from: [6., 12., 5.],
        at: [0., 0., 0.],
        up: [0., 0., 1.],
        near: -2.3,
        far: 2.3,
        fov: 14.,
        size: [320, 280],
        orthographic: false,
    };
    let mut p = RenderParams::new(cam);
    p.unit_step = 0.03;
    p.plane_sep = 0.03;
    p.probe = Probe::RgbaLit;
    p.blend = Blend::Over;
    p.outside = 0.0;
    p
}

/// The reference's cube volume, LUT and lights (`rendr-data/`).
fn cube_inputs(d: &Path) -> (volume_io::VolumeBuf, Lut, Vec<rnd_core::light::Light>) {
    (
        volume_io::load_volume(&d.join("cube.nrrd")).unwrap(),
        files::load_lut(&d.join("lut.nrrd")).unwrap(),
        files::load_lights(&d.join("rgb.txt")).unwrap(),
    )
}

/// Distance (in LUT entries) from the nearest LUT bin boundary of the counted sample
/// values of one ray's `samples`; a tiny distance means float round-off decides which
/// entry is used.
fn nearest_boundary(samples: &[SampleInfo], lut: &Lut) -> f64 {
    let len = lut.entries().len() as f64;
    let (lo, hi) = (lut.vmin(), lut.vmax());
    samples
        .iter()
        .filter(|s| s.counted)
        .map(|s| {
            let f = (s.convo.value as f64 - lo) / (hi - lo) * len;
            (f - f.round()).abs()
        })
        .fold(f64::INFINITY, f64::min)
}

/// The f64 engine (`-ref false`: f64 geometry, separable sums) reproduces cube-rgb.nrrd
/// within 1e-5 except where round-off moves a sample across a LUT bin boundary, which
/// is proven for each such pixel.
#[test]
fn cube_rgb_f64_engine_matches_reference() {
    let Some(sh) = rnd_tests::shared("cube_rgb_f64_engine_matches_reference") else {
        return;
    };
    let d = sh.join("rendr-data");
    let (vol, lut, lights) = cube_inputs(&d);
    let mut p = cube_params();
    p.reference = false;
    let spec = RenderSpec::new(p, Some(&lut), None, &lights).unwrap();
    let img = parallel::render(&spec, vol.view(), KernelName::Bspln3, 2).unwrap();
    let reference = nrrd::read(&d.join("cube-rgb.nrrd")).unwrap();
    assert_eq!(reference.sizes(), &[4, 320, 280]);
    let want = reference.data.to_f32();
    assert_eq!(img.len(), want.len());

    // SPEC §13.5 pixels, each to 1e-5 (printed to 6 digits there, so compare to 2e-6
    // against the file itself and to 1e-5 against the listed numbers).
    let listed: &[((usize, usize), [f32; 4])] = &[
        ((0, 0), [0., 0., 0., 0.]),
        ((160, 140), [0., 0., 0., 0.]),
        ((183, 18), [0.2, 0.2, 0.970003, 0.0176803]),
        ((176, 19), [0.234257, 0.2, 0.965712, 0.0896213]),
        ((100, 100), [0.949497, 0.329096, 0.442809, 1.]),
        ((250, 200), [0.653116, 0.728219, 0.591621, 1.]),
        ((120, 60), [0.2, 0.781687, 0.2, 0.996306]),
        ((60, 150), [0.553805, 0.889047, 0.394962, 1.]),
        ((200, 240), [0.200958, 0.958987, 0.451135, 1.]),
        ((261, 50), [0.2, 0.200607, 0.943776, 0.745326]),
        ((287, 105), [0.2, 0.674191, 0.2, 0.588243]),
        ((88, 247), [0.853433, 0.200103, 0.2, 0.40966]),
    ];
    for &((h, v), rgba) in listed {
        let i = 4 * (h + 320 * v);
        for c in 0..4 {
            assert!(
                (img[i + c] - rgba[c]).abs() < 1e-5,
                "pixel ({h},{v}) channel {c}: {} vs listed {}",
                img[i + c],
                rgba[c]
            );
        }
    }

    // Every pixel: within 1e-5, or else explained by a sample value within float
    // round-off of a LUT bin boundary (our f32 arithmetic and the reference's then pick
    // neighbouring entries). Such pixels must be rare.
    let mut worst_ok = 0.0f32;
    let mut explained = 0;
    for px in 0..320 * 280 {
        let d = (0..4)
            .map(|c| (img[4 * px + c] - want[4 * px + c]).abs())
            .fold(0.0, f32::max);
        if d <= 1e-5 {
            worst_ok = worst_ok.max(d);
            continue;
        }
        let (h, v) = ((px % 320) as u32, (px / 320) as u32);
        let samples = rnd_tests::trace(&spec, vol.view(), KernelName::Bspln3, [h, v]);
        let dist = nearest_boundary(&samples, &lut);
        assert!(
            dist < 2e-3,
            "pixel ({h},{v}) differs by {d} and no sample is near a LUT bin boundary ({dist})"
        );
        assert!(d < 0.01, "pixel ({h},{v}) differs by {d}");
        explained += 1;
    }
    assert!(
        explained < 100,
        "{explained} pixels differ by more than 1e-5"
    );
    eprintln!(
        "cube-rgb: max error {worst_ok} on {} pixels; {explained} pixels differ more, each at a LUT bin flip",
        320 * 280 - explained
    );
    // Coverage as the reference: alpha > 0 on 49,862 pixels.
    let covered = (0..320 * 280).filter(|p| img[4 * p + 3] > 0.0).count();
    assert!(
        (covered as i64 - 49_862).abs() < 50,
        "{covered} covered pixels"
    );
    // Every alpha = 0 pixel is (0,0,0,0).
    for p in 0..320 * 280 {
        if img[4 * p + 3] == 0.0 {
            assert_eq!(&img[4 * p..4 * p + 3], &[0.0, 0.0, 0.0]);
        }
    }
}

/// The default engine, the reference program's own f32 arithmetic (docs/VERIFICATION.md,
/// "Reference arithmetic"), reproduces cube-rgb.nrrd on every pixel with no exceptions.
#[test]
fn cube_rgb_matches_every_pixel() {
    let Some(sh) = rnd_tests::shared("cube_rgb_matches_every_pixel") else {
        return;
    };
    let d = sh.join("rendr-data");
    let (vol, lut, lights) = cube_inputs(&d);
    let p = cube_params();
    assert!(
        p.reference,
        "the default engine is the reference arithmetic"
    );
    let spec = RenderSpec::new(p, Some(&lut), None, &lights).unwrap();
    let img = parallel::render(&spec, vol.view(), KernelName::Bspln3, 2).unwrap();
    let want = nrrd::read(&d.join("cube-rgb.nrrd")).unwrap().data.to_f32();
    assert_eq!(img.len(), want.len());
    let mut worst = 0.0f32;
    let mut exact_pixels = 0;
    for px in 0..320 * 280 {
        let mut exact = true;
        for c in 0..4 {
            let (a, b) = (img[4 * px + c], want[4 * px + c]);
            let d = (a - b).abs();
            assert!(
                d <= 1e-5,
                "pixel ({},{}) channel {c}: {a} vs reference {b}",
                px % 320,
                px / 320
            );
            worst = worst.max(d);
            exact &= a.to_bits() == b.to_bits();
        }
        // Opacity is accumulated exactly as the reference does it: bit for bit.
        assert_eq!(
            img[4 * px + 3].to_bits(),
            want[4 * px + 3].to_bits(),
            "pixel ({},{}) alpha",
            px % 320,
            px / 320
        );
        exact_pixels += exact as usize;
    }
    // Measured: max 2.03e-6 (one float ulp of colour sums near 1), 87,519 pixels
    // bit-identical; the rest differ in the last bits of the lit colour only.
    assert!(worst <= 2.5e-6, "max error {worst}");
    assert!(exact_pixels >= 87_000, "{exact_pixels} bit-exact pixels");
    eprintln!("cube-rgb: max error {worst}, {exact_pixels} of 89600 pixels bit-exact");
}

#[test]
fn lgen_reproduces_reference_lut() {
    let Some(sh) = rnd_tests::shared("lgen_reproduces_reference_lut") else {
        return;
    };
    let d = sh.join("rendr-data");
    let atxf = files::load_txf(&d.join("cube-atxf1.txt")).unwrap();
    let lut = Lut::generate(None, Some(&atxf), false, false, 512, 0.0, 1.0).unwrap();
    let reference = files::load_lut(&d.join("lut.nrrd")).unwrap();
    assert_eq!(reference.entries().len(), 512);
    assert_eq!((reference.vmin(), reference.vmax()), (0.0, 1.0));
    for (a, b) in lut.entries().iter().zip(reference.entries()) {
        for c in 0..4 {
            assert!((a[c] - b[c]).abs() <= 1e-6, "{a:?} vs {b:?}");
        }
    }
}

#[test]
fn cube_volume_geometry_matches_spec() {
    let Some(sh) = rnd_tests::shared("cube_volume_geometry_matches_spec") else {
        return;
    };
    let v = volume_io::load_volume(&sh.join("rendr-data/cube.nrrd")).unwrap();
    assert_eq!(v.sizes(), [50, 70, 90]);
    let sp: Vec<f64> = (0..3)
        .map(|c| rnd_core::math::v3::len(v.itow().column3(c)))
        .collect();
    for (a, b) in sp.iter().zip([0.08, 0.0571428575, 0.0444444455]) {
        assert!((a - b).abs() < 1e-8, "{sp:?}");
    }
    let o = v.itow().column3(3);
    for (a, b) in o.iter().zip([-1.96, -1.97142863, -1.97777784]) {
        assert!((a - b).abs() < 1e-7, "{o:?}");
    }
    let (lo, hi) = v.min_max();
    assert!((lo - 0.00234545162).abs() < 1e-9 && (hi - 1.00001502).abs() < 1e-7);
    let c = v.itow().point([24.5, 34.5, 44.5]);
    assert!(c.iter().all(|x| x.abs() < 1e-6));
    let corner = v.itow().point([-0.5, -0.5, -0.5]);
    assert!(corner.iter().all(|x| (x + 2.0).abs() < 1e-6));
    assert!(Path::new(&sh).exists());
}

#[test]
fn real_volumes_load() {
    let Some(sh) = rnd_tests::shared("real_volumes_load") else {
        return;
    };
    let ct = volume_io::load_volume(&sh.join("volumes/imageio-stent-ct.nrrd")).unwrap();
    assert_eq!(ct.sizes(), [128, 128, 256]);
    assert_eq!(ct.type_name(), "short");
    let (lo, hi) = ct.min_max();
    assert!(lo >= 0.0 && hi <= 2000.0 && hi > lo);
    let head = volume_io::load_volume(&sh.join("volumes/itk-t1-head.nrrd")).unwrap();
    assert_eq!(head.sizes(), [128, 128, 62]);
    assert!(head
        .notes
        .iter()
        .any(|n| n.contains("right-anterior-superior")));
    let water = volume_io::load_volume(&sh.join("volumes/nachr-m2-water-density.nrrd")).unwrap();
    assert_eq!(water.sizes(), [46, 46, 78]);
    assert_eq!(water.type_name(), "real");
}

/// `sdg -w which` as f32 samples on a 4-unit box of `sizes`, rotated by quaternion
/// (1, rot) and centred at `centre`: samples, sizes and index-to-world.
fn sdg_f32(
    which: u32,
    sizes: [usize; 3],
    rot: [f64; 3],
    centre: [f64; 3],
) -> (Vec<f32>, [usize; 3], rnd_core::affine::Affine4) {
    let grid = rnd_core::sdg::Grid {
        sizes,
        lengths: [4.0; 3],
        shear: [0.0; 3],
        rot,
        centre,
    };
    let (vals, itow) = rnd_core::sdg::generate(which, &grid).unwrap();
    (vals.iter().map(|&v| v as f32).collect(), sizes, itow)
}

/// Threads 1, 2 and 7 give identical bytes for every valid probe/blend pair.
#[test]
fn threads_give_identical_images() {
    use rnd_core::light::{Light, LightSpace};
    use rnd_core::render::AnyVolume;
    let (data, sizes, itow) = sdg_f32(2, [24, 26, 28], [0.1, 0.2, 0.0], [0.0; 3]);
    let vol = Volume::new(&data, sizes, itow).unwrap();
    let atxf = rnd_core::txf::Txf::new(
        rnd_core::txf::TxfSpace::Alpha,
        &[&[0.0, 0.0], &[0.8, 0.0], &[0.9, 1.0]],
    )
    .unwrap();
    let lut = Lut::generate(None, Some(&atxf), false, false, 256, 0.0, 1.0).unwrap();
    let lights = [Light::new([1.0, 0.5, 0.2], [1.0, 1.0, 0.0], LightSpace::World).unwrap()];
    let mut p = cube_params();
    p.camera.size = [37, 23];
    p.plane_sep = 0.05;
    p.time = false;
    for probe in Probe::ALL {
        for blend in Blend::ALL {
            if blend == Blend::Over && !probe.is_colour() {
                continue;
            }
            p.probe = probe;
            p.blend = blend;
            for reference in [false, true] {
                p.reference = reference;
                let spec = RenderSpec::new(p.clone(), Some(&lut), None, &lights).unwrap();
                let one =
                    parallel::render(&spec, AnyVolume::F32(vol), KernelName::Ctmr, 1).unwrap();
                for n in [2, 7] {
                    let many =
                        parallel::render(&spec, AnyVolume::F32(vol), KernelName::Ctmr, n).unwrap();
                    let same = one
                        .iter()
                        .zip(&many)
                        .all(|(a, b)| a.to_bits() == b.to_bits());
                    assert!(
                        same && one.len() == many.len(),
                        "{probe}/{blend} (reference arithmetic {reference}) differs with {n} threads"
                    );
                }
            }
        }
    }
}

/// The reference arithmetic (the default) and the f64 engine (`-ref false`) are the same
/// renderer: for every kernel, probe and blend they agree to float round-off on nearly
/// every pixel (a few may differ where round-off moves a sample across a LUT bin
/// boundary, the volume edge or a clipping plane). The field is 10 (1 − |p|), whose
/// gradient has magnitude 10 everywhere but its apex: where a gradient is round-off (a flat region),
/// its direction, and so lit colour, is noise in either engine.
#[test]
fn reference_arithmetic_agrees_with_f64_engine() {
    use rnd_core::light::{Light, LightSpace};
    use rnd_core::render::AnyVolume;
    let (data, sizes, itow) = sdg_f32(16, [30, 26, 28], [0.3, 0.2, 0.1], [0.1, 0.0, 0.0]);
    let vol = Volume::new(&data, sizes, itow).unwrap();
    let atxf = rnd_core::txf::Txf::new(
        rnd_core::txf::TxfSpace::Alpha,
        &[&[0.0, 0.0], &[6.0, 0.1], &[9.0, 0.7]],
    )
    .unwrap();
    let ctxf = rnd_core::txf::Txf::new(
        rnd_core::txf::TxfSpace::Rgb,
        &[&[0.0, 1.0, 0.2, 0.1], &[10.0, 0.1, 0.5, 1.0]],
    )
    .unwrap();
    let lut = Lut::generate(Some(&ctxf), Some(&atxf), false, false, 256, 0.0, 10.0).unwrap();
    let lights = [
        Light::new([1.0, 0.5, 0.2], [1.0, 1.0, 0.0], LightSpace::View).unwrap(),
        Light::new([0.2, 0.5, 1.0], [-1.0, 0.3, 2.0], LightSpace::World).unwrap(),
    ];
    let mut p = cube_params();
    p.camera.size = [41, 33];
    p.plane_sep = 0.07;
    p.unit_step = 0.05;
    p.time = false;
    let mut compared = 0;
    for ortho in [false, true] {
        p.camera.orthographic = ortho;
        for k in KernelName::ALL {
            for probe in Probe::ALL {
                for blend in Blend::ALL {
                    if blend == Blend::Over && !probe.is_colour() {
                        continue;
                    }
                    p.probe = probe;
                    p.blend = blend;
                    p.reference = false;
                    let spec = RenderSpec::new(p.clone(), Some(&lut), None, &lights).unwrap();
                    let fast = parallel::render(&spec, AnyVolume::F32(vol), k, 2).unwrap();
                    p.reference = true;
                    let spec = RenderSpec::new(p.clone(), Some(&lut), None, &lights).unwrap();
                    let refd = parallel::render(&spec, AnyVolume::F32(vol), k, 2).unwrap();
                    assert_eq!(fast.len(), refd.len());
                    let ch = fast.len() / (41 * 33);
                    let pixels = fast.len() / ch;
                    // (The zero kernel reconstructs 0 everywhere, the box kernel has no
                    // derivative, box and tent no second one; every ray starts outside
                    // so `in`'s minimum is 0.)
                    let trivial = (k == KernelName::Zero && probe.needs_convo())
                        || (k == KernelName::Box
                            && matches!(probe, Probe::GradVec | Probe::GradMag))
                        || (probe == Probe::Inside && blend == Blend::Min)
                        || (probe.second_order()
                            && matches!(k, KernelName::Zero | KernelName::Box | KernelName::Tent));
                    assert!(
                        trivial || fast.iter().any(|&x| x != 0.0 && !x.is_nan()),
                        "{k} {probe} {blend}: empty image"
                    );
                    let mut off = 0;
                    let mut first = None;
                    for (a, b) in fast.chunks(ch).zip(refd.chunks(ch)) {
                        let close = a.iter().zip(b).all(|(x, y)| {
                            (x.is_nan() && y.is_nan()) || (x - y).abs() <= 1e-4 * (1.0 + x.abs())
                        });
                        if !close {
                            off += 1;
                            first.get_or_insert((a.to_vec(), b.to_vec()));
                        }
                    }
                    assert!(
                        off * 100 <= pixels,
                        "{k} {probe} {blend} ortho {ortho}: {off} of {pixels} pixels differ, \
                         first {first:?}"
                    );
                    compared += 1;
                }
            }
        }
    }
    assert!(compared > 200);
}
