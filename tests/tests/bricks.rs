//! Sort-last rendering in bricks (rnd_core::brick), in one process: each brick of a k-d
//! decomposition renders its stretch of every ray from a region of the volume holding
//! only the brick and its ghost layers, and the partials composited in ray order must
//! give the whole volume's image: `max` bit for bit, `sum`, `mean` and `over` within
//! 1e-6 (relative to the pixel's magnitude, at least 1).

use rnd_core::brick::{decompose, ghosts, Brick, Own, Partial};
use rnd_core::camera::CameraSpec;
use rnd_core::kernel::KernelName;
use rnd_core::probe::Probe;
use rnd_core::render::{RenderParams, RenderSpec};
use rnd_core::sdg::{self, Grid};
use rnd_core::volume::Volume;
use rnd_std::parallel::{render, render_part_with, Control};
use rnd_std::volume_io::{load_volume, Samples};

/// The samples of `b` out of a whole volume's `data` of `sizes`.
fn cut<T: Copy>(data: &[T], sizes: [usize; 3], b: &Brick) -> Vec<T> {
    let mut out = Vec::with_capacity(b.voxels());
    for k in b.lo[2]..b.hi[2] {
        for j in b.lo[1]..b.hi[1] {
            let row = sizes[0] * (j + sizes[1] * k);
            out.extend_from_slice(&data[row + b.lo[0]..row + b.hi[0]]);
        }
    }
    out
}

/// The image of `spec` composited from `n` bricks of `whole`, each rendered from its
/// own region (with `threads` threads).
fn bricked(
    spec: &RenderSpec<'_>,
    whole: &rnd_std::volume_io::VolumeBuf,
    kernel: KernelName,
    n: usize,
    threads: usize,
) -> Vec<f32> {
    let grid = whole.sizes();
    let (below, above) = ghosts(kernel);
    let mut parts: Vec<rnd_std::parallel::Parts> = Vec::new();
    for b in decompose(grid, n).unwrap() {
        let g = b.grown(below, above, grid);
        let own = Own::of(&b, grid);
        let itow = whole.itow();
        let p = match whole.data() {
            Samples::F32(d) => {
                let v = cut(d, grid, &g);
                let vol = Volume::region(&v, grid, g, itow).unwrap();
                render_part_with(spec, vol.into(), kernel, &own, threads, &Control::new())
            }
            Samples::I16(d) => {
                let v = cut(d, grid, &g);
                let vol = Volume::region(&v, grid, g, itow).unwrap();
                render_part_with(spec, vol.into(), kernel, &own, threads, &Control::new())
            }
        };
        parts.push(p.unwrap());
    }
    let ch = spec.channels();
    let by_t = spec.params().reference;
    let mut img = vec![0.0f32; parts[0].partials.len() * ch];
    for (px, out) in img.chunks_mut(ch).enumerate() {
        let mut of_px: Vec<Partial> = parts.iter().map(|p| p.partials[px]).collect();
        let lists: Vec<&[f32]> = parts
            .iter()
            .map(|p| p.samples.get(px).map_or(&[][..], Vec::as_slice))
            .collect();
        let whole_ray = Partial::composite_all(&mut of_px, by_t).unwrap();
        whole_ray.finish(spec.params().outside, &lists, out);
    }
    img
}

/// `a` and `b` the same bits (`exact`), or within 1e-6 of the larger magnitude (at
/// least 1).
fn compare(a: &[f32], b: &[f32], exact: bool, what: &str) {
    assert_eq!(a.len(), b.len());
    if exact {
        let same = a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
        assert!(same, "{what}: not bit-identical");
        return;
    }
    let mut worst = 0.0f32;
    for (i, (&x, &y)) in a.iter().zip(b).enumerate() {
        let tol = 1e-6 * x.abs().max(y.abs()).max(1.0);
        assert!(
            (x - y).abs() <= tol || (x.is_nan() && y.is_nan()),
            "{what}: float {i}: {x} vs {y}"
        );
        worst = worst.max((x - y).abs() / x.abs().max(1.0));
    }
    eprintln!("{what}: worst relative difference {worst:e}");
}

fn spec_for<'a>(
    camera: CameraSpec,
    probe: Probe,
    blend: rnd_core::blend::Blend,
    reference: bool,
    lut: Option<&'a rnd_core::txf::Lut>,
    lights: &'a [rnd_core::light::Light],
    tweak: impl FnOnce(&mut RenderParams),
) -> RenderSpec<'a> {
    let mut p = RenderParams::new(camera);
    p.probe = probe;
    p.blend = blend;
    p.reference = reference;
    p.plane_sep = 0.7;
    tweak(&mut p);
    RenderSpec::new(p, lut, None, lights).unwrap()
}

