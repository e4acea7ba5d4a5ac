//! The embedding API (rnd-core and rnd-std as a library): every bad parameter, an image
//! too large for memory and a volume beyond the f32 arithmetic give an error of the
//! right kind, naming the parameter, never a panic or an abort; progress and
//! cancellation; the builders agree with the plain constructors.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use rnd_core::prelude::*;
use rnd_std::parallel::{render_with, Control, Progress};

fn cam() -> CameraSpec {
    CameraSpec::looking_at([0.0, 0.0, 10.0], [0.0; 3])
        .up([0.0, 1.0, 0.0])
        .clip(-4.0, 4.0)
        .size(8, 8)
}

fn ones() -> OwnedVolume<f32> {
    OwnedVolume::from_fn([6; 3], Affine4::from_spacing([1.0; 3], [-2.5; 3]), |_| 1.0).unwrap()
}

/// Each bad parameter: the error's kind and parameter.
#[test]
fn bad_parameters_name_their_kind_and_parameter() {
    let lut = Lut::new(0.0, 1.0, vec![[1.0; 4]]).unwrap();
    let light = [Light::new([1.0; 3], [0.0, 0.0, 1.0], LightSpace::View).unwrap()];
    type Edit = fn(&mut RenderParams);
    let cases: &[(Edit, ErrorKind, Param)] = &[
        (
            |p| p.camera.fov = 170.0,
            ErrorKind::Camera,
            Param::CameraFov,
        ),
        (
            |p| p.camera.size = [0, 8],
            ErrorKind::Camera,
            Param::ImageSize,
        ),
        (
            |p| p.camera.up = [0.0, 0.0, 1.0],
            ErrorKind::Camera,
            Param::CameraUp,
        ),
        (
            |p| p.camera.from = [0.0; 3],
            ErrorKind::Camera,
            Param::CameraFrom,
        ),
        (
            |p| p.camera.at = [f64::NAN; 3],
            ErrorKind::Camera,
            Param::CameraAt,
        ),
        (
            |p| p.camera.near = 5.0,
            ErrorKind::Camera,
            Param::CameraNear,
        ),
        (
            |p| p.camera.far = f64::INFINITY,
            ErrorKind::Camera,
            Param::CameraFar,
        ),
        (|p| p.plane_sep = -1.0, ErrorKind::Render, Param::PlaneSep),
        (|p| p.plane_sep = 1e-9, ErrorKind::Render, Param::PlaneSep),
        (|p| p.unit_step = 0.0, ErrorKind::Render, Param::UnitStep),
        (
            |p| p.alpha_near1 = 1.5,
            ErrorKind::Render,
            Param::AlphaNear1,
        ),
        (|p| p.phong.p = -1.0, ErrorKind::Render, Param::Phong),
        (
            |p| p.dcn = [f32::NAN; 3],
            ErrorKind::Render,
            Param::DepthCue,
        ),
        (|p| p.probe = Probe::Value, ErrorKind::Render, Param::Blend),
        (
            |p| p.unit_step = 1e-300,
            ErrorKind::Render,
            Param::Reference,
        ),
        (
            |p| p.camera.size = [u32::MAX; 2],
            ErrorKind::Memory,
            Param::ImageSize,
        ),
    ];
    for (i, (edit, kind, param)) in cases.iter().enumerate() {
        let mut p = RenderParams::new(cam());
        (p.probe, p.blend) = (Probe::Rgba, Blend::Over);
        edit(&mut p);
        let e = RenderSpec::new(p, Some(&lut), None, &light).unwrap_err();
        assert_eq!((e.kind, e.param), (*kind, Some(*param)), "case {i}: {e}");
        // Library terms, not the CLI's options.
        assert!(!e.msg.starts_with('-'), "case {i}: {e}");
    }
    let mut p = RenderParams::new(cam());
    p.probe = Probe::RgbaLit;
    let e = RenderSpec::new(p.clone(), None, None, &light).unwrap_err();
    assert_eq!(e.param, Some(Param::Lut), "{e}");
    let e = RenderSpec::new(p, Some(&lut), None, &[]).unwrap_err();
    assert_eq!(e.param, Some(Param::Lights), "{e}");
}

