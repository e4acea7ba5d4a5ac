//! Analytic scenes: renderings whose right answer follows from the model alone
//! (opacity correction, projection, clipping, counting, Blinn-Phong, depth cue).

use rnd_core::affine::Affine4;
use rnd_core::blend::{Blend, MAX_CHANNELS};
use rnd_core::camera::CameraSpec;
use rnd_core::kernel::KernelName;
use rnd_core::light::{Light, LightSpace, Phong};
use rnd_core::march::Loop;
use rnd_core::probe::Probe;
use rnd_core::render::{AnyVolume, RenderParams, RenderSpec, SampleInfo};
use rnd_core::sdg::{self, Grid};
use rnd_core::txf::{Levoy, Lut, Txf, TxfSpace};
use rnd_core::volume::Volume;
use rnd_tests::trace;

fn grid(sizes: [usize; 3], centre: [f64; 3]) -> Grid {
    Grid {
        sizes,
        lengths: [2.0; 3],
        shear: [0.0; 3],
        rot: [0.0; 3],
        centre,
    }
}

fn make(which: u32, g: &Grid) -> (Vec<f32>, Affine4) {
    let (v, itow) = sdg::generate(which, g).unwrap();
    (v.iter().map(|&x| x as f32).collect(), itow)
}

fn cam(
    fr: [f64; 3],
    at: [f64; 3],
    up: [f64; 3],
    nc: f64,
    fc: f64,
    size: [u32; 2],
    ortho: bool,
) -> CameraSpec {
    CameraSpec {
        from: fr,
        at,
        up,
        near: nc,
        far: fc,
        fov: 30.0,
        size,
        orthographic: ortho,
    }
}

/// Both engines: the reference arithmetic (`RenderParams::reference`, the default) and
/// the f64-geometry engine. The analytic scenes hold for each.
const ENGINES: [bool; 2] = [true, false];

/// A LUT of the property tests for volumes of value scale `scale`: `kind` 0 is 1-D over
/// the value; 1 value × gradient magnitude (an arch and a box), 2 the same axes swapped,
/// 3 value × κ1 (a Gaussian), 4 κ1 × κ2 (a box), 5 1-D over the gradient magnitude.
fn class_lut(kind: usize, scale: f64, lo: f64, width: f64) -> Lut {
    use rnd_core::classify::{LutAxis, Primitive, Quantity as Q, Shape};
    let v = LutAxis::new(Q::Value, -2.0 * scale, 2.0 * scale, 97);
    let gm = LutAxis::new(Q::GradMag, 0.0, 4.0 * scale, 53);
    let k = |q| LutAxis::new(q, -3.0, 3.0, 41);
    let prim = |shape, rgb, alpha| Primitive { shape, rgb, alpha };
    let (a, b) = ((lo * scale), (lo + width) * scale);
    let arch = prim(
        Shape::Arch {
            va: a - scale,
            vb: b + scale,
            top: 1.5 * scale,
            width: 0.5 * scale,
        },
        [1.0, 0.2, 0.1],
        0.6,
    );
    let bx = |x: [f64; 2], y: [f64; 2]| Shape::Box {
        lo: [x[0], y[0]],
        hi: [x[1], y[1]],
    };
    match kind {
        1 => Lut::from_primitives(
            [v, gm],
            &[
                arch,
                prim(bx([a, b], [0.5 * scale, 2.0 * scale]), [0.1, 0.5, 1.0], 0.7),
            ],
        ),
        2 => Lut::from_primitives(
            [gm, v],
            &[
                prim(bx([0.5 * scale, 2.0 * scale], [a, b]), [0.1, 0.5, 1.0], 0.7),
                arch,
            ],
        ),
        3 => Lut::from_primitives(
            [v, k(Q::K1)],
            &[prim(
                Shape::Gaussian {
                    centre: [(a + b) / 2.0, -0.5],
                    sigma: [width * scale, 0.7],
                },
                [0.3, 1.0, 0.2],
                0.8,
            )],
        ),
        4 => Lut::from_primitives(
            [k(Q::K1), k(Q::K2)],
            &[prim(bx([-2.0, 0.0], [-2.5, -0.2]), [1.0, 1.0, 0.2], 0.5)],
        ),
        5 => Lut::with_axes(
            &[LutAxis::new(Q::GradMag, 0.0, 4.0 * scale, 64)],
            (0..64)
                .map(|i| {
                    [
                        1.0,
                        i as f32 / 64.0,
                        0.2,
                        if (20..40).contains(&i) { 0.5 } else { 0.0 },
                    ]
                })
                .collect(),
        ),
        _ => {
            let a = Txf::new(
                TxfSpace::Alpha,
                &[&[a, 0.0], &[(a + b) / 2.0, 0.7], &[b, 0.0]],
            )
            .unwrap();
            Lut::generate(
                None,
                Some(&a),
                false,
                false,
                1000,
                -2.0 * scale,
                2.0 * scale,
            )
        }
    }
    .unwrap()
}

fn constant_lut(rgba: [f32; 4]) -> Lut {
    Lut::new(-10.0, 10.0, vec![rgba; 16]).unwrap()
}

/// An sdg function sampled on a sheared, rotated grid, as floats and as shorts (values ×
/// 1000), for tests that run on either voxel type.
struct SdgVolume {
    sizes: [usize; 3],
    itow: Affine4,
    f: Vec<f32>,
    s: Vec<i16>,
    short: bool,
}

impl SdgVolume {
    fn new(which: u32, sizes: [usize; 3], short: bool) -> SdgVolume {
        let g = Grid {
            sizes,
            lengths: [2.5; 3],
            shear: [0.1, 0.0, -0.1],
            rot: [0.2, 0.0, 0.3],
            centre: [0.0; 3],
        };
        let (vals, itow) = sdg::generate(which, &g).unwrap();
        SdgVolume {
            sizes,
            itow,
            f: vals.iter().map(|&v| v as f32).collect(),
            s: vals.iter().map(|&v| (v * 1000.0).round() as i16).collect(),
            short,
        }
    }

    /// Makes float voxel `i` NaN.
    fn set_nan(&mut self, i: usize) {
        self.f[i] = f32::NAN;
    }

    /// Function units per voxel unit (1000 for shorts).
    fn scale(&self) -> f64 {
        if self.short {
            1000.0
        } else {
            1.0
        }
    }

    fn vol(&self) -> AnyVolume<'_> {
        if self.short {
            AnyVolume::I16(Volume::new(&self.s, self.sizes, self.itow).unwrap())
        } else {
            AnyVolume::F32(Volume::new(&self.f, self.sizes, self.itow).unwrap())
        }
    }
}

fn px(img: &[f32], ch: usize, w: u32, h: u32, v: u32) -> &[f32] {
    let i = (h + w * v) as usize * ch;
    &img[i..i + ch]
}

/// Constant medium: `over` opacity is 1 − (1 − α)^(L/unitStep) with L = (counted
/// samples) × step length.
#[test]
fn constant_medium_over_opacity() {
    let g = grid([20, 20, 20], [0.0; 3]);
    let (data, itow) = make(11, &g);
    let vol = Volume::new(&data, g.sizes, itow).unwrap();
    let alpha = 0.3f32;
    let lut = constant_lut([1.0, 1.0, 1.0, alpha]);
    for reference in ENGINES {
        for (ortho, us, s) in [(true, 0.1, 0.01), (false, 0.05, 0.02), (true, 1.0, 0.003)] {
            let mut p = RenderParams::new(cam(
                [0.3, 0.2, 5.0],
                [0.0; 3],
                [0.0, 1.0, 0.0],
                -2.0,
                2.0,
                [9, 7],
                ortho,
            ));
            p.reference = reference;
            p.plane_sep = s;
            p.unit_step = us;
            p.probe = Probe::Rgba;
            p.blend = Blend::Over;
            let spec = RenderSpec::new(p.clone(), Some(&lut), None, &[]).unwrap();
            let img = render(&spec, AnyVolume::F32(vol), KernelName::Tent);
            p.probe = Probe::Inside;
            p.blend = Blend::Sum;
            let cspec = RenderSpec::new(p, None, None, &[]).unwrap();
            let count = render(&cspec, AnyVolume::F32(vol), KernelName::Tent);
            for v in 0..7 {
                for h in 0..9 {
                    let n = px(&count, 1, 9, h, v)[0] as f64;
                    let step = spec.ray_geom(h, v).step_len;
                    let l = n * step;
                    let want = 1.0 - (1.0 - alpha as f64).powf(l / us);
                    let a = px(&img, 4, 9, h, v)[3] as f64;
                    assert!(
                        (a - want).abs() < 2e-5 * n.max(1.0).sqrt(),
                        "ortho {ortho} ({h},{v}): {a} vs {want} (n {n})"
                    );
                    let rgb = &px(&img, 4, 9, h, v)[..3];
                    if n > 0.0 {
                        // White in, white out (the reference arithmetic divides its
                        // premultiplied colour by 1 - T: within an ulp or so of 1).
                        assert!(rgb.iter().all(|&c| (c - 1.0).abs() < 1e-6), "{rgb:?}");
                    } else {
                        assert_eq!(rgb, &[0.0, 0.0, 0.0], "outside value");
                    }
                    if ortho && h == 4 && v == 3 {
                        // The centre ray crosses the inside slab z in [-0.95, 0.95] along the
                        // direction (0.3, 0.2, 5): path length 1.9 |d| / d_z.
                        let want_l = 1.9 * (0.3f64 * 0.3 + 0.2 * 0.2 + 25.0).sqrt() / 5.0;
                        assert!((l - want_l).abs() <= step + 1e-9, "L = {l} vs {want_l}");
                    }
                }
            }
        }
    }
}