/// A smooth synthetic field (sdg function 1) on a 40 x 33 x 27 grid, rendered in 1 to 5
/// bricks with every blend the bricks support and both arithmetics.
#[test]
fn bricks_reproduce_the_whole_render_of_a_synthetic_volume() {
    use rnd_core::blend::Blend;
    let g = Grid {
        sizes: [40, 33, 27],
        lengths: [2.0; 3],
        shear: [0.0; 3],
        rot: [0.1, 0.2, 0.0],
        centre: [0.0; 3],
    };
    let (v, itow) = sdg::generate(1, &g).unwrap();
    let data: Vec<f32> = v.iter().map(|&x| x as f32).collect();
    let whole = rnd_std::volume_io::VolumeBuf::new(
        rnd_std::volume_io::VolumeData::F32(data),
        g.sizes,
        itow,
    )
    .unwrap();
    let cams = [
        // Perspective from off an axis, and an orthographic view along one.
        CameraSpec::looking_at([4.0, 3.0, 2.5], [0.0; 3]).size(37, 29),
        CameraSpec::looking_at([0.0, 0.0, 5.0], [0.0; 3])
            .size(31, 23)
            .orthographic(true),
    ];
    let lut = rnd_core::txf::Lut::new(
        -1.0,
        1.0,
        (0..32)
            .map(|i| {
                let t = i as f32 / 31.0;
                [t, 1.0 - t, 0.5, if i < 12 { 0.0 } else { 0.08 * t }]
            })
            .collect(),
    )
    .unwrap();
    // Convolved probes, probes counted everywhere (in, positions), several channels
    // (the gradient vector, the Hessian) and the f64 statistics.
    let cases: [(Probe, Blend); 14] = [
        (Probe::Value, Blend::Median),
        (Probe::GradVec, Blend::Median),
        (Probe::Value, Blend::Max),
        (Probe::GradMag, Blend::Max),
        (Probe::Value, Blend::Min),
        (Probe::Value, Blend::Sum),
        (Probe::Value, Blend::Mean),
        (Probe::Rgba, Blend::Over),
        (Probe::Inside, Blend::Sum),
        (Probe::PosWorld, Blend::Max),
        (Probe::GradVec, Blend::Mean),
        (Probe::Hess, Blend::Min),
        (Probe::Value, Blend::Variance),
        (Probe::K1, Blend::L2),
    ];
    for cam in cams {
        for kernel in [KernelName::Tent, KernelName::Bspln3, KernelName::Bspln2] {
            for (probe, blend) in cases {
                for reference in [true, false] {
                    let lut = (probe == Probe::Rgba).then_some(&lut);
                    let spec = spec_for(cam, probe, blend, reference, lut, &[], |_| {});
                    let one = render(&spec, whole.view(), kernel, 1).unwrap();
                    for n in 1..=5 {
                        let what = format!("{probe} {blend} {kernel} ref {reference} n {n}");
                        let b = bricked(&spec, &whole, kernel, n, 1 + n % 2);
                        let exact = matches!(blend, Blend::Max | Blend::Min | Blend::Median);
                        compare(&one, &b, exact, &what);
                    }
                }
            }
        }
    }
}

/// The bundled MRI head (i16), lit `over` with its LUT and lights and a value MIP, in 2
/// to 4 bricks: the README's picture and a MIP.
#[test]
fn bricks_reproduce_the_bundled_head() {
    use rnd_core::blend::Blend;
    let root = rnd_tests::root();
    let head = load_volume(&root.join("data/itk-t1-head.nrrd")).unwrap();
    let lut = rnd_std::files::load_lut(&root.join("data/head-lut.nrrd")).unwrap();
    let lights = rnd_std::files::load_lights(&root.join("data/head-lights.txt")).unwrap();
    let mut cam = CameraSpec::looking_at([323.0, -12.5, 260.0], [-127.0, -162.5, 110.0]);
    cam.up = [0.0, 0.0, 1.0];
    cam.near = -150.0;
    cam.far = 150.0;
    cam.size = [96, 96];
    let lit = |reference| {
        spec_for(
            cam,
            Probe::RgbaLit,
            Blend::Over,
            reference,
            Some(&lut),
            &lights,
            |p| {
                p.plane_sep = 1.0;
                p.unit_step = 2.0;
            },
        )
    };
    let mip = |reference| spec_for(cam, Probe::Value, Blend::Max, reference, None, &[], |_| {});
    for reference in [true, false] {
        for (spec, exact) in [(lit(reference), false), (mip(reference), true)] {
            let one = render(&spec, head.view(), KernelName::Bspln3, 2).unwrap();
            assert!(
                one.iter().any(|&x| x > 0.1),
                "an image with something in it"
            );
            for n in 2..=4 {
                let b = bricked(&spec, &head, KernelName::Bspln3, n, 2);
                let what = format!("head {} ref {reference} n {n}", spec.params().blend);
                compare(&one, &b, exact, &what);
            }
        }
    }
}

