//! Runs the crate's examples (built by `cargo test` next to the test binaries) and checks
//! what they print.

use std::path::PathBuf;
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

#[test]
fn probe_i16_reconstructs_the_linear_field() {
    let out = Command::new(example("probe_i16")).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    // Tent and Catmull-Rom reproduce a linear field exactly at a point whose f32
    // arithmetic is exact; the cubic B-spline to within rounding.
    assert!(
        text.contains("tent: value 19 gradient [6.0, -4.0, 2.0]"),
        "{text}"
    );
    assert!(
        text.contains("ctmr: value 19 gradient [6.0, -4.0, 2.0]"),
        "{text}"
    );
    let line = text
        .lines()
        .find(|l| l.starts_with("bspln3: value "))
        .unwrap();
    let v: f32 = line["bspln3: value ".len()..]
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!((v - 19.0).abs() < 1e-5, "{line}");
}