/// Halving the plane separation with the same unit step changes `over` very little.
#[test]
fn opacity_correction_makes_step_size_irrelevant() {
    let g = Grid {
        sizes: [40, 40, 40],
        lengths: [4.0; 3],
        shear: [0.0; 3],
        rot: [0.0; 3],
        centre: [0.0; 3],
    };
    let (data, itow) = make(2, &g);
    let vol = Volume::new(&data, g.sizes, itow).unwrap();
    // A smooth opacity ramp and colour ramp.
    let a = Txf::new(TxfSpace::Alpha, &[&[0.0, 0.0], &[1.0, 0.6]]).unwrap();
    let c = Txf::new(
        TxfSpace::Rgb,
        &[&[0.0, 1.0, 0.0, 0.0], &[1.0, 0.0, 0.0, 1.0]],
    )
    .unwrap();
    let lut = Lut::generate(Some(&c), Some(&a), false, false, 4096, 0.0, 1.0).unwrap();
    for reference in ENGINES {
        let mut p = RenderParams::new(cam(
            [6.0, 12.0, 5.0],
            [0.0; 3],
            [0.0, 0.0, 1.0],
            -2.5,
            2.5,
            [40, 36],
            false,
        ));
        p.reference = reference;
        p.probe = Probe::Rgba;
        p.blend = Blend::Over;
        p.unit_step = 0.05;
        p.plane_sep = 0.01;
        let fine = render(
            &RenderSpec::new(p.clone(), Some(&lut), None, &[]).unwrap(),
            AnyVolume::F32(vol),
            KernelName::Bspln3,
        );
        p.plane_sep = 0.005;
        let finer = render(
            &RenderSpec::new(p, Some(&lut), None, &[]).unwrap(),
            AnyVolume::F32(vol),
            KernelName::Bspln3,
        );
        let worst = fine
            .iter()
            .zip(&finer)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-3, "halving -s changed over by {worst}");
        assert!(fine.chunks(4).filter(|p| p[3] > 0.5).count() > 100);
    }
}

fn argmax(img: &[f32], w: u32) -> (u32, u32) {
    let (i, _) = img
        .iter()
        .enumerate()
        .fold((0, f32::MIN), |b, (i, &v)| if v > b.1 { (i, v) } else { b });
    (i as u32 % w, i as u32 / w)
}

/// A single bright voxel under `max` lands where the camera maps it; the look-at point
/// is the image centre.
#[test]
fn impulse_lands_where_projected() {
    let g = grid([20, 24, 22], [0.3, -0.2, 0.1]);
    let (data, itow) = make(8, &g);
    let vol = Volume::new(&data, g.sizes, itow).unwrap();
    let spot = itow.point([10.0, 12.0, 11.0]);
    for reference in ENGINES {
        for (fr, up, ortho) in [
            ([4.0, 3.0, 2.0], [0.0, 0.0, 1.0], false),
            ([-2.0, 5.0, -3.0], [1.0, 0.0, 0.0], true),
            ([0.5, -0.5, 6.0], [0.0, 1.0, 0.0], false),
        ] {
            for at in [[0.0; 3], [0.5, -0.4, 0.2]] {
                let spec_c = cam(fr, at, up, -2.0, 2.0, [61, 47], ortho);
                let mut p = RenderParams::new(spec_c);
                p.reference = reference;
                p.plane_sep = 0.01;
                p.probe = Probe::Value;
                let spec = RenderSpec::new(p, None, None, &[]).unwrap();
                let img = render(&spec, AnyVolume::F32(vol), KernelName::Tent);
                let (h, v) = argmax(&img, 61);
                let (ph, pv) = spec.camera().project(spot);
                assert!(
                    (h as f64 - ph).abs() <= 1.0 && (v as f64 - pv).abs() <= 1.0,
                    "fr {fr:?}: max at ({h},{v}), predicted ({ph:.2},{pv:.2})"
                );
                // The look-at point projects to the image centre.
                let (ch, cv) = spec.camera().project(at);
                assert!((ch - 30.0).abs() < 1e-9 && (cv - 23.0).abs() < 1e-9);
            }
        }
    }
}

/// The centre ray passes through the look-at point, the up vector points up in the
/// image, and the aspect ratio is honoured (pixels are square in world units).
#[test]
fn look_at_centre_up_is_up_aspect() {
    let g = grid([8, 8, 8], [0.0; 3]);
    let (data, itow) = make(11, &g);
    let vol = Volume::new(&data, g.sizes, itow).unwrap();
    for reference in ENGINES {
        for ortho in [false, true] {
            let fr = [3.0, -4.0, 2.0];
            let at = [0.2, 0.1, -0.3];
            let up = [0.3, 0.1, 1.0];
            let mut p = RenderParams::new(cam(fr, at, up, -1.0, 1.0, [41, 21], ortho));
            p.reference = reference;
            p.plane_sep = 0.0;
            p.probe = Probe::PosWorld;
            let spec = RenderSpec::new(p, None, None, &[]).unwrap();
            let img = render(&spec, AnyVolume::F32(vol), KernelName::Box);
            let at_pix = |h, v| -> [f64; 3] {
                let q = px(&img, 3, 41, h, v);
                [q[0] as f64, q[1] as f64, q[2] as f64]
            };
            // Centre pixel's near-plane point lies on the line fr -> at.
            let c = at_pix(20, 10);
            let dir = rnd_core::math::v3::normalize(rnd_core::math::v3::sub(at, fr));
            let rel = rnd_core::math::v3::sub(c, fr);
            let off = rnd_core::math::v3::sub(
                rel,
                rnd_core::math::v3::scale(rnd_core::math::v3::dot(rel, dir), dir),
            );
            assert!(
                rnd_core::math::v3::len(off) < 1e-5,
                "ortho {ortho}: centre ray off by {off:?}"
            );
            // Up: the top row is further along `up` than the bottom row; right is up × back.
            let top = at_pix(20, 0);
            let bottom = at_pix(20, 20);
            assert!(rnd_core::math::v3::dot(rnd_core::math::v3::sub(top, bottom), up) > 0.0);
            let left = at_pix(0, 10);
            let right = at_pix(40, 10);
            let rdir = rnd_core::math::v3::sub(right, left);
            assert!(rnd_core::math::v3::dot(rdir, spec.camera().u.to_array()) > 0.0);
            // Square pixels: horizontal and vertical neighbour spacing are equal.
            let dx =
                rnd_core::math::v3::len(rnd_core::math::v3::sub(at_pix(21, 10), at_pix(20, 10)));
            let dy =
                rnd_core::math::v3::len(rnd_core::math::v3::sub(at_pix(20, 11), at_pix(20, 10)));
            assert!((dx - dy).abs() < 1e-5 * dx, "{dx} vs {dy}");
            // FOV: the image-plane height through the look-at is 2 d tan(fov/2).
            let d = spec.camera().d;
            assert!((spec.camera().hght - 2.0 * d * (15f64).to_radians().tan()).abs() < 1e-12);
        }
    }
}