/// An image that fits no memory is refused before anything is allocated: by the core
/// (which cannot know the machine) through a fallible reservation, by rnd-std against
/// the process's memory limit first; the kind is Memory either way.
#[test]
fn huge_images_are_errors_not_aborts() {
    let vol = ones();
    let spec = RenderSpec::new(
        RenderParams::new(cam().size(1 << 20, 1 << 20)),
        None,
        None,
        &[],
    )
    .unwrap();
    let e = rnd_std::parallel::render(&spec, vol.view().into(), KernelName::Tent, 2).unwrap_err();
    assert_eq!(e.kind, rnd_std::ErrorKind::Memory, "{e}");
    assert_eq!(e.param, Some(Param::ImageSize), "{e}");
    assert!(e.msg.contains("1048576 x 1048576"), "{e}");
    // The core alone: 4 TiB is more than the system gives (overcommit refuses it).
    let e = render(&spec, vol.view().into(), KernelName::Tent).unwrap_err();
    assert_eq!(
        (e.kind, e.param),
        (ErrorKind::Memory, Some(Param::ImageSize)),
        "{e}"
    );
}

/// The reference arithmetic compares index bounds in f32: an axis of 2^24 samples is a
/// Volume error (the f64 arithmetic renders it).
#[test]
fn axes_beyond_f32_are_volume_errors() {
    let vol =
        OwnedVolume::from_vec(vec![0i16; 1 << 24], [1 << 24, 1, 1], Affine4::IDENTITY).unwrap();
    let mut p = RenderParams::new(cam());
    let spec = RenderSpec::new(p.clone(), None, None, &[]).unwrap();
    let e = render(&spec, vol.view().into(), KernelName::Tent).unwrap_err();
    assert_eq!(
        (e.kind, e.param),
        (ErrorKind::Volume, Some(Param::Volume)),
        "{e}"
    );
    let e = rnd_std::parallel::render(&spec, vol.view().into(), KernelName::Tent, 1).unwrap_err();
    assert_eq!(e.kind, rnd_std::ErrorKind::Core(ErrorKind::Volume), "{e}");
    p.reference = false;
    let spec = RenderSpec::new(p, None, None, &[]).unwrap();
    assert!(render(&spec, vol.view().into(), KernelName::Tent).is_ok());
}

/// Bad volumes, transfer functions and lights: kinds, no panics.
#[test]
fn bad_inputs_have_kinds() {
    let e = OwnedVolume::from_vec(vec![0.0f32; 7], [2, 2, 2], Affine4::IDENTITY).unwrap_err();
    assert_eq!(e.kind, ErrorKind::Volume);
    let singular = Affine4::from_spacing([1.0, 0.0, 1.0], [0.0; 3]);
    let e = OwnedVolume::from_vec(vec![0.0f32; 8], [2, 2, 2], singular).unwrap_err();
    assert_eq!(e.kind, ErrorKind::Volume);
    let e = OwnedVolume::<i16>::from_fn([usize::MAX, 2, 2], Affine4::IDENTITY, |_| 0).unwrap_err();
    assert_eq!(e.kind, ErrorKind::Memory);
    assert_eq!(Txf::alpha(&[]).unwrap_err().kind, ErrorKind::Txf);
    let e = Lut::builder(1.0, 1.0).build().unwrap_err();
    assert_eq!((e.kind, e.param), (ErrorKind::Txf, Some(Param::LutDomain)));
    let rgb = Txf::rgb(&[[0.0, 1.0, 1.0, 1.0]]).unwrap();
    assert_eq!(
        Lut::builder(0.0, 1.0)
            .opacity(&rgb)
            .build()
            .unwrap_err()
            .kind,
        ErrorKind::Txf
    );
    assert_eq!(
        Lut::builder(0.0, 1.0).entries(0).build().unwrap_err().kind,
        ErrorKind::Txf
    );
    let e = Light::new([1.0; 3], [f64::NAN; 3], LightSpace::World).unwrap_err();
    assert_eq!(e.kind, ErrorKind::Light);
    // rnd-std keeps the core's kind and parameter.
    let e = rnd_std::Error::from(Lut::builder(2.0, 1.0).build().unwrap_err());
    assert_eq!(e.kind, rnd_std::ErrorKind::Core(ErrorKind::Txf));
    assert_eq!(e.param, Some(Param::LutDomain));
    // A file that is not there: Io, naming it.
    let e = rnd_std::volume_io::load_volume("no/such/volume.nrrd".as_ref()).unwrap_err();
    assert_eq!(e.kind, rnd_std::ErrorKind::Io);
    assert!(e.to_string().contains("no/such/volume.nrrd"), "{e}");
}

