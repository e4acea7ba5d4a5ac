#![cfg(feature = "png")]
//! Runs the crate's examples (built by `cargo test` next to the test binaries) and checks
//! the images they write.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The example binary `name` of this build (target/<profile>/examples/).
fn example(name: &str) -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let dir = exe.parent().unwrap().parent().unwrap();
    let p = dir.join("examples").join(name);
    assert!(
        p.exists(),
        "{} was not built (cargo test builds the examples)",
        p.display()
    );
    p
}

/// Runs `name` with `args`, then decodes the PNG it wrote to `png`.
fn run(name: &str, args: &[&Path], png: &Path) -> image::RgbImage {
    let out = Command::new(example(name)).args(args).output().unwrap();
    assert!(
        out.status.success(),
        "{name}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    image::open(png).unwrap().to_rgb8()
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("rnd-std-examples-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn mip_png_shows_the_two_blobs() {
    let d = scratch("mip");
    let png = d.join("mip.png");
    let img = run("mip_png", &[&png], &png);
    assert_eq!(img.dimensions(), (256, 256));
    // Grey; the corners see almost nothing; the brightest pixels are near the big
    // blob's peak (1 at its centre; the B-spline smooths it a little); bright pixels
    // cover the blobs, a small part of the picture.
    assert!(img.pixels().all(|p| p[0] == p[1] && p[1] == p[2]));
    assert!(img.get_pixel(0, 0)[0] < 5, "{:?}", img.get_pixel(0, 0));
    let max = img.pixels().map(|p| p[0]).max().unwrap();
    assert!(max >= 240, "{max}");
    let bright = img.pixels().filter(|p| p[0] > 128).count();
    assert!(
        (256 * 256 / 200..256 * 256 / 10).contains(&bright),
        "{bright}"
    );
    std::fs::remove_dir_all(d).unwrap();
}

#[test]
fn head_lit_renders_the_skin() {
    let d = scratch("head");
    let png = d.join("head.png");
    let head = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/itk-t1-head.nrrd");
    let img = run("head_lit", &[&head, &png], &png);
    assert_eq!(img.dimensions(), (300, 300));
    // Background black; a good part of the image is lit skin (warm: red above blue).
    let skin = img.pixels().filter(|p| p[0] > 40 && p[0] > p[2]).count();
    assert!(skin > 300 * 300 / 10, "{skin} skin pixels");
    assert_eq!(img.get_pixel(0, 0).0, [0, 0, 0]);
    std::fs::remove_dir_all(d).unwrap();
}