/// Near and far planes clip, and sum / mean of `in` count the samples taken.
#[test]
fn clipping_and_counting() {
    let g = grid([20, 20, 20], [0.0; 3]);
    let (data, itow) = make(11, &g);
    let vol = Volume::new(&data, g.sizes, itow).unwrap();
    for reference in ENGINES {
        for (nc, fc, s) in [
            (-0.5, 0.3, 0.01),
            (-0.9, 0.9, 0.05),
            (0.2, 0.25, 0.01),
            (-3.0, 3.0, 0.1),
        ] {
            let mut p = RenderParams::new(cam(
                [0.0, 0.0, 5.0],
                [0.0; 3],
                [0.0, 1.0, 0.0],
                nc,
                fc,
                [5, 5],
                true,
            ));
            p.reference = reference;
            p.plane_sep = s;
            p.probe = Probe::Inside;
            p.blend = Blend::Sum;
            let sum = render(
                &RenderSpec::new(p.clone(), None, None, &[]).unwrap(),
                AnyVolume::F32(vol),
                KernelName::Tent,
            );
            p.blend = Blend::Mean;
            let mean = render(
                &RenderSpec::new(p.clone(), None, None, &[]).unwrap(),
                AnyVolume::F32(vol),
                KernelName::Tent,
            );
            p.probe = Probe::PosView;
            p.blend = Blend::Sum;
            let pv = render(
                &RenderSpec::new(p, None, None, &[]).unwrap(),
                AnyVolume::F32(vol),
                KernelName::Tent,
            );
            // Planes at z = -nc - k s (world z = 5 - depth), k = 0.. while depth <= fcv.
            let total = ((fc - nc) / s + 1e-9).floor() as usize + 1;
            let inside = (0..total)
                .filter(|k| {
                    let z = -nc - *k as f64 * s;
                    z.abs() <= 0.95 + 1e-12
                })
                .count();
            let c = sum[12] as usize;
            assert_eq!(
                c, inside,
                "nc {nc} fc {fc}: {c} inside samples, expected {inside}"
            );
            assert!((mean[12] as f64 - inside as f64 / total as f64).abs() < 1e-6);
            // Sum of the view z over all samples: an arithmetic series.
            let ncv = 5.0 + nc;
            let want: f64 = (0..total).map(|k| -(ncv + k as f64 * s)).sum();
            assert!(
                (pv[12 * 3 + 2] as f64 - want).abs() < 1e-4 * want.abs(),
                "{} vs {want}",
                pv[38]
            );
        }
    }
}

/// Depth cue: with only ambient light (ka = 1) on a white material, every sample's colour
/// is lerp(dcn, dcf, τ) with τ its relative depth between the planes.
#[test]
fn depth_cue_is_linear_in_depth() {
    let g = grid([20, 20, 20], [0.0; 3]);
    let (data, itow) = make(11, &g);
    let vol = Volume::new(&data, g.sizes, itow).unwrap();
    let lut = constant_lut([1.0, 1.0, 1.0, 0.5]);
    let lights = [Light::new([1.0; 3], [0.0, 0.0, 1.0], LightSpace::View).unwrap()];
    for reference in ENGINES {
        let mut p = RenderParams::new(cam(
            [1.0, 2.0, 5.0],
            [0.0; 3],
            [0.0, 0.0, 1.0],
            -0.8,
            0.8,
            [7, 7],
            false,
        ));
        p.reference = reference;
        p.probe = Probe::RgbaLit;
        p.blend = Blend::Sum;
        p.plane_sep = 0.05;
        p.phong = Phong {
            ka: 1.0,
            kd: 0.0,
            ks: 0.0,
            p: 10.0,
        };
        p.dcn = [1.2, 1.0, 0.2];
        p.dcf = [0.2, 0.5, 0.9];
        let spec = RenderSpec::new(p.clone(), Some(&lut), None, &lights).unwrap();
        let samples = trace(&spec, AnyVolume::F32(vol), KernelName::Tent, [3, 3]);
        let (ncv, fcv) = (spec.camera().ncv, spec.camera().fcv);
        let mut n = 0;
        for s in samples.iter().filter(|s| s.counted) {
            let tau = (-s.pos_v[2] - ncv) / (fcv - ncv);
            for c in 0..3 {
                let want = p.dcn[c] as f64 + tau * (p.dcf[c] - p.dcn[c]) as f64;
                assert!(
                    (s.probe[c] as f64 - want).abs() < 1e-5,
                    "tau {tau}: {:?}",
                    s.probe
                );
            }
            n += 1;
        }
        assert!(n > 20);
    }
}

/// Blinn-Phong on a sphere: ambient, diffuse and specular terms separately, and the
/// specular highlight where the half vector is the surface normal.
#[test]
fn blinn_phong_on_a_sphere() {
    let g = Grid {
        sizes: [64, 64, 64],
        lengths: [2.0; 3],
        shear: [0.0; 3],
        rot: [0.0; 3],
        centre: [0.0; 3],
    };
    let (data, itow) = make(9, &g); // f = -(x²+y²+z²): outward normal N = p/|p|
    let vol = Volume::new(&data, g.sizes, itow).unwrap();
    // Opaque from f = -0.36 (radius 0.6) inwards.
    let a = Txf::new(TxfSpace::Alpha, &[&[-0.37, 0.0], &[-0.36, 1.0]]).unwrap();
    let lut = Lut::generate(None, Some(&a), false, false, 4096, -3.0, 0.0).unwrap();
    let ldir = [1.0, 0.5, 1.0];
    let lights = [Light::new([1.0; 3], ldir, LightSpace::World).unwrap()];
    let size = 81u32;
    for reference in ENGINES {
        let mut p = RenderParams::new(cam(
            [0.0, 0.0, 4.0],
            [0.0; 3],
            [0.0, 1.0, 0.0],
            -1.0,
            1.0,
            [size, size],
            true,
        ));
        p.reference = reference;
        p.camera.fov = 30.0;
        p.probe = Probe::RgbaLit;
        p.blend = Blend::Over;
        p.plane_sep = 0.002;
        p.unit_step = 0.002;
        // Specular only.
        p.phong = Phong {
            ka: 0.0,
            kd: 0.0,
            ks: 1.0,
            p: 200.0,
        };
        let spec = RenderSpec::new(p.clone(), Some(&lut), None, &lights).unwrap();
        let img = render(&spec, AnyVolume::F32(vol), KernelName::Bspln3);
        let red: Vec<f32> = img.chunks(4).map(|c| c[0] * c[3]).collect();
        let (h, v) = argmax(&red, size);
        let l = rnd_core::math::v3::normalize(ldir);
        let hv = rnd_core::math::v3::normalize([l[0], l[1], l[2] + 1.0]);
        let spot = rnd_core::math::v3::scale(0.6, hv);
        let (ph, pv) = spec.camera().project(spot);
        assert!(
            (h as f64 - ph).abs() <= 1.5 && (v as f64 - pv).abs() <= 1.5,
            "highlight at ({h},{v}), predicted ({ph:.1},{pv:.1})"
        );
        // Ambient only: colour = ka * material everywhere the sphere is.
        p.phong = Phong {
            ka: 0.7,
            kd: 0.0,
            ks: 0.0,
            p: 1.0,
        };
        let img = render(
            &RenderSpec::new(p.clone(), Some(&lut), None, &lights).unwrap(),
            AnyVolume::F32(vol),
            KernelName::Bspln3,
        );
        for c in img.chunks(4).filter(|c| c[3] > 0.0) {
            assert!((c[0] - 0.7).abs() < 1e-5 && (c[1] - 0.7).abs() < 1e-5);
        }
        // Diffuse only: the centre pixel (N = view direction) shows kd * (N·L).
        p.phong = Phong {
            ka: 0.0,
            kd: 0.8,
            ks: 0.0,
            p: 1.0,
        };
        let img = render(
            &RenderSpec::new(p, Some(&lut), None, &lights).unwrap(),
            AnyVolume::F32(vol),
            KernelName::Bspln3,
        );
        let centre = px(&img, 4, size, size / 2, size / 2);
        let want = 0.8 * l[2] as f32;
        assert!(
            (centre[0] - want).abs() < 0.01,
            "diffuse {centre:?} vs {want}"
        );
    }
}

/// Renders with `p` (the accelerated loop and skipping as `p` says) and with the plain
/// loop, no skipping; None when `p` does not validate.
fn fast_and_plain(
    mut p: RenderParams,
    lut: &Lut,
    lev: Option<&Levoy>,
    lights: &[Light],
    vol: AnyVolume<'_>,
    k: KernelName,
) -> Option<(Vec<f32>, Vec<f32>)> {
    let fast = render(
        &RenderSpec::new(p.clone(), Some(lut), lev, lights).ok()?,
        vol,
        k,
    );
    p.fast_loop = false;
    p.skip_empty = false;
    let plain = render(&RenderSpec::new(p, Some(lut), lev, lights).ok()?, vol, k);
    Some((fast, plain))
}