/// The builder makes the LUT the positional generator makes.
#[test]
fn lut_builder_is_generate() {
    let c = Txf::hsv(&[[0.0, 0.0, 1.0, 1.0], [2.0, 0.6, 0.5, 0.8]]).unwrap();
    let a = Txf::alpha(&[[0.0, 0.0], [1.0, 0.3], [2.0, 1.0]]).unwrap();
    for (cs, as_) in [(false, false), (true, false), (false, true), (true, true)] {
        let mut b = Lut::builder(-1.0, 5.0).entries(77);
        b = if cs {
            b.colour_stretched(&c)
        } else {
            b.colour(&c)
        };
        b = if as_ {
            b.opacity_stretched(&a)
        } else {
            b.opacity(&a)
        };
        let g = Lut::generate(Some(&c), Some(&a), cs, as_, 77, -1.0, 5.0).unwrap();
        assert_eq!(b.build().unwrap(), g);
    }
}

/// Progress reaches every row once, in bands of up to eight rows; a set flag cancels (kind Cancelled) and the same
/// render without it gives the image `render` gives, for any thread count.
#[test]
fn progress_and_cancellation() {
    let vol = ones();
    let spec = RenderSpec::new(RenderParams::new(cam().size(16, 37)), None, None, &[]).unwrap();
    let plain = render(&spec, vol.view().into(), KernelName::Bspln3).unwrap();
    for threads in [1, 3] {
        let rows = AtomicUsize::new(0);
        let last = AtomicUsize::new(0);
        let f = |p: Progress| {
            assert_eq!(p.rows, 37);
            rows.fetch_add(1, Ordering::Relaxed);
            last.fetch_max(p.rows_done, Ordering::Relaxed);
        };
        let c = Control::new().on_progress(&f);
        let img = render_with(&spec, vol.view().into(), KernelName::Bspln3, threads, &c).unwrap();
        assert_eq!(img, plain);
        assert_eq!(last.load(Ordering::Relaxed), 37);
        // One report per band of rows: eight at a time from a thread's own run but never
        // more than half of what is left of it (rounded up), single rows taken from
        // another's (one thread: 8, 8, 8, 7, 3, 2, 1).
        let reports = rows.load(Ordering::Relaxed);
        if threads == 1 {
            assert_eq!(reports, 7);
        } else {
            assert!((37usize.div_ceil(8)..=37).contains(&reports), "{reports}");
        }
        // Cancelled from the first progress report on: the render stops with an error.
        let stop = AtomicBool::new(false);
        let g = |_: Progress| stop.store(true, Ordering::Relaxed);
        let c = Control::new().on_progress(&g).cancel_flag(&stop);
        let e = render_with(&spec, vol.view().into(), KernelName::Bspln3, threads, &c).unwrap_err();
        assert_eq!(e.kind, rnd_std::ErrorKind::Cancelled, "{e}");
    }
}

/// Framing puts the whole volume in view: every corner projects inside the image.
#[test]
fn framing_shows_every_corner() {
    let geom = Affine4::from_columns(
        [0.9, 0.1, 0.0],
        [0.0, 1.2, 0.3],
        [0.2, 0.0, 2.5],
        [4.0, -3.0, 7.0],
    );
    let vol = OwnedVolume::from_fn([20, 30, 12], geom, |_| 0i16).unwrap();
    let corners = vol.view().world_corners();
    for dir in [
        [1.0, 0.0, 0.0],
        [0.0, -1.0, 0.2],
        [1.0, 1.0, 1.0],
        [0.0, 0.0, -1.0],
    ] {
        for ortho in [false, true] {
            let spec = CameraSpec::framing(&corners, dir)
                .unwrap()
                .orthographic(ortho)
                .size(64, 48);
            let cam = Camera::new(spec).unwrap();
            for c in corners {
                let (x, y) = cam.project(c);
                assert!(
                    (-0.5..63.5).contains(&x) && (-0.5..47.5).contains(&y),
                    "{dir:?} {ortho}: {x} {y}"
                );
                // Along the view direction (−n) from the look-at point.
                let depth =
                    -rnd_core::math::v3::dot(rnd_core::math::v3::sub(c, spec.at), cam.n.to_array());
                assert!(depth > spec.near && depth < spec.far, "{depth}");
            }
        }
    }
    assert!(CameraSpec::framing(&[], [1.0, 0.0, 0.0]).is_none());
    assert!(CameraSpec::framing(&corners, [0.0; 3]).is_none());
}

