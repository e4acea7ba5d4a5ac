//! Classification over two quantities, checked analytically: a LUT axis over the
//! gradient magnitude sees the slope of a ramp, and LUT axes over the principal
//! curvatures see the radius of the spheres of |x|².

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