/// An opacity so small that 1 − α rounds to 1 in f32, corrected for a step so long that
/// the exponent is infinite (found by the render fuzz target): the sample adds nothing,
/// and no pixel is NaN (it was ∞ · 0), perspective and orthographic.
#[test]
fn tiny_opacity_over_an_infinite_step_is_transparent() {
    let sv = SdgVolume::new(11, [6, 7, 8], false);
    let lut = Lut::new(-1.0, 3.0, vec![[0.9, 0.5, 0.2, 7.5e-9]; 4]).unwrap();
    let lights = [Light::new([1.0, 0.9, 0.8], [1.0, 2.0, 3.0], LightSpace::View).unwrap()];
    for ortho in [false, true] {
        let mut p = RenderParams::new(cam(
            [7.0, 8.0, 4.5],
            [0.0; 3],
            [0.0, 0.0, 1.0],
            -1.0,
            9.0,
            [5, 5],
            ortho,
        ));
        p.reference = false;
        p.plane_sep = 1.4e114;
        p.unit_step = 3.65;
        p.probe = Probe::RgbaLit;
        p.blend = Blend::Over;
        p.outside = 4.0;
        let spec = RenderSpec::new(p.clone(), Some(&lut), None, &lights).unwrap();
        let img = render(&spec, sv.vol(), KernelName::Tent);
        assert!(img.iter().all(|x| !x.is_nan()), "{img:?}");
        // Rays through the volume take one sample, inside, with opacity 0.
        assert!(img.chunks(4).any(|px| px == [0.0; 4]), "{img:?}");
        // The reference arithmetic (f32) refuses that step; at the largest f32 steps the
        // exponent step / us is still infinite in f32, and the result is the same.
        p.reference = true;
        let e = RenderSpec::new(p.clone(), Some(&lut), None, &lights).unwrap_err();
        assert!(e.msg.contains("plane separation 1.4e114"), "{e}");
        assert_eq!(e.param, Some(rnd_core::Param::Reference));
        p.plane_sep = 3e38;
        p.unit_step = 1e-3;
        let spec = RenderSpec::new(p, Some(&lut), None, &lights).unwrap();
        let img = render(&spec, sv.vol(), KernelName::Tent);
        assert!(img.iter().all(|x| !x.is_nan()), "{img:?}");
        assert!(img.chunks(4).any(|px| px == [0.0; 4]), "{img:?}");
    }
}

proptest::proptest! {
    #![proptest_config(proptest::test_runner::Config { cases: 24, .. Default::default() })]

    /// Empty-space skipping gives exactly the plain path's image on random scenes, with
    /// 1-D LUTs over the value or the gradient magnitude and 2-D LUTs over value ×
    /// gradient magnitude (either order), value × κ1 and κ1 × κ2.
    #[test]
    fn empty_space_skipping_is_exact(
        which in proptest::sample::select(vec![2u32, 9, 10, 12, 13, 14]),
        ki in 1usize..7,
        lo in 0.0f64..0.9,
        width in 0.01f64..0.5,
        fr in proptest::array::uniform3(-6.0f64..6.0),
        lit in proptest::bool::ANY,
        short in proptest::bool::ANY,
        kind in 0usize..6,
    ) {
        proptest::prop_assume!(fr.iter().map(|x| x * x).sum::<f64>() > 9.0);
        let sv = SdgVolume::new(which, [23, 19, 21], short);
        let (vol, scale) = (sv.vol(), sv.scale());
        // Opacity only near [lo, lo + width] (in function units) along value axes.
        let lut = class_lut(kind, scale, lo, width);
        let lights = [Light::new([1.0, 0.8, 0.6], [1.0, 2.0, 3.0], LightSpace::View).unwrap()];
        let mut p = RenderParams::new(cam(fr, [0.0; 3], [0.0, 0.0, 1.0], -2.0, 2.0, [24, 18], false));
        p.plane_sep = 0.02;
        p.unit_step = 0.05;
        p.probe = if lit { Probe::RgbaLit } else { Probe::Rgba };
        p.blend = Blend::Over;
        p.outside = f32::NAN;
        let k = KernelName::ALL[ki];
        for reference in ENGINES {
            p.reference = reference;
            p.skip_empty = true;
            let fast = render(&RenderSpec::new(p.clone(), Some(&lut), None, &lights).unwrap(), vol, k);
            p.skip_empty = false;
            let plain = render(&RenderSpec::new(p.clone(), Some(&lut), None, &lights).unwrap(), vol, k);
            proptest::prop_assert!(fast.iter().zip(&plain).all(|(a, b)| a.to_bits() == b.to_bits()), "{k} w{which} -ref {reference} LUT {kind}");
        }
    }
}

proptest::proptest! {
    #![proptest_config(proptest::test_runner::Config { cases: 48, .. Default::default() })]

    /// Skipping under `max` (samples bounded by the running maximum, or below a sample
    /// the previous ray's maximum points at, are counted unconvolved) gives exactly the
    /// plain path's image, for the value and the gradient magnitude, every kernel, both
    /// arithmetics, both loops, perspective and orthographic, with a few NaN voxels.
    #[test]
    fn max_skipping_is_exact(
        which in proptest::sample::select(vec![2u32, 9, 10, 12, 13, 14]),
        ki in 0usize..7,
        fr in proptest::array::uniform3(-6.0f64..6.0),
        gm in proptest::bool::ANY,
        short in proptest::bool::ANY,
        ortho in proptest::bool::ANY,
        nan in proptest::option::of(0usize..23 * 19 * 21),
    ) {
        proptest::prop_assume!(fr.iter().map(|x| x * x).sum::<f64>() > 9.0);
        let mut sv = SdgVolume::new(which, [23, 19, 21], short);
        if let (Some(i), false) = (nan, short) {
            sv.set_nan(i);
        }
        let vol = sv.vol();
        let mut p = RenderParams::new(cam(fr, [0.0; 3], [0.0, 0.0, 1.0], -2.0, 2.0, [24, 18], ortho));
        p.plane_sep = 0.03;
        p.probe = if gm { Probe::GradMag } else { Probe::Value };
        p.blend = Blend::Max;
        p.outside = -7.0;
        let k = KernelName::ALL[ki];
        for reference in ENGINES {
            p.reference = reference;
            for fast in [true, false] {
                p.fast_loop = fast;
                p.skip_empty = true;
                let skip = render(&RenderSpec::new(p.clone(), None, None, &[]).unwrap(), vol, k);
                p.skip_empty = false;
                let plain = render(&RenderSpec::new(p.clone(), None, None, &[]).unwrap(), vol, k);
                proptest::prop_assert!(
                    skip.iter().zip(&plain).all(|(a, b)| a.to_bits() == b.to_bits()),
                    "{k} w{which} gm {gm} -ref {reference} fast {fast}"
                );
            }
        }
    }
}

proptest::proptest! {
    #![proptest_config(proptest::test_runner::Config { cases: 24, .. Default::default() })]

    /// The frames of a loaded volume (`rnd_std::parallel::render_volume`: the volume
    /// keeps its skip grid from frame to frame, and the render's workers aim it at each
    /// new camera in parts, or build it in runs) give, at every thread count, the bits of
    /// a render of that frame alone on one thread: random cameras and thread counts,
    /// every kernel, both arithmetics, lit `over` with a LUT (the opacity grid) and `max`
    /// of the value or the gradient magnitude (the bounds grid).
    #[test]
    fn kept_grid_frames_are_fresh_renders_at_any_thread_count(
        which in proptest::sample::select(vec![2u32, 9, 10, 12, 13, 14]),
        ki in 0usize..7,
        eyes in proptest::collection::vec(proptest::array::uniform3(-6.0f64..6.0), 3),
        threads in proptest::collection::vec(1usize..6, 3),
        what in 0usize..3,
        short in proptest::bool::ANY,
        ortho in proptest::bool::ANY,
        lo in 0.0f64..0.9,
    ) {
        use rnd_std::parallel::{render_volume, render_with, Control};
        use rnd_std::volume_io::{VolumeBuf, VolumeData};
        proptest::prop_assume!(eyes.iter().all(|e| e.iter().map(|x| x * x).sum::<f64>() > 9.0));
        let sv = SdgVolume::new(which, [23, 19, 21], short);
        let data = if short { VolumeData::I16(sv.s.clone()) } else { VolumeData::F32(sv.f.clone()) };
        let lut = class_lut(0, sv.scale(), lo, 0.3);
        let lights = [Light::new([1.0, 0.8, 0.6], [1.0, 2.0, 3.0], LightSpace::View).unwrap()];
        let k = KernelName::ALL[ki];
        let ctl = Control::new();
        for reference in ENGINES {
            // A new volume for each arithmetic: its first frame builds the grid.
            let vol = VolumeBuf::new(data.clone(), sv.sizes, sv.itow).unwrap();
            for (i, (&eye, &nt)) in eyes.iter().zip(&threads).enumerate() {
                let mut p = RenderParams::new(cam(eye, [0.0; 3], [0.0, 0.0, 1.0], -2.0, 2.0, [24, 18], ortho));
                p.reference = reference;
                p.plane_sep = 0.03;
                p.unit_step = 0.05;
                let (lut, lights) = if what == 0 {
                    (p.probe, p.blend) = (Probe::RgbaLit, Blend::Over);
                    (Some(&lut), &lights[..])
                } else {
                    p.probe = if what == 1 { Probe::Value } else { Probe::GradMag };
                    p.blend = Blend::Max;
                    (None, &[][..])
                };
                let spec = RenderSpec::new(p, lut, None, lights).unwrap();
                proptest::prop_assert!(spec.skip_kind().is_some());
                let kept = render_volume(&spec, &vol, k, nt, &ctl).unwrap();
                let alone = render_with(&spec, vol.view(), k, 1, &ctl).unwrap();
                proptest::prop_assert!(
                    kept.iter().zip(&alone).all(|(a, b)| a.to_bits() == b.to_bits()),
                    "{k} w{which} -ref {reference} frame {i}, {nt} threads, what {what}"
                );
            }
        }
    }
}