/// What the lower-level calls are handed in the wrong shape is refused with a Render
/// error, never a panic: `cast` of a pixel outside the image or into room shorter than
/// the probe, `render_rows` and `render_part_rows` of rows outside the image or with
/// outputs of the wrong length; and the pieces they are made of stay total (`Accum`
/// finishing into little room, a `Lanes` batch full, outside its volume, or empty).
#[test]
fn misshapen_calls_are_errors_not_panics() {
    use rnd_core::blend::{Accum, MAX_CHANNELS};
    use rnd_core::brick::{Brick, Own, Partial};
    use rnd_core::march::Loop;
    use rnd_core::refarith::Lanes;
    use rnd_core::simd::Simd;
    let vol = ones();
    let v = vol.view();
    let lut = Lut::new(0.0, 1.0, vec![[1.0, 1.0, 1.0, 0.0], [1.0, 0.5, 0.2, 0.5]]).unwrap();
    let light = [Light::new([1.0; 3], [0.0, 0.0, 1.0], LightSpace::View).unwrap()];
    let render_err = |r: rnd_core::Result<()>| {
        let e = r.unwrap_err();
        assert_eq!(e.kind, ErrorKind::Render, "{e}");
        e.msg
    };
    for over in [false, true] {
        let mut p = RenderParams::new(cam());
        if over {
            (p.probe, p.blend) = (Probe::RgbaLit, Blend::Over);
        }
        let spec = RenderSpec::new(p, Some(&lut), None, &light).unwrap();
        let plen = spec.params().probe.length();
        let ch = spec.channels();
        for k in [KernelName::Tent, KernelName::Bspln3] {
            let whole = render(&spec, v.into(), k).unwrap();
            // cast: the pixel's result at the front of room that holds it.
            let mut room = [f32::NAN; MAX_CHANNELS];
            spec.cast(v.into(), k, 3, 5, &mut room, Loop::Batched, None)
                .unwrap();
            assert_eq!(&room[..plen], &whole[(5 * 8 + 3) * ch..][..plen]);
            assert!(room[plen..].iter().all(|x| x.is_nan()));
            let short = &mut room[..plen - 1];
            let m = render_err(spec.cast(v.into(), k, 3, 5, short, Loop::OneSample, None));
            assert!(
                m.contains("pixel (3, 5)") && m.contains(&format!("take {plen}")),
                "{m}"
            );
            for (hi, vi) in [(8, 0), (0, 8), (u32::MAX, u32::MAX)] {
                let m = render_err(spec.cast(v.into(), k, hi, vi, &mut room, Loop::Batched, None));
                assert!(m.contains("8 x 8 image"), "{m}");
            }
            // render_rows: exactly the rows' floats, rows within the image.
            let grid = spec.skip_grid(&v, k);
            let mut rows = vec![0.0f32; 3 * 8 * ch];
            spec.render_rows(v.into(), k, grid.as_ref(), 2..5, &mut rows, None)
                .unwrap();
            assert_eq!(rows, whole[2 * 8 * ch..5 * 8 * ch]);
            for (r, len) in [
                (2..5, 3 * 8 * ch - 1),
                (2..5, 3 * 8 * ch + 1),
                (7..9, 2 * 8 * ch),
            ] {
                let mut out = vec![0.0f32; len];
                let m = render_err(spec.render_rows(v.into(), k, grid.as_ref(), r, &mut out, None));
                assert!(m.contains(&format!("{len} floats")), "{m}");
            }
            #[allow(clippy::reversed_empty_ranges)]
            let m = render_err(spec.render_rows(v.into(), k, None, 5..2, &mut [], None));
            assert!(m.contains("rows 5..2"), "{m}");
            // render_part_rows: one partial a pixel of rows within the image.
            let own = Own::of(&Brick::whole([6; 3]), [6; 3]);
            let mut parts = vec![Partial::empty(spec.params().blend, plen); 8];
            spec.render_part_rows(v.into(), k, None, &own, 7..8, &mut parts, &mut [], None)
                .unwrap();
            let m = render_err(spec.render_part_rows(
                v.into(),
                k,
                None,
                &own,
                8..9,
                &mut parts,
                &mut [],
                None,
            ));
            assert!(m.contains("8 partials for rows 8..9"), "{m}");
            parts.pop();
            render_err(spec.render_part_rows(
                v.into(),
                k,
                None,
                &own,
                7..8,
                &mut parts,
                &mut [],
                None,
            ));
        }
    }
    // An `over` blend finished into less room than its four channels: what fits.
    let mut a = Accum::new(Blend::Over, 4);
    let mut x = [0.0f32; MAX_CHANNELS];
    x[..4].copy_from_slice(&[1.0, 0.5, 0.25, 0.5]);
    a.add(&x);
    let (mut four, mut two) = ([0.0f32; 4], [0.0f32; 2]);
    a.finish(0.0, None, &mut four);
    a.finish(0.0, None, &mut two);
    assert_eq!(two, four[..2]);
    // A batch of lanes takes at most LANES samples, only supports inside its volume, and
    // an empty batch (or a volume not holding its supports) convolves nothing.
    let mut lanes = Lanes::<2>::default();
    let mut out = [[f32::NAN; 4]; rnd_core::refarith::LANES];
    assert!(!lanes.convolve::<f32, rnd_core::kernel::Tent, false>(&v, Simd::detect(), &mut out));
    assert!(out.iter().flatten().all(|x| x.is_nan()));
    for n in [[5, 0, 0], [0, -1, 0], [0, 0, i64::MAX]] {
        assert!(!lanes.push_placed(&v, n, [0.5; 3]), "{n:?}");
    }
    for _ in 0..rnd_core::refarith::LANES {
        assert!(lanes.push_placed(&v, [4, 4, 4], [0.5; 3]));
    }
    assert!(!lanes.push_placed(&v, [0; 3], [0.5; 3]));
    assert!(!lanes.push::<f32, rnd_core::kernel::Tent>(&v, [1.0; 3]));
    let small = OwnedVolume::from_fn([2; 3], Affine4::IDENTITY, |_| 1.0f32).unwrap();
    assert!(!lanes.convolve::<f32, rnd_core::kernel::Tent, false>(
        &small.view(),
        Simd::detect(),
        &mut out
    ));
    assert!(lanes.convolve::<f32, rnd_core::kernel::Tent, false>(&v, Simd::detect(), &mut out));
    assert!(out.iter().all(|o| o[0] == 1.0), "{out:?}");
}