/// Partials check their stretches: overlaps and gaps are refused.
#[test]
fn partials_composite_only_adjacent_stretches() {
    use rnd_core::blend::Blend;
    let a = Partial {
        first: 0,
        end: 5,
        ..Partial::empty(Blend::Sum, 1)
    };
    let b = Partial {
        first: 3,
        end: 9,
        ..a
    };
    assert!(a.composite(&b, false).is_err(), "overlapping stretches");
    let c = Partial {
        first: 6,
        end: 9,
        ..a
    };
    assert!(Partial::composite_all(&mut [a, c], false).is_err(), "a gap");
    let d = Partial {
        first: 5,
        end: 9,
        ..a
    };
    assert_eq!(Partial::composite_all(&mut [d, a], false).unwrap().end, 9);
}

/// A region read from a NRRD (raw little- and big-endian, gzip, bzip2, a detached data
/// file, a byte skip, 16-bit, float and 8-bit samples, a leading axis of 1) holds the
/// samples and geometry of the same box of the whole volume, read in parts; a region
/// outside the grid is refused.
#[test]
fn region_reads_hold_the_box_of_the_whole_volume() {
    use rnd_std::nrrd::{self, Data, Encoding, Endian, Nrrd, WriteOptions};
    use rnd_std::volume_io::load_volume_region;
    let dir = std::env::temp_dir().join(format!("rendr-bricks-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let sizes = [13usize, 9, 11];
    let n = sizes.iter().product::<usize>();
    let datas = [
        Data::I16((0..n).map(|i| (i as i16).wrapping_mul(37)).collect()),
        Data::F32((0..n).map(|i| (i as f32).sin() * 100.0).collect()),
        Data::U8((0..n).map(|i| (i * 7 % 251) as u8).collect()),
    ];
    let mut files = Vec::new();
    for (d, data) in datas.into_iter().enumerate() {
        for (e, (encoding, endian)) in [
            (Encoding::Raw, Endian::Little),
            (Encoding::Raw, Endian::Big),
            (Encoding::Gzip, Endian::Little),
            (Encoding::Bzip2, Endian::Big),
        ]
        .into_iter()
        .enumerate()
        {
            let lead = e == 1;
            let sz: Vec<usize> = if lead {
                std::iter::once(1).chain(sizes).collect()
            } else {
                sizes.to_vec()
            };
            let mut a = Nrrd::new(sz, data.clone()).unwrap();
            let dirs = [[0.5, 0.1, 0.0], [0.0, 0.7, 0.2], [0.1, 0.0, 0.9]];
            let mut sd: Vec<Option<Vec<f64>>> = dirs.iter().map(|d| Some(d.to_vec())).collect();
            if lead {
                sd.insert(0, None);
            }
            a.header.space_directions = Some(sd);
            a.header.space_origin = Some(vec![1.0, -2.0, 3.5]);
            a.header.space_dimension = Some(3);
            let p = dir.join(format!("v{d}{e}.nrrd"));
            nrrd::write(&a, &p, WriteOptions { encoding, endian }).unwrap();
            files.push(p);
        }
    }
    // A detached raw data file after a byte skip.
    let raw: Vec<u8> = (0..n).flat_map(|i| (i as i16).to_le_bytes()).collect();
    let mut bytes = b"junk!".to_vec();
    bytes.extend(&raw);
    std::fs::write(dir.join("d.raw"), &bytes).unwrap();
    std::fs::write(
        dir.join("d.nhdr"),
        "NRRD0004\ntype: short\ndimension: 3\nsizes: 13 9 11\nencoding: raw\n\
         endian: little\nbyte skip: 5\ndata file: d.raw\n",
    )
    .unwrap();
    files.push(dir.join("d.nhdr"));
    for f in &files {
        let whole = load_volume(f).unwrap();
        assert_eq!(whole.sizes(), sizes, "{}", f.display());
        for n in [1, 2, 3, 5] {
            for b in decompose(sizes, n).unwrap() {
                let g = b.grown(2, 3, sizes);
                let r = load_volume_region(f, 1, |grid| {
                    assert_eq!(grid, sizes);
                    Ok(g)
                })
                .unwrap();
                assert!(r.partial_read, "{}", f.display());
                assert_eq!((r.grid, r.region), (sizes, g));
                assert_eq!(r.buf.itow(), whole.itow(), "{}", f.display());
                assert_eq!(r.view().unwrap().grid(), sizes);
                match (whole.data(), r.buf.data()) {
                    (Samples::F32(a), Samples::F32(b)) => assert!(cut(a, sizes, &g) == b),
                    (Samples::I16(a), Samples::I16(b)) => assert!(cut(a, sizes, &g) == b),
                    _ => panic!("{}: sample types differ", f.display()),
                }
            }
        }
        let bad = Brick {
            lo: [0, 0, 0],
            hi: [14, 9, 11],
        };
        let e = load_volume_region(f, 1, |_| Ok(bad)).unwrap_err();
        assert!(e.to_string().contains("leaves the grid"), "{e}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