proptest::proptest! {
    #![proptest_config(proptest::test_runner::Config { cases: 32, .. Default::default() })]

    /// A volume whose rows are padded (`Volume::padded`, the copy `rnd-std` makes of
    /// volumes whose row length aliases in the cache) renders the bits of the same
    /// samples unpadded: every kernel, both arithmetics, both loops, skipping on and
    /// off, for `max` of the value and the gradient magnitude, lit `over` with a LUT,
    /// and a curvature probe (second derivatives). The padding holds NaN, so a read of
    /// it as a sample would show.
    #[test]
    fn padded_rows_render_the_same_bits(
        which in proptest::sample::select(vec![2u32, 9, 10, 12, 13, 14]),
        ki in 0usize..7,
        fr in proptest::array::uniform3(-6.0f64..6.0),
        what in 0usize..4,
        short in proptest::bool::ANY,
        ortho in proptest::bool::ANY,
        pad in 1usize..40,
    ) {
        proptest::prop_assume!(fr.iter().map(|x| x * x).sum::<f64>() > 9.0);
        // (Not looking along the up vector, which the camera refuses.)
        proptest::prop_assume!(fr[0].abs() + fr[1].abs() > 0.1);
        let sv = SdgVolume::new(which, [23, 19, 21], short);
        let row = 23 + pad;
        let padded = |d: &[f32]| -> Vec<f32> {
            d.chunks(23).flat_map(|r| r.iter().copied().chain(std::iter::repeat_n(f32::NAN, pad))).collect()
        };
        let (pf, ps): (Vec<f32>, Vec<i16>) = (
            padded(&sv.f),
            sv.s.chunks(23).flat_map(|r| r.iter().copied().chain(std::iter::repeat_n(i16::MIN, pad))).collect(),
        );
        let pvol = if short {
            AnyVolume::I16(Volume::padded(&ps, sv.sizes, row, sv.itow).unwrap())
        } else {
            AnyVolume::F32(Volume::padded(&pf, sv.sizes, row, sv.itow).unwrap())
        };
        let vol = sv.vol();
        let lut = class_lut(0, sv.scale(), 0.3, 0.4);
        let lights = [Light::new([1.0, 0.8, 0.6], [1.0, 2.0, 3.0], LightSpace::View).unwrap()];
        let mut p = RenderParams::new(cam(fr, [0.0; 3], [0.0, 0.0, 1.0], -2.0, 2.0, [24, 18], ortho));
        p.plane_sep = 0.03;
        (p.probe, p.blend) = [
            (Probe::Value, Blend::Max),
            (Probe::GradMag, Blend::Max),
            (Probe::RgbaLit, Blend::Over),
            (Probe::K1, Blend::Max),
        ][what];
        let k = KernelName::ALL[ki];
        for reference in ENGINES {
            p.reference = reference;
            for (fast, skip) in [(true, true), (false, true), (true, false)] {
                (p.fast_loop, p.skip_empty) = (fast, skip);
                let spec = RenderSpec::new(p.clone(), Some(&lut), None, &lights).unwrap();
                let a = render(&spec, pvol, k);
                let b = render(&spec, vol, k);
                proptest::prop_assert!(
                    a.iter().zip(&b).all(|(a, b)| a.to_bits() == b.to_bits()),
                    "{k} w{which} {} -ref {reference} fast {fast} skip {skip} pad {pad}", p.probe
                );
            }
        }
    }
}

/// Fuzz regression (fuzz/corpus/render/regressions): a camera so far away that the ray's
/// positions stop changing in floating point must still finish (it hung before), and
/// absurd sample counts are refused up front.
#[test]
fn far_camera_terminates_and_sample_count_is_bounded() {
    let g = grid([8, 8, 8], [0.0; 3]);
    let (data, itow) = make(11, &g);
    let vol = Volume::new(&data, g.sizes, itow).unwrap();
    // At 1e15 the planes 2 apart are distinct, but steps of 0.01 are below the spacing
    // of f64 there (0.125): the positions stall.
    let mut p = RenderParams::new(cam(
        [0.0, 0.0, 1e15],
        [0.0; 3],
        [0.0, 1.0, 0.0],
        -1.0,
        1.0,
        [2, 2],
        true,
    ));
    p.reference = false;
    p.camera.fov = 1e-14;
    p.plane_sep = 0.01;
    p.probe = Probe::Inside;
    p.blend = Blend::Sum;
    let spec = RenderSpec::new(p.clone(), None, None, &[]).unwrap();
    let img = render(&spec, AnyVolume::F32(vol), KernelName::Tent);
    assert!(img.iter().all(|v| v.is_finite()));
    p.plane_sep = 1e-12;
    let e = RenderSpec::new(p.clone(), None, None, &[]).unwrap_err();
    assert!(e.msg.contains("samples per ray"), "{e}");
    // At 1e17 the near and far planes themselves collapse: refused.
    p.camera.from = [0.0, 0.0, 1e17];
    p.plane_sep = 0.01;
    let e = RenderSpec::new(p.clone(), None, None, &[]).unwrap_err();
    assert!(e.msg.contains("coincide"), "{e}");
    // Fuzz regression (reference arithmetic): at 5e15 the planes are distinct in f64 but not in f32,
    // where the depth cue divided 0 by 0. The reference arithmetic refuses the camera.
    p.camera.from = [0.0, 0.0, 5e15];
    p.dcn = [0.6; 3];
    p.dcf = [0.0; 3];
    assert!(RenderSpec::new(p.clone(), None, None, &[]).is_ok());
    p.reference = true;
    let e = RenderSpec::new(p, None, None, &[]).unwrap_err();
    assert!(
        e.msg.contains("the camera") && e.msg.contains("f64 arithmetic"),
        "{e}"
    );
}

/// Fuzz regression (reference arithmetic): a light direction of length ~3e-35 is normalized fine in f64,
/// but its squared length underflows in f32 and lighting gave NaN; that engine refuses it.
#[test]
fn tiny_light_direction_under_reference_arithmetic() {
    let lut = constant_lut([0.5, 0.5, 0.5, 0.5]);
    let lights = [Light::new([1.0, 0.9, 0.8], [-1.86e-35; 3], LightSpace::View).unwrap()];
    let mut p = RenderParams::new(cam(
        [3.0, 2.0, 1.0],
        [0.0; 3],
        [0.0, 0.0, 1.0],
        -1.0,
        1.0,
        [4, 4],
        false,
    ));
    p.reference = false;
    p.probe = Probe::RgbaLit;
    p.blend = Blend::Over;
    assert!(RenderSpec::new(p.clone(), Some(&lut), None, &lights).is_ok());
    p.reference = true;
    let e = RenderSpec::new(p, Some(&lut), None, &lights).unwrap_err();
    assert!(
        e.msg.contains("light 1") && e.msg.contains("f64 arithmetic"),
        "{e}"
    );
}

/// Fuzz regression: a negative specular exponent with ks = 0 gave 0 · ∞ = NaN; negative
/// exponents are now refused, and ks = 0 skips the specular term.
#[test]
fn negative_specular_exponent_is_refused() {
    let lut = constant_lut([1.0, 1.0, 1.0, 0.5]);
    let lights = [Light::new([1.0; 3], [0.0, 0.0, 1.0], LightSpace::View).unwrap()];
    let mut p = RenderParams::new(cam(
        [0.0, 0.0, 5.0],
        [0.0; 3],
        [0.0, 1.0, 0.0],
        -1.0,
        1.0,
        [3, 3],
        true,
    ));
    p.probe = Probe::RgbaLit;
    p.blend = Blend::Over;
    p.phong = Phong {
        ka: -6.7,
        kd: -8.5,
        ks: 0.0,
        p: -1.049,
    };
    let e = RenderSpec::new(p.clone(), Some(&lut), None, &lights).unwrap_err();
    assert!(e.msg.contains("specular exponent"), "{e}");
    // With p = 0 and ks = 0 the output is finite.
    p.phong.p = 0.0;
    let g = grid([8, 8, 8], [0.0; 3]);
    let (data, itow) = make(9, &g);
    let vol = Volume::new(&data, g.sizes, itow).unwrap();
    let img = render(
        &RenderSpec::new(p, Some(&lut), None, &lights).unwrap(),
        AnyVolume::F32(vol),
        KernelName::Tent,
    );
    assert!(img.iter().all(|v| v.is_finite()));
    assert!(Lut::new(0.0, 1.0, vec![[f32::NAN, 0.0, 0.0, 1.0]]).is_err());
}