/// The image writers check shapes before they encode or write: samples that do not fill
/// the image (or an image of no channels), pixels that do not fill a PNG, and a PNG size
/// outside 1..2^32 are Output errors, never a panic, and nothing is written.
#[test]
fn misshapen_images_are_errors_not_panics() {
    use rnd_std::image_out::{encode_apng, encode_png, png_bytes, write_image, Image, PngColor};
    use rnd_std::ErrorKind;
    let img = |data: Vec<f32>, channels, size| Image {
        data,
        channels,
        size,
    };
    let good = img(vec![0.5; 2 * 3 * 4], 4, [2, 3]);
    assert!(png_bytes(&good, None).is_ok());
    let dir = std::env::temp_dir().join(format!("rnd-api-img-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (bad, what) in [
        (img(vec![0.5; 23], 4, [2, 3]), "23 samples"),
        (img(vec![0.5; 25], 4, [2, 3]), "25 samples"),
        (img(vec![0.5; 6], 0, [2, 3]), "0 channels"),
        (img(vec![0.5; 6], 1, [usize::MAX, 3]), "6 samples"),
    ] {
        let e = png_bytes(&bad, None).unwrap_err();
        assert_eq!(e.kind, ErrorKind::Output, "{e}");
        assert!(e.to_string().contains(what), "{e}");
        for name in ["x.png", "x.nrrd"] {
            let e = write_image(bad.clone(), &dir.join(name), "x", None).unwrap_err();
            assert_eq!(e.kind, ErrorKind::Output, "{e}");
            assert!(!dir.join(name).exists());
        }
    }
    assert!(std::fs::read_dir(&dir).unwrap().next().is_none());
    std::fs::remove_dir_all(&dir).unwrap();
    // Pixels for a PNG: exactly w·h (grey) or 3·w·h (RGB) bytes, sides in 1..2^32.
    assert!(encode_png(&[7; 6], 2, 3, PngColor::Grey).is_ok());
    assert!(encode_png(&[7; 18], 2, 3, PngColor::Rgb).is_ok());
    for (buf, w, h, c) in [
        (vec![7; 5], 2, 3, PngColor::Grey),
        (vec![7; 6], 2, 3, PngColor::Rgb),
        (vec![], 0, 3, PngColor::Grey),
        (vec![7; 2], (1 << 32) + 1, 1, PngColor::Grey),
        (vec![7; 2], usize::MAX, 2, PngColor::Rgb),
    ] {
        let e = encode_png(&buf, w, h, c).unwrap_err();
        assert_eq!(e.kind, ErrorKind::Output, "{e}");
        let e = encode_apng(&[buf], w, h, c, 10).unwrap_err();
        assert_eq!(e.kind, ErrorKind::Output, "{e}");
    }
}
