//! The verification guide's experiments (docs/VERIFICATION.md): re-runs
//! docs/make-figures.sh with the current binary, checks the committed figures are exactly
//! what the code makes now, and asserts each experiment's prediction on the pictures.

use std::path::{Path, PathBuf};
use std::process::Command;

use rnd_core::camera::{Camera, CameraSpec};

fn grey(p: &Path) -> (u32, u32, Vec<f32>) {
    let img = image::open(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    let (w, h) = (img.width(), img.height());
    let rgb = img.to_rgb8();
    let v = rgb
        .pixels()
        .map(|p| (p[0] as f32 + p[1] as f32 + p[2] as f32) / (3.0 * 255.0))
        .collect();
    (w, h, v)
}

/// Brightest pixel within `r` of (x, y).
fn peak_near(img: &(u32, u32, Vec<f32>), x: f64, y: f64, r: i64) -> (i64, i64) {
    let (w, h, v) = img;
    let mut best = (0, 0, f32::MIN);
    for yy in (y as i64 - r).max(0)..=(y as i64 + r).min(*h as i64 - 1) {
        for xx in (x as i64 - r).max(0)..=(x as i64 + r).min(*w as i64 - 1) {
            let val = v[(xx + *w as i64 * yy) as usize];
            if val > best.2 {
                best = (xx, yy, val);
            }
        }
    }
    (best.0, best.1)
}

/// Width and height (pixels) of the region brighter than `t`.
fn extent(img: &(u32, u32, Vec<f32>), t: f32) -> (u32, u32) {
    let (w, h, v) = img;
    let (mut x0, mut x1, mut y0, mut y1) = (u32::MAX, 0, u32::MAX, 0);
    for y in 0..*h {
        for x in 0..*w {
            if v[(x + w * y) as usize] > t {
                x0 = x0.min(x);
                x1 = x1.max(x);
                y0 = y0.min(y);
                y1 = y1.max(y);
            }
        }
    }
    (x1 + 1 - x0, y1 + 1 - y0)
}

#[test]
fn figures_are_current_and_experiments_hold() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let out = rnd_tests::tmpdir("figures");
    let st = Command::new("bash")
        .arg(root.join("docs/make-figures.sh"))
        .arg(&out)
        .env("RENDR", env!("CARGO_BIN_EXE_rendr"))
        .status()
        .unwrap();
    assert!(st.success());
    // The committed figures are exactly what the current code makes.
    let committed = root.join("docs/figures");
    let mut n = 0;
    for e in std::fs::read_dir(&out).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap();
        let old = std::fs::read(committed.join(name))
            .unwrap_or_else(|_| panic!("docs/figures/{name:?} missing: run docs/make-figures.sh"));
        assert!(
            old == std::fs::read(&p).unwrap(),
            "docs/figures/{name:?} is stale: run docs/make-figures.sh"
        );
        n += 1;
    }
    assert!(n >= 40, "{n} figures");
    let f = |name: &str| grey(&out.join(name));

    // 1a. Marker: blobs where the camera model puts them; up is up.
    for (file, up) in [
        ("cam-marker.png", [0.0, 0.0, 1.0]),
        ("cam-marker-upx.png", [1.0, 0.0, 0.0]),
    ] {
        let cam = Camera::new(CameraSpec {
            from: [0., -5., 0.],
            at: [0.; 3],
            up,
            near: -1.5,
            far: 1.5,
            fov: 20.,
            size: [200, 200],
            orthographic: false,
        })
        .unwrap();
        let img = f(file);
        for blob in [[0.0, 0.0, 0.0], [0.6, 0.0, 0.0], [0.0, 0.0, 0.6]] {
            let (px, py) = cam.project(blob);
            let (bx, by) = peak_near(&img, px, py, 8);
            assert!(
                (bx as f64 - px).abs() <= 1.5 && (by as f64 - py).abs() <= 1.5,
                "{file} blob {blob:?}: peak ({bx},{by}) predicted ({px:.1},{py:.1})"
            );
        }
        // The look-at point (the origin blob) is the image centre; the "up" blob is above it.
        let (cx, cy) = cam.project([0.0; 3]);
        assert!((cx - 99.5).abs() < 1e-9 && (cy - 99.5).abs() < 1e-9);
        let upblob = if up[2] == 1.0 {
            [0.0, 0.0, 0.6]
        } else {
            [0.6, 0.0, 0.0]
        };
        let (ux, uy) = cam.project(upblob);
        assert!((ux - cx).abs() < 1e-9 && uy < cy - 20.0);
    }
    // 1b. Aspect ratio: the sphere is round in a 2:1 image.
    let (w, h) = extent(&f("cam-aspect.png"), 0.05);
    assert!((w as i64 - h as i64).abs() <= 2, "sphere {w} x {h} pixels");
    // 1c. FOV: radius 0.5 at distance 6 (silhouette slightly larger: asin) spans
    // 150 * 2 r' / (2 * 6 * tan(fov / 2)) pixels; 14 degrees gives about twice 28's.
    let r = 0.5 / (1.0f64 - (0.5f64 / 6.0).powi(2)).sqrt();
    for fov in [14.0f64, 28.0] {
        let (w, _) = extent(&f(&format!("cam-fov{fov}.png")), 0.05);
        let want = 150.0 * 2.0 * r / (2.0 * 6.0 * (fov / 2.0).to_radians().tan());
        assert!(
            (w as f64 - want).abs() <= 3.0,
            "fov {fov}: {w} px, predicted {want:.1}"
        );
    }
    // 2. Levoy: the same shell at |grad| = 1 and |grad| = 10.
    let (a, b) = (f("levoy-g1.png"), f("levoy-g10.png"));
    let worst =
        a.2.iter()
            .zip(&b.2)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0f32, f32::max);
    assert!(worst <= 2.0 / 255.0, "Levoy images differ by {worst}");
    assert!(a.2.iter().filter(|&&x| x > 0.1).count() > 1000);
    // 3. Opacity correction: -s 0.04 and -s 0.01 with the same -us look the same.
    let (a, b) = (f("oc-s0.04.png"), f("oc-s0.01.png"));
    let mean: f32 =
        a.2.iter()
            .zip(&b.2)
            .map(|(x, y)| (x - y).abs())
            .sum::<f32>()
            / a.2.len() as f32;
    assert!(mean < 0.01, "mean difference {mean}");
    // 4. Specular highlight where N = H = normalize(L + V), on the radius-0.6 sphere.
    let cam = Camera::new(CameraSpec {
        from: [0., 0., 4.],
        at: [0.; 3],
        up: [0., 1., 0.],
        near: -1.,
        far: 1.,
        fov: 30.,
        size: [150, 150],
        orthographic: true,
    })
    .unwrap();
    let l = rnd_core::math::v3::normalize([1.0, 0.5, 1.0]);
    let hv = rnd_core::math::v3::normalize([l[0], l[1], l[2] + 1.0]);
    let (px, py) = cam.project(rnd_core::math::v3::scale(0.6, hv));
    let spec = f("bp-spec.png");
    let (bx, by) = peak_near(&spec, 75.0, 75.0, 75);
    assert!(
        (bx as f64 - px).abs() <= 1.5 && (by as f64 - py).abs() <= 1.5,
        "highlight ({bx},{by}) predicted ({px:.1},{py:.1})"
    );
    // Ambient only: a flat disc of 0.7 (edge pixels partly transparent over black).
    let amb = f("bp-amb.png");
    assert!(amb.2.iter().all(|&v| v <= 0.71));
    let covered = amb.2.iter().filter(|&&v| v > 0.0).count();
    let flat = amb.2.iter().filter(|&&v| (v - 0.7).abs() < 0.01).count();
    assert!(flat as f64 > 0.9 * covered as f64, "{flat} of {covered}");
    // 4b. Depth cue on a constant medium, white ambient light, max blend: the first
    // counted sample is nearest (brightest), so every covered pixel shows lerp(1, 0, τ0).
    let dc = f("depth-cue-const.png");
    assert!(dc.2.iter().any(|&v| v > 0.9));
}