/// Every valid probe × blend pair: the pixel equals the blend computed by hand from the
/// per-sample probe values the trace reports (probing and blending are orthogonal).
#[test]
fn every_probe_blend_pair_blends_its_samples() {
    let g = Grid {
        sizes: [30, 30, 30],
        lengths: [4.0; 3],
        shear: [0.0; 3],
        rot: [0.1, 0.0, 0.2],
        centre: [0.0; 3],
    };
    let (data, itow) = make(2, &g);
    let vol = Volume::new(&data, g.sizes, itow).unwrap();
    let a = Txf::new(TxfSpace::Alpha, &[&[0.0, 0.0], &[1.0, 0.4]]).unwrap();
    let c = Txf::new(
        TxfSpace::Rgb,
        &[&[0.0, 1.0, 0.0, 0.0], &[1.0, 0.0, 1.0, 0.5]],
    )
    .unwrap();
    let lut = Lut::generate(Some(&c), Some(&a), false, false, 256, 0.0, 1.0).unwrap();
    let lights = [Light::new([1.0, 0.9, 0.8], [1.0, 2.0, 3.0], LightSpace::World).unwrap()];
    for reference in ENGINES {
        let mut checked = 0;
        for probe in Probe::ALL {
            for blend in rnd_core::blend::Blend::ALL {
                if blend == Blend::Over && !probe.is_colour() {
                    continue;
                }
                let mut p = RenderParams::new(cam(
                    [6.0, 12.0, 5.0],
                    [0.0; 3],
                    [0.0, 0.0, 1.0],
                    -2.5,
                    2.5,
                    [9, 9],
                    false,
                ));
                p.reference = reference;
                p.probe = probe;
                p.blend = blend;
                p.plane_sep = 0.1;
                p.unit_step = 0.2;
                p.outside = -7.0;
                let spec = RenderSpec::new(p, Some(&lut), None, &lights).unwrap();
                let img = render(&spec, AnyVolume::F32(vol), KernelName::Ctmr);
                let len = probe.length();
                for (h, v) in [(4, 4), (0, 0), (2, 6)] {
                    let samples = trace(&spec, AnyVolume::F32(vol), KernelName::Ctmr, [h, v]);
                    let counted: Vec<[f32; MAX_CHANNELS]> = samples
                        .iter()
                        .filter(|s| s.counted)
                        .map(|s| s.probe)
                        .collect();
                    // Everywhere-defined probes count every sample.
                    if probe.everywhere() {
                        assert_eq!(counted.len(), samples.len());
                    }
                    let mut want = [0.0f32; MAX_CHANNELS];
                    if counted.is_empty() {
                        want = [-7.0; MAX_CHANNELS];
                    } else {
                        match blend {
                            Blend::Max => {
                                for c in 0..len {
                                    want[c] = counted.iter().map(|x| x[c]).fold(f32::MIN, f32::max);
                                }
                            }
                            Blend::Sum | Blend::Mean => {
                                for c in 0..len {
                                    want[c] = counted.iter().map(|x| x[c]).sum();
                                    if blend == Blend::Mean {
                                        want[c] /= counted.len() as f32;
                                    }
                                }
                            }
                            Blend::Min => {
                                for c in 0..len {
                                    want[c] = counted.iter().map(|x| x[c]).fold(f32::MAX, f32::min);
                                }
                            }
                            Blend::L2 | Blend::Variance | Blend::Sd => {
                                // Two passes (mean, then squared deviations), unlike the
                                // renderer's running sums.
                                for c in 0..len {
                                    let xs: Vec<f64> =
                                        counted.iter().map(|x| x[c] as f64).collect();
                                    let n = xs.len() as f64;
                                    let mean = xs.iter().sum::<f64>() / n;
                                    let var =
                                        xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n;
                                    let l2 = xs.iter().map(|x| x * x).sum::<f64>().sqrt();
                                    want[c] = match blend {
                                        Blend::L2 => l2,
                                        Blend::Variance => var,
                                        _ => var.sqrt(),
                                    } as f32;
                                }
                            }
                            Blend::Median => {
                                for c in 0..len {
                                    let mut xs: Vec<f32> = counted.iter().map(|x| x[c]).collect();
                                    xs.sort_by(f32::total_cmp);
                                    let n = xs.len();
                                    want[c] = if n % 2 == 1 {
                                        xs[n / 2]
                                    } else {
                                        ((xs[n / 2 - 1] as f64 + xs[n / 2] as f64) / 2.0) as f32
                                    };
                                }
                            }
                            Blend::Over => {
                                let (mut col, mut al) = ([0.0f32; 3], 0.0f32);
                                for x in &counted {
                                    let t = (1.0 - al) * x[3];
                                    for c in 0..3 {
                                        col[c] += t * x[c];
                                    }
                                    al += t;
                                }
                                for c in 0..3 {
                                    want[c] = if al > 0.0 { col[c] / al } else { 0.0 };
                                }
                                want[3] = al;
                            }
                        }
                    }
                    let got = px(&img, len, 9, h, v);
                    for c in 0..len {
                        let tol = 1e-5 * (1.0 + want[c].abs());
                        assert!(
                            (got[c] - want[c]).abs() <= tol,
                            "{probe}/{blend} ({h},{v}) ch {c}: {} vs {}",
                            got[c],
                            want[c]
                        );
                    }
                    checked += 1;
                }
            }
        }
        // Every probe with every blend but over; the colour probes with every blend.
        let colour = Probe::ALL.iter().filter(|p| p.is_colour()).count();
        assert_eq!(
            checked,
            3 * ((Probe::ALL.len() - colour) * (Blend::ALL.len() - 1) + colour * Blend::ALL.len())
        );
    }
}

/// The scene of the loop-equivalence properties: a LUT, Levoy opacity and a light for a
/// volume of value scale `scale`; probe `pi` and blend `bi` (over only for colour),
/// camera [from, at], [near, far] planes, plane separation, projection and alphaNear1.
#[allow(clippy::too_many_arguments)]
fn loop_case(
    scale: f64,
    pi: usize,
    bi: usize,
    fr_at: [[f64; 3]; 2],
    planes: [f64; 2],
    step: f64,
    ortho: bool,
    a1: f32,
    kind: usize,
) -> (Lut, Levoy, [Light; 1], RenderParams) {
    let probe = [
        Probe::Value,
        Probe::GradVec,
        Probe::GradMag,
        Probe::Rgba,
        Probe::RgbaLit,
        Probe::Hess,
        Probe::K1,
        Probe::GaussCurv,
    ][pi];
    let blend = if probe.is_colour() {
        Blend::ALL[bi % Blend::ALL.len()]
    } else {
        // Every blend but over (which needs colour).
        let scalar: Vec<Blend> = Blend::ALL
            .into_iter()
            .filter(|&b| b != Blend::Over)
            .collect();
        scalar[bi % scalar.len()]
    };
    let a = Txf::new(
        TxfSpace::Alpha,
        &[&[0.0, 0.0], &[0.3 * scale, 0.6], &[0.6 * scale, 0.0]],
    )
    .unwrap();
    let c = Txf::new(
        TxfSpace::Rgb,
        &[&[-scale, 1.0, 0.2, 0.1], &[scale, 0.1, 0.5, 1.0]],
    )
    .unwrap();
    let lut = if kind == 0 {
        Lut::generate(
            Some(&c),
            Some(&a),
            false,
            false,
            300,
            -2.0 * scale,
            2.0 * scale,
        )
        .unwrap()
    } else {
        class_lut(kind, scale, 0.2, 0.4)
    };
    let lev = Levoy::new(vec![[(0.4 * scale) as f32, 0.5, 0.8]]).unwrap();
    let lights = [Light::new([1.0, 0.8, 0.6], [1.0, 2.0, 3.0], LightSpace::View).unwrap()];
    let [fr, at] = fr_at;
    let mut p = RenderParams::new(cam(
        fr,
        at,
        [0.0, 0.0, 1.0],
        planes[0],
        planes[1],
        [9, 7],
        ortho,
    ));
    p.plane_sep = step;
    p.unit_step = 0.05;
    p.probe = probe;
    p.blend = blend;
    p.alpha_near1 = a1;
    p.outside = f32::NAN;
    (lut, lev, lights, p)
}

proptest::proptest! {
    #![proptest_config(proptest::test_runner::Config { cases: 64, .. Default::default() })]

    /// In both engines the accelerated ray loop (the f64 engine: inside stretch found by
    /// bisection, batched phase-by-phase convolution; the reference arithmetic: each
    /// ray's outside stretch skipped, sixteen samples convolved at once; both: empty-space
    /// skipping) gives exactly the plain one-sample loop's image, traced or not: every
    /// probe it handles, every blend, both voxel types, every kernel, perspective and
    /// orthographic cameras placed inside, at the edge of and outside the volume, one
    /// sample per ray, early termination and Levoy opacity.
    #[test]
    fn fast_loop_is_exact(
        which in proptest::sample::select(vec![2u32, 9, 10, 12, 13]),
        ki in 0usize..7,
        pi in 0usize..8,
        bi in 0usize..9,
        fr in proptest::array::uniform3(-6.0f64..6.0),
        at in proptest::array::uniform3(-1.0f64..1.0),
        // Whole-number planes with binary-fraction steps put samples exactly on the far
        // plane (counted: it is not past it).
        near in proptest::prop_oneof![-3.0f64..0.5, proptest::sample::select(vec![-2.0f64, -1.0, 0.0])],
        depth in proptest::prop_oneof![0.1f64..5.0, proptest::sample::select(vec![1.0f64, 2.0, 3.0])],
        step in proptest::sample::select(vec![0.0f64, 0.013, 0.05, 0.31, 0.25, 0.5]),
        ortho in proptest::bool::ANY,
        short in proptest::bool::ANY,
        levoy in proptest::bool::ANY,
        a1 in proptest::sample::select(vec![1.0f32, 0.9, 0.3]),
        kind in 0usize..6,
    ) {
        proptest::prop_assume!((0..3).map(|a| (fr[a] - at[a]).powi(2)).sum::<f64>() > 1.0);
        let sv = SdgVolume::new(which, [13, 11, 12], short);
        let (vol, scale) = (sv.vol(), sv.scale());
        let (lut, lev, lights, p) =
            loop_case(scale, pi, bi, [fr, at], [near, near + depth], step, ortho, a1, kind);
        let (probe, blend) = (p.probe, p.blend);
        let lev = if levoy { Some(&lev) } else { None };
        let k = KernelName::ALL[ki];
        for reference in ENGINES {
            let mut p = p.clone();
            p.reference = reference;
            let Ok(spec) = RenderSpec::new(p.clone(), Some(&lut), lev, &lights) else {
                // Up vector parallel to the view direction, or (reference arithmetic) a
                // camera beyond f32: nothing to compare.
                continue;
            };
            let (fast, plain) = fast_and_plain(p, &lut, lev, &lights, vol, k).unwrap();
            proptest::prop_assert!(
                fast.iter().zip(&plain).all(|(a, b)| a.to_bits() == b.to_bits()),
                "{k} {probe} {blend} -ref {reference} LUT {kind}: {fast:?} vs {plain:?}"
            );
            // The traced one-sample loop (what -db runs) gives the same image too.
            let traced = traced_image(&spec, vol, k);
            proptest::prop_assert!(
                fast.iter().zip(&traced).all(|(a, b)| a.to_bits() == b.to_bits())
                    && fast.len() == traced.len(),
                "{k} {probe} {blend} -ref {reference}: {fast:?} vs traced {traced:?}"
            );
        }
    }
    /// Empty-space skipping over wide empty regions: an impulse or a thin spherical
    /// shell in a volume of several skip blocks per axis, so rays jump across boxes of
    /// many empty blocks; the image equals the plain loop's without skipping.
    #[test]
    fn wide_empty_skips_are_exact(
        which in proptest::sample::select(vec![8u32, 9]),
        ki in 0usize..7,
        lit in proptest::bool::ANY,
        fr in proptest::array::uniform3(-6.0f64..6.0),
        at in proptest::array::uniform3(-0.5f64..0.5),
        step in proptest::sample::select(vec![0.013f64, 0.05, 0.31]),
        ortho in proptest::bool::ANY,
        short in proptest::bool::ANY,
    ) {
        proptest::prop_assume!((0..3).map(|a| (fr[a] - at[a]).powi(2)).sum::<f64>() > 1.0);
        let sv = SdgVolume::new(which, [45, 38, 50], short);
        let (vol, scale) = (sv.vol(), sv.scale());
        // Opacity only near the impulse's peak (8) or the shell -(r^2) = -0.5 (9).
        let (lo, hi) = if which == 8 { (0.05, 1.2) } else { (-0.55, -0.45) };
        let a = Txf::new(TxfSpace::Alpha, &[&[lo * scale, 0.0], &[(lo + hi) / 2.0 * scale, 0.7], &[hi * scale, 0.0]]).unwrap();
        let c = Txf::new(TxfSpace::Rgb, &[&[-scale, 1.0, 0.2, 0.1], &[scale, 0.1, 0.5, 1.0]]).unwrap();
        let lut = Lut::generate(Some(&c), Some(&a), false, false, 400, -2.0 * scale, 2.0 * scale).unwrap();
        let lights = [Light::new([1.0, 0.8, 0.6], [1.0, 2.0, 3.0], LightSpace::View).unwrap()];
        let mut p = RenderParams::new(cam(fr, at, [0.0, 0.0, 1.0], -2.5, 2.5, [11, 9], ortho));
        p.plane_sep = step;
        p.unit_step = 0.05;
        p.probe = if lit { Probe::RgbaLit } else { Probe::Rgba };
        p.blend = Blend::Over;
        let k = KernelName::ALL[ki];
        for reference in ENGINES {
            let mut p = p.clone();
            p.reference = reference;
            let Some((fast, plain)) = fast_and_plain(p, &lut, None, &lights, vol, k) else {
                continue;
            };
            proptest::prop_assert!(fast.iter().any(|&x| x > 0.0) || plain.iter().all(|&x| x == 0.0));
            proptest::prop_assert!(
                fast.iter().zip(&plain).all(|(a, b)| a.to_bits() == b.to_bits()),
                "{k} -ref {reference}: {fast:?} vs {plain:?}"
            );
        }
    }
}

/// Renders every pixel of `spec` through [`RenderSpec::cast`] with [`Loop::OneSample`]
/// and a (no-op) trace.
fn traced_image(spec: &RenderSpec<'_>, vol: AnyVolume<'_>, k: KernelName) -> Vec<f32> {
    let [w, h] = spec.size();
    let len = spec.params().probe.length();
    let mut img = vec![0.0f32; (w * h) as usize * len];
    for vi in 0..h {
        for hi in 0..w {
            let i = (vi * w + hi) as usize * len;
            let mut ignore = |_: &SampleInfo| {};
            let px = &mut img[i..i + len];
            spec.cast(vol, k, hi, vi, px, Loop::OneSample, Some(&mut ignore))
                .unwrap();
        }
    }
    img
}

/// The whole image on this thread (these scenes are small and valid).
fn render(spec: &RenderSpec<'_>, vol: AnyVolume<'_>, k: KernelName) -> Vec<f32> {
    rnd_core::render::render(spec, vol, k).expect("a small valid scene renders")
}

/// 2-D LUT axes checked analytically (in this test binary, so that CI builds one fewer).
mod classify {
    // Classification over two quantities, checked analytically: a LUT axis over the
    // gradient magnitude sees the slope of a ramp, and LUT axes over the principal
    // curvatures see the radius of the spheres of |x|².

    use rnd_core::affine::Affine4;
    use rnd_core::blend::Blend;
    use rnd_core::camera::CameraSpec;
    use rnd_core::classify::{LutAxis, Primitive, Quantity, Shape};
    use rnd_core::kernel::KernelName;
    use rnd_core::probe::Probe;
    use rnd_core::render::{render, AnyVolume, RenderParams, RenderSpec};
    use rnd_core::txf::Lut;
    use rnd_core::volume::Volume;

    /// `f` sampled on an n³ grid of spacing `h` centred on the origin.
    fn sampled(n: usize, h: f64, f: impl Fn([f64; 3]) -> f64) -> (Vec<f32>, Affine4) {
        let c = -h * (n as f64 - 1.0) / 2.0;
        let itow = Affine4::from_columns([h, 0.0, 0.0], [0.0, h, 0.0], [0.0, 0.0, h], [c, c, c]);
        let mut v = Vec::with_capacity(n * n * n);
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    v.push(f([i, j, k].map(|x| c + h * x as f64)) as f32);
                }
            }
        }
        (v, itow)
    }

    /// An orthographic view down −z of the square [−half, half]² in `px` × `px` pixels.
    fn view(half: f64, px: u32) -> RenderParams {
        let fov = 2.0 * (half / 10.0).atan().to_degrees();
        let mut p = RenderParams::new(CameraSpec {
            from: [0.0, 0.0, 10.0],
            at: [0.0; 3],
            up: [0.0, 1.0, 0.0],
            near: -half,
            far: half,
            fov,
            size: [px, px],
            orthographic: true,
        });
        p.plane_sep = 0.05;
        p.unit_step = 0.1;
        p
    }

    /// A ramp f = 2.75·x has gradient magnitude 2.75 everywhere (every kernel here
    /// reproduces linear functions): with opacity only in the gm cell [2.5, 3), every ray
    /// through the volume is coloured; with it only in [2, 2.5) or [3, 3.5), no ray is.
    #[test]
    fn gradient_magnitude_axis_sees_the_slope() {
        let (data, itow) = sampled(20, 0.2, |x| 2.75 * x[0] + 1.0);
        let vol = Volume::new(&data, [20; 3], itow).unwrap();
        let axes = [
            LutAxis::new(Quantity::Value, -10.0, 10.0, 8),
            LutAxis::new(Quantity::GradMag, 0.0, 6.0, 12),
        ];
        for (cell, opaque) in [(5usize, true), (4, false), (6, false)] {
            let rgba = (0..8 * 12)
                .map(|e| {
                    let a = if e / 8 == cell { 0.5 } else { 0.0 };
                    [1.0, 0.25, 0.0, a]
                })
                .collect();
            let lut = Lut::with_axes(&axes, rgba).unwrap();
            for k in [KernelName::Tent, KernelName::Bspln3, KernelName::Ctmr] {
                for reference in [true, false] {
                    for skip in [true, false] {
                        let mut p = view(1.5, 9);
                        (p.probe, p.blend, p.reference, p.skip_empty) =
                            (Probe::Rgba, Blend::Over, reference, skip);
                        let spec = RenderSpec::new(p, Some(&lut), None, &[]).unwrap();
                        let img = render(&spec, AnyVolume::F32(vol), k).unwrap();
                        for px in img.chunks(4) {
                            if opaque {
                                assert!(px[3] > 0.99, "{k} {px:?}");
                                assert!((px[0] - 1.0).abs() < 1e-5 && (px[1] - 0.25).abs() < 1e-5);
                            } else {
                                assert_eq!(px, [0.0; 4], "{k} cell {cell}");
                            }
                        }
                    }
                }
            }
        }
    }

    /// f = |x|² has isosurfaces that are spheres, κ1 = κ2 = −1/r (the normal −∇f points
    /// inwards), exactly for kernels reproducing quadratics (bspln3 adds a constant, which
    /// changes no derivative). With opacity only where both curvatures are in
    /// [−1, −2/3] (1 ≤ r ≤ 1.5), the `max` of the opacity along a ray down the z axis at
    /// distance d from it is 1 for d < 1.5 and 0 beyond.
    #[test]
    fn curvature_axes_select_a_radius_band() {
        let (data, itow) = sampled(41, 0.1, |x| x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
        let vol = Volume::new(&data, [41; 3], itow).unwrap();
        let axes = [
            LutAxis::new(Quantity::K1, -3.0, 0.0, 90),
            LutAxis::new(Quantity::K2, -3.0, 0.0, 90),
        ];
        let band = Primitive {
            shape: Shape::Box {
                lo: [-1.0, -1.0],
                hi: [-2.0 / 3.0, -2.0 / 3.0],
            },
            rgb: [0.2, 1.0, 0.4],
            alpha: 1.0,
        };
        let lut = Lut::from_primitives(axes, &[band]).unwrap();
        let (half, px) = (1.9, 39u32);
        for k in [KernelName::Bspln3, KernelName::C4hexic] {
            for reference in [true, false] {
                let mut p = view(half, px);
                (p.probe, p.blend, p.reference) = (Probe::Rgba, Blend::Max, reference);
                let spec = RenderSpec::new(p, Some(&lut), None, &[]).unwrap();
                let img = render(&spec, AnyVolume::F32(vol), k).unwrap();
                let (mut inside, mut outside) = (0, 0);
                for y in 0..px {
                    for x in 0..px {
                        let at = |i: u32| (i as f64 + 0.5) / px as f64 * 2.0 * half - half;
                        let d = at(x).hypot(at(y));
                        let a = img[4 * (y * px + x) as usize + 3];
                        if d < 1.35 {
                            assert_eq!(a, 1.0, "{k} -ref {reference} at d {d}");
                            inside += 1;
                        } else if d > 1.65 {
                            assert_eq!(a, 0.0, "{k} -ref {reference} at d {d}");
                            outside += 1;
                        }
                    }
                }
                assert!(inside > 400 && outside > 200, "{inside} {outside}");
            }
        }
    }
}

/// Every pixel of `spec` over `vol` with kernel `k`, four ways: `render` (whose rows skip
/// the rays it reckons miss the volume), each ray through the batched and the one-sample
/// loop untraced, and through the one-sample loop traced (which casts every ray whole).
fn four_ways(spec: &RenderSpec<'_>, vol: AnyVolume<'_>, k: KernelName) -> [Vec<f32>; 4] {
    let [w, h] = spec.size();
    let len = spec.params().probe.length();
    let img = rnd_core::render::render(spec, vol, k).unwrap();
    let mut out = [img, Vec::new(), Vec::new(), Vec::new()];
    for px in 0..w * h {
        let mut r = [[0.0f32; MAX_CHANNELS]; 3];
        spec.cast(
            vol,
            k,
            px % w,
            px / w,
            &mut r[0][..len],
            Loop::Batched,
            None,
        )
        .unwrap();
        spec.cast(
            vol,
            k,
            px % w,
            px / w,
            &mut r[1][..len],
            Loop::OneSample,
            None,
        )
        .unwrap();
        let mut ignore = |_: &SampleInfo| {};
        let trace = Some(&mut ignore as &mut dyn FnMut(&SampleInfo));
        spec.cast(
            vol,
            k,
            px % w,
            px / w,
            &mut r[2][..len],
            Loop::OneSample,
            trace,
        )
        .unwrap();
        for (o, x) in out[1..].iter_mut().zip(&r) {
            o.extend_from_slice(&x[..len]);
        }
    }
    out
}

/// The reference arithmetic builds its camera frame in f32, as the course program does.
/// An up vector whose cross product with the view overflows f32 leaves that frame with
/// zero axes (every ray the central one), and one nearly along the view turns it: its
/// rays then meet the volume through pixels the f64 camera would not send them through.
/// The rays the renderer leaves uncast as missing the volume must miss it in the
/// arithmetic's own frame (found by the render fuzz target: corner pixels were left at
/// the outside value while their rays, cast whole, blended samples).
#[test]
fn rays_left_uncast_miss_the_volume_in_the_reference_frame() {
    let data: Vec<f32> = (0..6 * 7 * 8)
        .map(|i| ((i * 37) % 11) as f32 / 10.0)
        .collect();
    let itow = Affine4::from_columns(
        [0.5, 0.0, 0.1],
        [0.0, 0.4, 0.0],
        [0.0, 0.1, 0.3],
        [-1.0, -1.0, -1.0],
    );
    let vol = AnyVolume::F32(Volume::new(&data, [6, 7, 8], itow).unwrap());
    // A long thin volume, whose image a turned frame moves to other pixels.
    let long: Vec<f32> = (0..24 * 6 * 6)
        .map(|i| ((i * 37) % 11) as f32 / 10.0)
        .collect();
    let diag = Affine4::from_columns(
        [0.5, 0.0, 0.0],
        [0.0, 0.4, 0.0],
        [0.0, 0.0, 0.3],
        [-1.0, -1.0, -1.0],
    );
    let long = AnyVolume::F32(Volume::new(&long, [24, 6, 6], diag).unwrap());
    let cameras = [
        // The fuzz target's input: up's cross product overflows f32.
        CameraSpec {
            from: [-9.005, 5.719, -9.202],
            at: [-0.434, 1.382, 0.0],
            up: [8.492, -3.733, 4.857852309139532e19],
            near: 0.278,
            far: 9.988,
            fov: 28.52,
            size: [6, 2],
            orthographic: false,
        },
        // Up nearly along the view: valid in f64, its frame turned in f32 (the cross
        // product of nearly parallel vectors is all rounding there).
        CameraSpec {
            from: [
                4.75 + 12.0 * 0.2822 + 2e-7,
                -0.4 + 12.0 * 0.3763,
                -0.55 + 12.0 * 0.9407,
            ],
            at: [4.75, -0.4, -0.55],
            up: [0.2822, 0.3763, 0.9407],
            near: -7.0,
            far: 7.0,
            fov: 60.0,
            size: [12, 12],
            orthographic: false,
        },
    ];
    for (i, (camera, vol)) in cameras.into_iter().zip([vol, long]).enumerate() {
        let rc = rnd_core::refarith::RefCamera::new(&camera);
        let c = rnd_core::camera::Camera::new(camera).unwrap();
        let turn = (0..3)
            .map(|a| (f64::from(rc.u[a]) - c.u[a]).abs())
            .fold(0.0, f64::max);
        assert!(
            turn > 0.5,
            "camera {i}: the f32 frame lies near the f64 one ({turn})"
        );
        if i == 0 {
            assert_eq!(rc.u, [0.0; 3], "the f32 frame of camera 0 is degenerate");
        }
        for (probe, blend) in [(Probe::Value, Blend::Sd), (Probe::Value, Blend::Max)] {
            let mut p = RenderParams::new(camera);
            (p.plane_sep, p.probe, p.blend, p.outside) = (0.0857, probe, blend, 8.86);
            p.reference = true;
            let spec = RenderSpec::new(p, None, None, &[]).unwrap();
            for k in [KernelName::Zero, KernelName::Tent, KernelName::Bspln3] {
                let [img, batched, one, traced] = four_ways(&spec, vol, k);
                let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                let what = format!("camera {i}, {probe} {blend}, {k}");
                assert!(
                    traced.iter().any(|&x| x != 8.86),
                    "{what}: no ray meets the volume"
                );
                assert_eq!(bits(&img), bits(&traced), "{what}: render vs traced");
                assert_eq!(bits(&batched), bits(&traced), "{what}: batched vs traced");
                assert_eq!(bits(&one), bits(&traced), "{what}: one-sample vs traced");
            }
        }
    }
}
