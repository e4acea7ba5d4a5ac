//! Tests that run the built `rendr` binary: option parsing, printed numbers, the seed's
//! command walkthrough, and bad input (clear one-line errors, no panics, no output).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn rendr() -> Command {
    Command::new(env!("CARGO_BIN_EXE_rendr"))
}

fn run_in(dir: &Path, args: &[&str]) -> Output {
    rendr()
        .current_dir(dir)
        .args(args)
        .output()
        .expect("run rendr")
}

fn ok(dir: &Path, args: &[&str]) -> String {
    let o = run_in(dir, args);
    assert!(
        o.status.success(),
        "rendr {args:?} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Runs a command that must fail: exit code 1 (never 101 = panic), one line on stderr
/// naming the problem (`frag`), and no file `out` left behind.
fn fails(dir: &Path, args: &[&str], frag: &str, out: Option<&str>) {
    let o = run_in(dir, args);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(
        o.status.code(),
        Some(1),
        "rendr {args:?}: status {:?}, stderr {err}",
        o.status
    );
    assert!(
        err.contains(frag),
        "rendr {args:?}: stderr {err:?} lacks {frag:?}"
    );
    assert!(!err.contains("panicked"), "{err}");
    // (mgo announces each command it runs: those before the failing one did run.)
    assert!(
        o.stdout.is_empty() || args[0] == "mgo",
        "rendr {args:?}: printed before failing: {:?}",
        String::from_utf8_lossy(&o.stdout)
    );
    if let Some(f) = out {
        assert!(!dir.join(f).exists(), "rendr {args:?} left {f} behind");
    }
    // No temporary files either.
    for e in std::fs::read_dir(dir).unwrap() {
        let n = e.unwrap().file_name().to_string_lossy().into_owned();
        assert!(!n.contains("rendr-tmp"), "temporary file {n} left behind");
    }
}

fn corpus(name: &str) -> String {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/corpus/bad")
        .join(name);
    p.to_string_lossy().into_owned()
}

fn read_floats(p: &Path) -> (Vec<usize>, Vec<f32>) {
    let n = rnd_std::nrrd::read(p).unwrap();
    (n.sizes().to_vec(), n.data.to_f32())
}

#[test]
fn no_arguments_lists_commands() {
    let o = rendr().output().unwrap();
    assert!(o.status.success());
    let s = String::from_utf8_lossy(&o.stdout);
    for c in [
        "about", "4mi", "cam", "lgen", "levoy", "info", "sdg", "ceval", "klist", "go", "keval",
        "teval",
    ] {
        assert!(
            s.contains(&format!(" rendr {c} ")),
            "{c} missing from:\n{s}"
        );
    }
}

#[test]
fn help_and_usage() {
    let d = rnd_tests::tmpdir("help");
    let o = run_in(&d, &["go", "--help"]);
    assert!(o.status.success());
    let s = String::from_utf8_lossy(&o.stdout);
    assert!(
        s.contains("-s,--planesep <sep>") && s.contains("(default: \"0.1\")"),
        "{s}"
    );
    // Missing required options: short usage, exit 1.
    let o = run_in(&d, &["cam"]);
    assert_eq!(o.status.code(), Some(1));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("Usage: rendr cam [@file ...] -fr <x y z>"),
        "{e}"
    );
    assert!(e.contains("\"rendr cam --help\" for more information"));
    // Every command has help text.
    for c in [
        "about", "4mi", "m4ai", "cam", "teval", "lgen", "levoy", "ceval", "go", "klist", "keval",
        "info", "sdg",
    ] {
        let o = run_in(&d, &[c, "--help"]);
        assert!(o.status.success(), "{c} --help");
        assert!(!o.stdout.is_empty());
    }
    fails(&d, &["frobnicate"], "unknown command", None);
}

const CUBE_CAM: &str = "-fr 6 12 5 -at 0 0 0  # look from, at\n-up 0 0 1\n# whole-line comment\n-nc -2.56304 -fc 2.56304 -fov 16\n-sz 300 300\n";

#[test]
fn cam_prints_spec_numbers() {
    let d = rnd_tests::tmpdir("cam");
    std::fs::write(d.join("cube-cam.txt"), CUBE_CAM).unwrap();
    let s = ok(&d, &["cam", "@cube-cam.txt"]);
    assert!(s.contains("11.7548 = ncv"), "{s}");
    assert!(s.contains("16.8809 = fcv"));
    assert!(s.contains("4.02448 = hght"));
    assert!(s.contains("14.3178 = |fr-at|=d"));
    assert!(s.contains("-0.894427 0.447214 0 = u"));
    assert!(s.contains("0.419058 0.838116 0.349215 = n"));
    // A later option overrides the response file's.
    let s = ok(
        &d,
        &[
            "cam",
            "@cube-cam.txt",
            "-fov",
            "14",
            "-nc",
            "-2.3",
            "-fc",
            "2.3",
            "-sz",
            "320",
            "280",
        ],
    );
    assert!(
        s.contains("14 = FOV") && s.contains("12.0178 = ncv") && s.contains("3.51601 = hght"),
        "{s}"
    );
    assert!(
        s.contains("4.0183 = wdth") && s.contains("1.14286 = ar"),
        "{s}"
    );
    // -v: view-space origin is the eye.
    assert!(s.contains("0 0 0 1 (view) -> 6 12 5 1 (world)"), "{s}");
}

#[test]
fn option_errors_are_one_line() {
    let d = rnd_tests::tmpdir("opterr");
    std::fs::write(d.join("c.txt"), CUBE_CAM).unwrap();
    fails(
        &d,
        &["cam", "@c.txt", "-fov", "abc"],
        "-fov: can't parse \"abc\" as a real number",
        None,
    );
    fails(
        &d,
        &["cam", "@c.txt", "-zoom", "2"],
        "unknown option \"-zoom\"",
        None,
    );
    fails(
        &d,
        &["cam", "-fr", "1", "2", "3"],
        "missing required options -at -up -nc -fc -fov -sz",
        None,
    );
    fails(
        &d,
        &["cam", "@c.txt", "-at", "6", "12", "5"],
        "look-from equals look-at",
        None,
    );
    fails(
        &d,
        &["cam", "@c.txt", "-up", "6", "12", "5"],
        "parallel",
        None,
    );
    fails(
        &d,
        &["cam", "@c.txt", "-fov", "170"],
        "-fov: field of view must be in (0, 160) degrees",
        None,
    );
    fails(&d, &["cam", "@c.txt", "-sz", "0", "10"], "-sz", None);
    fails(&d, &["cam", "@c.txt", "-fov", "nan"], "-fov", None);
    fails(
        &d,
        &["cam", "@nothere.txt"],
        "@nothere.txt: can't read response file",
        None,
    );
    fails(
        &d,
        &["cam", "@c.txt", "-fr", "1", "2"],
        "-fr: needs 3 values",
        None,
    );
    fails(
        &d,
        &[
            "lgen", "-i", "x", "x", "-mm", "0", "1", "-o", "l.nrrd", "-rs", "maybe", "no",
        ],
        "-rs: can't parse \"maybe\" as a boolean",
        Some("l.nrrd"),
    );
}

#[test]
fn bool_words_and_negative_numbers() {
    let d = rnd_tests::tmpdir("bools");
    for w in [
        "true", "false", "yes", "no", "on", "off", "1", "0", "TRUE", "t", "n",
    ] {
        // "-rs false <w>": rescaling opacity without an opacity txf is an error, so
        // only false words may succeed; true words must be refused with that message.
        let args = [
            "lgen", "-i", "x", "x", "-mm", "-1", "-0.5", "-rs", "false", w, "-l", "4", "-o",
            "l.nrrd",
        ];
        let is_true = matches!(
            w.to_ascii_lowercase().as_str(),
            "true" | "yes" | "on" | "1" | "t"
        );
        if is_true {
            fails(
                &d,
                &args,
                "can't rescale opacity without an opacity txf",
                None,
            );
        } else {
            ok(&d, &args);
        }
    }
    let (s, v) = read_floats(&d.join("l.nrrd"));
    assert_eq!(s, vec![4, 4]);
    assert!(v.iter().all(|&x| x == 1.0));
    let n = rnd_std::nrrd::read(&d.join("l.nrrd")).unwrap();
    assert_eq!(n.header.axis_mins.as_ref().unwrap()[1], -1.0);
}

#[test]
fn m4ai_inverts() {
    let d = rnd_tests::tmpdir("m4ai");
    std::fs::write(d.join("mat.txt"), "2 0 0 1\n0 4 0 2\n0 0 8 3\n0 0 0 1\n").unwrap();
    for name in ["4mi", "m4ai"] {
        let s = ok(&d, &[name, "mat.txt"]);
        let ai = s.split("Ai =\n").nth(1).unwrap();
        let row0: Vec<f64> = ai
            .lines()
            .next()
            .unwrap()
            .split_whitespace()
            .map(|w| w.parse().unwrap())
            .collect();
        assert_eq!(row0, vec![0.5, 0.0, 0.0, -0.5], "{s}");
        let last = s.lines().last().unwrap();
        assert!(last.ends_with("= FrobeniusNorm(P-I)   (should be nearly zero)"));
        let v: f64 = last.split_whitespace().next().unwrap().parse().unwrap();
        assert!(v < 1e-12);
    }
    std::fs::write(d.join("sing.txt"), "1 2 3 0\n2 4 6 0\n0 0 1 0\n0 0 0 1\n").unwrap();
    fails(&d, &["4mi", "sing.txt"], "singular", None);
    std::fs::write(d.join("small.txt"), "1 2\n3 4\n").unwrap();
    fails(&d, &["4mi", "small.txt"], "need a 4x4 matrix", None);
}

#[test]
fn keval_and_klist() {
    let d = rnd_tests::tmpdir("keval");
    let s = ok(&d, &["keval", "-s", "-d", "2", "bspln3", "0.3"]);
    assert!(s.contains("support(Bspln3) = 4"));
    assert!(s.contains("Bspln3(0.3)= 0.590166667"), "{s}");
    assert!(s.contains("dBspln3(0.3)= -0.465"));
    let s = ok(&d, &["keval", "ctmr", "0.5", "-d", "2"]);
    assert!(
        s.contains("Ctmr(0.5)= 0.5625")
            && s.contains("dCtmr(0.5)= -1.375")
            && s.contains("ddCtmr(0.5)= -0.5")
    );
    let s = ok(&d, &["keval", "Bspln3", "0", "-a", "0.3"]);
    assert!(
        s.contains("0.0571666667 0.590166667 0.348166667 0.0045 = Bspln3 weights at alpha=0.3"),
        "{s}"
    );
    let s = ok(&d, &["klist"]);
    for k in ["Box", "Tent", "Bspln2", "Bspln3", "Ctmr", "C4hexic"] {
        assert!(s.contains(&format!("=== {k}")), "{s}");
    }
    fails(
        &d,
        &["keval", "cubic", "0"],
        "unknown kernel \"cubic\"",
        None,
    );
}

#[test]
fn sdg_and_info_geometry() {
    let d = rnd_tests::tmpdir("sdg");
    ok(
        &d,
        &["sdg", "-w", "0", "-sz", "3", "4", "5", "-o", "a.nrrd"],
    );
    let n = rnd_std::nrrd::read(&d.join("a.nrrd")).unwrap();
    let dirs = n.header.space_directions.clone().unwrap();
    let want = [[2.0 / 3.0, 0., 0.], [0., 0.5, 0.], [0., 0., 0.4]];
    for a in 0..3 {
        for c in 0..3 {
            assert!((dirs[a].as_ref().unwrap()[c] - want[a][c]).abs() < 1e-12);
        }
    }
    let o = n.header.space_origin.clone().unwrap();
    assert!(
        (o[0] + 2.0 / 3.0).abs() < 1e-12
            && (o[1] + 0.75).abs() < 1e-12
            && (o[2] + 0.8).abs() < 1e-12
    );
    assert_eq!(
        n.header.content.as_deref(),
        Some("rendr sdg -w 0 -sz 3 4 5 -o a.nrrd")
    );
    ok(
        &d,
        &[
            "sdg", "-sz", "3", "4", "5", "-c", "1", "2", "3", "-l", "3", "4", "5", "-sh", "0.5",
            "0", "0", "-r", "0", "0", "1", "-o", "b.nrrd",
        ],
    );
    let s = ok(&d, &["info", "b.nrrd"]);
    assert!(
        s.contains("3 by 4 by 5 volume with type real voxels"),
        "{s}"
    );
    // Columns (0,1,0), (-1,0.5,0), (0,0,1), origin (2.5, 0.25, 1).
    let v = rnd_std::volume_io::load_volume(&d.join("b.nrrd")).unwrap();
    let m = v.itow();
    let close = |a: [f64; 3], b: [f64; 3]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-12);
    assert!(close(m.column3(0), [0., 1., 0.]) && close(m.column3(1), [-1., 0.5, 0.]));
    assert!(close(m.column3(2), [0., 0., 1.]) && close(m.column3(3), [2.5, 0.25, 1.]));
    ok(
        &d,
        &["sdg", "-w", "8", "-sz", "3", "4", "5", "-o", "c.nrrd"],
    );
    let (_, vals) = read_floats(&d.join("c.nrrd"));
    let one = vals.iter().position(|&x| x == 1.0).unwrap();
    assert_eq!(one, 1 + 3 * (2 + 4 * 2));
    assert_eq!(vals.iter().filter(|&&x| x != 0.0).count(), 1);
    // Short output with -vs: round(f * sval / fval).
    ok(
        &d,
        &[
            "sdg", "-w", "0", "-sz", "3", "4", "5", "-t", "short", "-vs", "1", "100", "-o",
            "s.nrrd",
        ],
    );
    let n = rnd_std::nrrd::read(&d.join("s.nrrd")).unwrap();
    assert_eq!(n.header.scalar, rnd_std::nrrd::ScalarType::I16);
    // z of the first slice is -0.8 -> f = 0.8 -> 80.
    assert_eq!(n.data.get_f64(0), Some(80.0));
    fails(
        &d,
        &["sdg", "-w", "99", "-o", "x.nrrd"],
        "-w: unknown function 99",
        Some("x.nrrd"),
    );
    fails(
        &d,
        &["sdg", "-sz", "100000", "100000", "100000", "-o", "x.nrrd"],
        "would need",
        Some("x.nrrd"),
    );
}

#[test]
fn info_on_cube_matches_spec() {
    let Some(sh) = rnd_tests::shared("info_on_cube_matches_spec") else {
        return;
    };
    let d = rnd_tests::tmpdir("info-cube");
    let cube = sh.join("rendr-data/cube.nrrd");
    let s = ok(&d, &["info", cube.to_str().unwrap()]);
    assert!(s.contains("50 by 70 by 90 volume with type real voxels"));
    assert!(
        s.contains("[0.00234545162, 1.00001502] is range of values"),
        "{s}"
    );
    assert!(
        s.contains(" 0.0799999982 0.0571428575 0.0444444455 (average"),
        "{s}"
    );
    assert!(s.contains("90 (0/1), 90 (0/2), 90 (1/2)"));
}

/// Every float voxel of `sdg -w 0` (rotated, sheared) holds -z; short voxels hold
/// round(-z * sval / fval).
#[test]
fn sdg_zramp_holds_minus_z() {
    let d = rnd_tests::tmpdir("zramp");
    let common = [
        "-w", "0", "-l", "5", "5", "5", "-sz", "20", "25", "30", "-r", "0.5", "0.6", "-0.3", "-sh",
        "0.1", "-0.2", "0.3", "-c", "0.1", "-0.1", "0.3",
    ];
    let mut a: Vec<&str> = vec!["sdg"];
    a.extend(common);
    let mut f = a.clone();
    f.extend(["-o", "z3.nrrd"]);
    ok(&d, &f);
    let mut s = a.clone();
    s.extend(["-o", "z3-us.nrrd", "-t", "short", "-vs", "4", "10000"]);
    ok(&d, &s);
    for (file, scale, tol) in [("z3.nrrd", 1.0, 1e-6), ("z3-us.nrrd", 2500.0, 0.5)] {
        let v = rnd_std::volume_io::load_volume(&d.join(file)).unwrap();
        let [s0, s1, s2] = v.sizes();
        let n = rnd_std::nrrd::read(&d.join(file)).unwrap();
        for k in 0..s2 {
            for j in 0..s1 {
                for i in 0..s0 {
                    let w = v.itow().point([i as f64, j as f64, k as f64]);
                    let x = n.data.get_f64(i + s0 * (j + s1 * k)).unwrap();
                    assert!(
                        (x - (-w[2] * scale)).abs() <= tol * (1.0 + w[2].abs()),
                        "{file} ({i},{j},{k}): {x} vs {}",
                        -w[2] * scale
                    );
                }
            }
        }
    }
}

/// The seed's `ceval` loop: every kernel but box gives -z and (0,0,-1) on the zramps.
#[test]
fn ceval_zramps() {
    let d = rnd_tests::tmpdir("ceval");
    let zr: [&[&str]; 4] = [
        &["-sz", "25", "25", "25"],
        &["-sz", "20", "25", "30"],
        &["-sz", "20", "25", "30", "-r", "0.5", "0.6", "-0.3"],
        &[
            "-sz", "20", "25", "30", "-r", "0.5", "0.6", "-0.3", "-sh", "0.1", "-0.2", "0.3", "-c",
            "0.1", "-0.1", "0.3",
        ],
    ];
    for (x, extra) in zr.iter().enumerate() {
        let name = format!("zramp{x}.nrrd");
        let mut a = vec!["sdg", "-w", "0", "-l", "5", "5", "5", "-o", &name];
        a.extend_from_slice(extra);
        ok(&d, &a);
        let sname = format!("zramp{x}-us.nrrd");
        let mut a = vec![
            "sdg", "-w", "0", "-l", "5", "5", "5", "-o", &sname, "-t", "short", "-vs", "4", "10000",
        ];
        a.extend_from_slice(extra);
        ok(&d, &a);
        for k in ["tent", "bspln2", "bspln3", "ctmr", "c4hexic"] {
            for (f, scale) in [(&name, 1.0), (&sname, 2500.0)] {
                let s = ok(
                    &d,
                    &[
                        "ceval", "-i", f, "-k", k, "-w", "0.2", "0.4", "0.8", "-g", "true",
                    ],
                );
                let mut lines = s.lines();
                let v: f64 = lines
                    .next()
                    .unwrap()
                    .split_whitespace()
                    .next()
                    .unwrap()
                    .parse()
                    .unwrap();
                assert!((v / scale + 0.8).abs() < 2e-4, "{f} {k}: {s}");
                let g: Vec<f64> = lines
                    .next()
                    .unwrap()
                    .split_whitespace()
                    .take(3)
                    .map(|w| w.parse().unwrap())
                    .collect();
                assert!(
                    g[0].abs() / scale < 2e-3
                        && g[1].abs() / scale < 2e-3
                        && (g[2] / scale + 1.0).abs() < 2e-3,
                    "{f} {k}: {s}"
                );
            }
        }
    }
    let s = ok(
        &d,
        &[
            "ceval",
            "-i",
            "zramp0.nrrd",
            "-k",
            "tent",
            "-w",
            "9",
            "0",
            "0",
        ],
    );
    assert!(s.starts_with("outside =rndConvoEval"), "{s}");
    let s = ok(
        &d,
        &[
            "ceval",
            "-i",
            "zramp0.nrrd",
            "-k",
            "tent",
            "-w",
            "0",
            "0",
            "0",
            "-wtoi",
        ],
    );
    assert!(s.starts_with("12 12 12 = WtoI(0 0 0)"), "{s}");
}

fn seed_cube(d: &Path) {
    ok(
        d,
        &["sdg", "-w", "2", "-l", "4", "4", "4", "-o", "cube.nrrd"],
    );
    std::fs::write(
        d.join("cube-cam.txt"),
        "-fr 6 12 5 -at 0 0 0\n-up 0 0 1\n-nc -2.56304 -fc 2.56304 -fov 16\n-sz 300 300\n",
    )
    .unwrap();
}

fn go(d: &Path, extra: &[&str]) {
    let mut a = vec!["go", "@cube-cam.txt", "-i", "cube.nrrd"];
    a.extend_from_slice(extra);
    ok(d, &a);
}

/// The seed's `go` walkthrough, checked against what the seed says.
#[test]
fn seed_go_walkthrough() {
    let d = rnd_tests::tmpdir("seedgo");
    seed_cube(&d);
    go(
        &d,
        &[
            "-s", "0", "-k", "box", "-p", "pv", "-b", "sum", "-o", "pv.nrrd",
        ],
    );
    let (s, pv) = read_floats(&d.join("pv.nrrd"));
    assert_eq!(s, vec![3, 300, 300]);
    // Third view coordinate = -ncv everywhere.
    assert!(pv.chunks(3).all(|p| (p[2] + 11.754781).abs() < 1e-5));
    // Corners: symmetric, (-x, +y) at the top left.
    let c00 = &pv[0..3];
    let cmm = &pv[3 * (299 + 300 * 299)..3 * (299 + 300 * 299) + 3];
    assert!(
        c00[0] < 0.0
            && c00[1] > 0.0
            && (c00[0] + cmm[0]).abs() < 1e-6
            && (c00[1] + cmm[1]).abs() < 1e-6
    );
    // pw = VtoW(pv); pi = WtoI(pw).
    go(
        &d,
        &[
            "-s", "0", "-k", "box", "-p", "pw", "-b", "sum", "-o", "pw.nrrd",
        ],
    );
    go(
        &d,
        &[
            "-s", "0", "-k", "box", "-p", "pi", "-b", "sum", "-o", "pi.nrrd",
        ],
    );
    let (_, pw) = read_floats(&d.join("pw.nrrd"));
    let (_, pi) = read_floats(&d.join("pi.nrrd"));
    let cam = rnd_core::camera::Camera::new(rnd_core::camera::CameraSpec {
        from: [6., 12., 5.],
        at: [0.; 3],
        up: [0., 0., 1.],
        near: -2.56304,
        far: 2.56304,
        fov: 16.,
        size: [300, 300],
        orthographic: false,
    })
    .unwrap();
    let vol = rnd_std::volume_io::load_volume(&d.join("cube.nrrd")).unwrap();
    let wtoi = vol.itow().affine_inverse().unwrap();
    for px in [0usize, 777, 45_000, 89_999] {
        let v = [
            pv[3 * px] as f64,
            pv[3 * px + 1] as f64,
            pv[3 * px + 2] as f64,
        ];
        let w = cam.vtow.point(v);
        let i = wtoi.point(w);
        for c in 0..3 {
            assert!((pw[3 * px + c] as f64 - w[c]).abs() < 1e-4);
            assert!((pi[3 * px + c] as f64 - i[c]).abs() < 1e-3);
        }
    }
    // pv0 (-s 0 -fc 3) equals pv1 (-s 1 -fc -1.5) exactly.
    go(
        &d,
        &[
            "-s", "0", "-nc", "-2", "-fc", "3", "-k", "box", "-p", "pv", "-b", "sum", "-o",
            "pv0.nrrd",
        ],
    );
    go(
        &d,
        &[
            "-s", "1", "-nc", "-2", "-fc", "-1.5", "-k", "box", "-p", "pv", "-b", "sum", "-o",
            "pv1.nrrd",
        ],
    );
    go(
        &d,
        &[
            "-s", "1", "-nc", "-2", "-fc", "-0.5", "-k", "box", "-p", "pv", "-b", "sum", "-o",
            "pv2.nrrd",
        ],
    );
    let (_, pv0) = read_floats(&d.join("pv0.nrrd"));
    let (_, pv1) = read_floats(&d.join("pv1.nrrd"));
    let (_, pv2) = read_floats(&d.join("pv2.nrrd"));
    assert_eq!(pv0, pv1);
    // step = pv2 - 2 pv1: third coordinate -1; the first two vary (perspective).
    let step: Vec<f32> = pv2.iter().zip(&pv1).map(|(a, b)| a - 2.0 * b).collect();
    assert!(step.chunks(3).all(|s| (s[2] + 1.0).abs() < 1e-4));
    assert!(step[0] < 0.0 && step[1] > 0.0 && (step[0] + step[3 * 89_999]).abs() < 1e-4);
    // Orthographic: every step the same (0, 0, -1).
    go(
        &d,
        &[
            "-s",
            "1",
            "-nc",
            "-2",
            "-fc",
            "-1.5",
            "-k",
            "box",
            "-p",
            "pv",
            "-b",
            "sum",
            "-ortho",
            "-o",
            "pv1o.nrrd",
        ],
    );
    go(
        &d,
        &[
            "-s",
            "1",
            "-nc",
            "-2",
            "-fc",
            "-0.5",
            "-k",
            "box",
            "-p",
            "pv",
            "-b",
            "sum",
            "-ortho",
            "-o",
            "pv2o.nrrd",
        ],
    );
    let (_, a) = read_floats(&d.join("pv1o.nrrd"));
    let (_, b) = read_floats(&d.join("pv2o.nrrd"));
    let stepo: Vec<f32> = b.iter().zip(&a).map(|(x, y)| x - 2.0 * y).collect();
    assert!(stepo
        .chunks(3)
        .all(|s| s[0].abs() < 1e-5 && s[1].abs() < 1e-5 && (s[2] + 1.0).abs() < 1e-5));
    // v and in: the visible triangle (inside region) shrinks with kernel support.
    let mut covered = Vec::new();
    for k in ["box", "tent", "bspln3"] {
        go(
            &d,
            &[
                "-s",
                "0",
                "-k",
                k,
                "-p",
                "in",
                "-b",
                "sum",
                "-o",
                &format!("in-{k}.nrrd"),
            ],
        );
        go(
            &d,
            &[
                "-s",
                "0",
                "-k",
                k,
                "-p",
                "v",
                "-b",
                "sum",
                "-o",
                &format!("v-{k}.nrrd"),
            ],
        );
        let (_, inside) = read_floats(&d.join(format!("in-{k}.nrrd")));
        let (_, v) = read_floats(&d.join(format!("v-{k}.nrrd")));
        let n = inside.iter().filter(|&&x| x == 1.0).count();
        assert!(inside.iter().all(|&x| x == 0.0 || x == 1.0));
        // Outside pixels get the outside value 0 for v.
        assert!(inside.iter().zip(&v).all(|(i, v)| *i == 1.0 || *v == 0.0));
        covered.push(n);
    }
    assert!(
        covered[0] > covered[1] && covered[1] > covered[2] && covered[2] > 0,
        "{covered:?}"
    );
    // Blends: max <= sum; mean = sum / count (box keeps every sample in count).
    for b in ["max", "sum", "mean"] {
        go(
            &d,
            &[
                "-s",
                "0.1",
                "-k",
                "box",
                "-p",
                "v",
                "-b",
                b,
                "-o",
                &format!("p-{b}.nrrd"),
            ],
        );
    }
    go(
        &d,
        &[
            "-s",
            "0.1",
            "-k",
            "box",
            "-p",
            "in",
            "-b",
            "sum",
            "-o",
            "p-count.nrrd",
        ],
    );
    let (_, mx) = read_floats(&d.join("p-max.nrrd"));
    let (_, sm) = read_floats(&d.join("p-sum.nrrd"));
    let (_, mn) = read_floats(&d.join("p-mean.nrrd"));
    let (_, cnt) = read_floats(&d.join("p-count.nrrd"));
    for i in 0..mx.len() {
        if cnt[i] > 0.0 {
            assert!(mx[i] <= sm[i] + 1e-6 && mn[i] <= mx[i] + 1e-6);
            assert!(
                (mn[i] - sm[i] / cnt[i]).abs() <= 1e-5 * (1.0 + sm[i].abs()),
                "px {i}"
            );
        }
    }
    // cube-rgb and cube-dc render (PNG directly, and NRRD with 4 channels).
    let sh = rnd_tests::shared("seed_go_walkthrough (cube-rgb part)");
    if let Some(sh) = sh {
        let rd = sh.join("rendr-data");
        let atxf = rd.join("cube-atxf1.txt");
        ok(
            &d,
            &[
                "lgen",
                "-i",
                "x",
                atxf.to_str().unwrap(),
                "-mm",
                "0",
                "1",
                "-o",
                "lut.nrrd",
            ],
        );
        let rgb = rd.join("rgb.txt");
        let one = rd.join("1.txt");
        go(
            &d,
            &[
                "-us",
                "0.03",
                "-s",
                "0.03",
                "-k",
                "ctmr",
                "-p",
                "rgbalit",
                "-b",
                "over",
                "-lut",
                "lut.nrrd",
                "-lit",
                rgb.to_str().unwrap(),
                "-o",
                "cube-rgb.nrrd",
            ],
        );
        go(
            &d,
            &[
                "-us",
                "0.03",
                "-s",
                "0.03",
                "-k",
                "ctmr",
                "-p",
                "rgbalit",
                "-b",
                "over",
                "-lut",
                "lut.nrrd",
                "-lit",
                one.to_str().unwrap(),
                "-dcn",
                "1.2",
                "1.1",
                "0.9",
                "-dcf",
                "0.2",
                "0.3",
                "0.4",
                "-o",
                "cube-dc.png",
            ],
        );
        let (s, v) = read_floats(&d.join("cube-rgb.nrrd"));
        assert_eq!(s, vec![4, 300, 300]);
        assert!(v.chunks(4).filter(|p| p[3] > 0.5).count() > 10_000);
        let png = std::fs::read(d.join("cube-dc.png")).unwrap();
        assert_eq!(&png[1..4], b"PNG");
    }
}

/// Bad input: each case a clear message naming the problem, exit 1, no output file.
#[test]
fn bad_input_corpus() {
    let d = rnd_tests::tmpdir("bad");
    seed_cube(&d);
    ok(
        &d,
        &["lgen", "-i", "x", "x", "-mm", "0", "1", "-o", "lut.nrrd"],
    );
    std::fs::write(d.join("lit.txt"), "#space:=rgb\n1 1 1 0 0 1 1\n").unwrap();
    let vol_cases: &[(&str, &str)] = &[
        ("bad-magic.nrrd", "bad magic"),
        ("truncated.nrrd", "data is truncated"),
        ("gzip-garbage.nrrd", "can't be decompressed"),
        ("sizes-overflow.nrrd", "overflow"),
        ("huge-claim.nrrd", "would need"),
        (
            "dimension-mismatch.nrrd",
            "sizes: 2 values but dimension is 3",
        ),
        ("singular-directions.nrrd", "singular"),
        ("ragged.txt", "ragged rows"),
        ("unknown-type.nrrd", "unknown or unsupported type"),
        ("lut-3-channels.nrrd", "volume must be 3-D"),
        ("nifti-truncated.nii", "data is truncated"),
        ("nifti-huge-dims.nii", "would need"),
        ("nifti-bitpix.nii", "bitpix 8 does not match datatype 4"),
        (
            "nifti-in-header-offset.nii",
            "vox_offset 100 is inside the header",
        ),
        ("gzip-not-nifti.gz", "does not hold a NIfTI file"),
        ("mhd-missing-data.mhd", "no-such-file.raw"),
        ("mha-channels.mha", "ElementNumberOfChannels 3"),
        ("dicom-lying-length.dcm", "claims 4294967040 bytes"),
    ];
    for (f, frag) in vol_cases {
        let p = corpus(f);
        fails(&d, &["info", &p], frag, None);
        fails(
            &d,
            &[
                "go",
                "@cube-cam.txt",
                "-i",
                &p,
                "-k",
                "tent",
                "-o",
                "out.nrrd",
            ],
            frag,
            Some("out.nrrd"),
        );
    }
    let go_base = ["go", "@cube-cam.txt", "-i", "cube.nrrd", "-k", "tent"];
    let go_cases: &[(&[&str], &str)] = &[
        (
            &["-p", "v", "-b", "over", "-o", "o.nrrd"],
            "-b: blend over needs probe rgba or rgbalit",
        ),
        (
            &["-p", "rgba", "-o", "o.nrrd"],
            "-lut: probe rgba needs a LUT",
        ),
        (
            &["-p", "rgbalit", "-lut", "lut.nrrd", "-o", "o.nrrd"],
            "-lit: probe rgbalit needs lights",
        ),
        (
            &[
                "-p",
                "rgba",
                "-lut",
                &corpus("lut-3-channels.nrrd"),
                "-o",
                "o.nrrd",
            ],
            "axis 0 has size 3, need 4",
        ),
        (
            &[
                "-p",
                "rgba",
                "-lut",
                &corpus("lut-vmin-vmax.nrrd"),
                "-o",
                "o.nrrd",
            ],
            "needs finite min < max",
        ),
        (
            &[
                "-p",
                "rgbalit",
                "-lut",
                "lut.nrrd",
                "-lit",
                &corpus("light-zero-dir.txt"),
                "-o",
                "o.nrrd",
            ],
            "zero length",
        ),
        (
            &[
                "-p",
                "rgbalit",
                "-lut",
                "lut.nrrd",
                "-lit",
                &corpus("light-6-columns.txt"),
                "-o",
                "o.nrrd",
            ],
            "need 7 columns",
        ),
        (
            &[
                "-p",
                "rgba",
                "-lut",
                "lut.nrrd",
                "-lev",
                &corpus("levoy-2-columns.txt"),
                "-o",
                "o.nrrd",
            ],
            "need 3 columns",
        ),
        (
            &["-at", "6", "12", "5", "-o", "o.nrrd"],
            "look-from equals look-at",
        ),
        (&["-s", "-1", "-o", "o.nrrd"], "-s: plane separation"),
        (&["-us", "0", "-o", "o.nrrd"], "-us: unit step"),
        (&["-a1", "1.5", "-o", "o.nrrd"], "-a1: alpha_near1"),
        (&["-p", "colour", "-o", "o.nrrd"], "unknown probe"),
        (&["-b", "mode", "-o", "o.nrrd"], "unknown blend"),
        (&["-k", "cubic", "-o", "o.nrrd"], "unknown kernel"),
        (
            &["-nc", "3", "-fc", "2", "-o", "o.nrrd"],
            "must be less than far clip",
        ),
        (&["-fov", "inf", "-o", "o.nrrd"], "-fov"),
        (&["-o", "cube.nrrd"], "would overwrite the input"),
        (&["-o", "nodir/o.nrrd"], "can't create output"),
        (
            &["-i", "missing.nrrd", "-o", "o.nrrd"],
            "missing.nrrd: can't read",
        ),
        (&["-db", "400", "0"], "-db: pixel"),
        (
            &["-q", "1", "0", "-o", "o.png"],
            "-q: need finite min < max",
        ),
    ];
    for (extra, frag) in go_cases {
        let mut a: Vec<&str> = go_base.to_vec();
        a.extend_from_slice(extra);
        fails(&d, &a, frag, Some("o.nrrd"));
        assert!(!d.join("o.png").exists());
    }
    let txf_cases: &[(&str, &str)] = &[
        ("unsorted-txf.txt", "not strictly increasing"),
        ("txf-columns.txt", "axis[0].size should be 2"),
        ("txf-space.txt", "unknown space \"cmyk\""),
        ("txf-nan.txt", "non-finite"),
    ];
    for (f, frag) in txf_cases {
        fails(
            &d,
            &[
                "lgen",
                "-i",
                "x",
                &corpus(f),
                "-mm",
                "0",
                "1",
                "-o",
                "l2.nrrd",
            ],
            frag,
            Some("l2.nrrd"),
        );
        fails(&d, &["teval", &corpus(f), "0.5"], frag, None);
    }
    fails(
        &d,
        &["lgen", "-i", "x", "x", "-mm", "1", "1", "-o", "l2.nrrd"],
        "-mm: LUT domain needs finite min < max",
        Some("l2.nrrd"),
    );
    fails(
        &d,
        &[
            "levoy",
            "-i",
            &corpus("levoy-2-columns.txt"),
            "-mm",
            "0",
            "1",
            "-gm",
            "1",
            "-o",
            "l3.nrrd",
        ],
        "need 3 columns",
        Some("l3.nrrd"),
    );
    // An existing output survives a failed run byte for byte.
    std::fs::write(d.join("keep.nrrd"), b"precious").unwrap();
    fails(
        &d,
        &[
            "go",
            "@cube-cam.txt",
            "-i",
            "cube.nrrd",
            "-k",
            "tent",
            "-p",
            "rgba",
            "-o",
            "keep.nrrd",
        ],
        "needs a LUT",
        None,
    );
    assert_eq!(std::fs::read(d.join("keep.nrrd")).unwrap(), b"precious");
}

#[test]
fn db_traces_one_ray() {
    let d = rnd_tests::tmpdir("db");
    seed_cube(&d);
    let s = ok(
        &d,
        &[
            "go",
            "@cube-cam.txt",
            "-i",
            "cube.nrrd",
            "-k",
            "tent",
            "-s",
            "0.5",
            "-db",
            "150",
            "150",
        ],
    );
    assert!(
        s.contains("pixel (150, 150):")
            && s.contains("length of ray step")
            && s.contains("sample 0:")
    );
    let samples = s
        .lines()
        .filter(|l| l.trim_start().starts_with("sample "))
        .count();
    // depth span 2 * 2.56304 with planes 0.5 apart: 11 samples.
    assert_eq!(samples, 11, "{s}");
    assert!(s.lines().last().unwrap().starts_with("result: "));
}

/// `go` with the SPEC §4.9 command (the default `-ref true`: the reference program's
/// arithmetic) reproduces cube-rgb.nrrd on every pixel, and `-db` traces the same
/// arithmetic (its result is the image's pixel).
#[test]
fn go_reproduces_cube_rgb() {
    let Some(sh) = rnd_tests::shared("go_reproduces_cube_rgb") else {
        return;
    };
    let rd = sh.join("rendr-data");
    let d = rnd_tests::tmpdir("goref");
    let (cube, lut, rgb) = (
        rd.join("cube.nrrd"),
        rd.join("lut.nrrd"),
        rd.join("rgb.txt"),
    );
    let mut args: Vec<&str> = vec!["go", "-i", cube.to_str().unwrap()];
    args.extend([
        "-fr", "6", "12", "5", "-at", "0", "0", "0", "-up", "0", "0", "1", "-nc", "-2.3", "-fc",
        "2.3", "-fov", "14", "-sz", "320", "280", "-us", "0.03", "-s", "0.03", "-k", "bspln3",
        "-p", "rgbalit", "-b", "over", "-nt", "2",
    ]);
    args.extend(["-lut", lut.to_str().unwrap(), "-lit", rgb.to_str().unwrap()]);
    let mut render = args.clone();
    render.extend(["-o", "cube-rgb.nrrd"]);
    ok(&d, &render);
    let (s, got) = read_floats(&d.join("cube-rgb.nrrd"));
    let (ws, want) = read_floats(&rd.join("cube-rgb.nrrd"));
    assert_eq!(s, ws);
    let worst = got
        .iter()
        .zip(&want)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(worst <= 2.5e-6, "go: max error {worst}");
    // Alpha is bit-exact on every pixel (docs/VERIFICATION.md section 5).
    assert!(
        got.chunks(4)
            .zip(want.chunks(4))
            .all(|(a, b)| a[3].to_bits() == b[3].to_bits()),
        "go: an alpha differs from the reference's"
    );
    // Without the AVX-512 paths, and without any AVX (SSE2 only): the same bytes.
    for (var, name) in [("RND_AVX512", "avx2"), ("RND_AVX2", "sse")] {
        let out = format!("cube-rgb-{name}.nrrd");
        let mut narrow = args.clone();
        narrow.extend(["-o", &out]);
        let o = rendr()
            .current_dir(&d)
            .env(var, "0")
            .args(&narrow)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let (_, plain) = read_floats(&d.join(&out));
        assert!(
            plain
                .iter()
                .zip(&got)
                .all(|(a, b)| a.to_bits() == b.to_bits()),
            "go differs with {var}=0"
        );
    }

    // SPEC §13.5 pixel (176, 19) traced: the last line is the pixel's value.
    let mut trace = args.clone();
    trace.extend(["-db", "176", "19"]);
    let out = ok(&d, &trace);
    let last = out.lines().last().unwrap();
    let vals: Vec<f32> = last
        .strip_prefix("result: ")
        .unwrap()
        .split_whitespace()
        .map(|w| w.parse().unwrap())
        .collect();
    let i = 4 * (176 + 320 * 19);
    for c in 0..4 {
        assert!(
            (vals[c] - got[i + c]).abs() < 1e-6 * (1.0 + got[i + c].abs()),
            "{last} vs image {:?}",
            &got[i..i + 4]
        );
    }
}

/// The reference arithmetic (the default) compares index bounds in f32, exact only
/// below 2^24: a longer axis is refused with a clear message (never an out-of-bounds
/// read), and renders with `-ref false`. Likewise cameras and steps f32 cannot hold.
#[test]
fn ref_refuses_axes_beyond_f32() {
    let d = rnd_tests::tmpdir("refaxis");
    ok(
        &d,
        &[
            "sdg",
            "-w",
            "3",
            "-sz",
            "16777216",
            "1",
            "1",
            "-t",
            "short",
            "-o",
            "long.nrrd",
        ],
    );
    let go = [
        "go",
        "-i",
        "long.nrrd",
        "-fr",
        "0",
        "0",
        "5",
        "-at",
        "0",
        "0",
        "0",
        "-up",
        "0",
        "1",
        "0",
        "-nc",
        "-1",
        "-fc",
        "1",
        "-fov",
        "10",
        "-k",
        "tent",
        "-sz",
        "4",
        "4",
        "-o",
        "x.nrrd",
    ];
    fails(
        &d,
        &go,
        "-i: long.nrrd: an axis of 16777216 samples is beyond the reference's exact f32 \
         index arithmetic (at most 16777215); use the f64 arithmetic (-ref false)",
        Some("x.nrrd"),
    );
    let mut f64_engine = go.to_vec();
    f64_engine.extend(["-ref", "false"]);
    ok(&d, &f64_engine);
    // A camera or step that exists in f64 but not in f32.
    ok(
        &d,
        &["sdg", "-w", "2", "-sz", "8", "8", "8", "-o", "small.nrrd"],
    );
    let far = [
        "go",
        "-i",
        "small.nrrd",
        "-fr",
        "0",
        "0",
        "1e39",
        "-at",
        "0",
        "0",
        "0",
        "-up",
        "0",
        "1",
        "0",
        "-nc",
        "-1e38",
        "-fc",
        "1e38",
        "-fov",
        "10",
        "-k",
        "tent",
        "-sz",
        "4",
        "4",
        "-s",
        "1e37",
        "-us",
        "1e37",
        "-o",
        "y.nrrd",
    ];
    fails(&d, &far, "the camera (look-from", Some("y.nrrd"));
    let mut tiny = go.to_vec();
    tiny.extend(["-i", "small.nrrd", "-us", "1e-60", "-o", "z.nrrd"]);
    fails(
        &d,
        &tiny,
        "-ref: unit step 1e-60 / plane separation 0.1 are beyond the reference's f32 arithmetic; use the f64 arithmetic (-ref false)",
        Some("z.nrrd"),
    );
    tiny.extend(["-ref", "false"]);
    ok(&d, &tiny);
}

#[test]
fn readme_default_render() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let d = rnd_tests::tmpdir("readme");
    let out = d.join("head.png");
    let o = rendr()
        .current_dir(&root)
        .args(["go", "@data/head.txt", "-o", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let png = std::fs::read(&out).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    // The bundled LUT is exactly what lgen makes from the bundled control points.
    let lut2 = d.join("lut.nrrd");
    let o = rendr()
        .current_dir(&root)
        .args([
            "lgen",
            "-i",
            "data/skin-rgb.txt",
            "data/skin-alpha.txt",
            "-mm",
            "0",
            "255",
            "-o",
            lut2.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success());
    let a = rnd_std::nrrd::read(&lut2).unwrap();
    let b = rnd_std::nrrd::read(&root.join("data/head-lut.nrrd")).unwrap();
    assert_eq!(a.data, b.data);
}

#[test]
fn teval_levoy_and_lut_picture() {
    let d = rnd_tests::tmpdir("teval");
    std::fs::write(
        d.join("a.txt"),
        "#space:=alpha\n0.00 0\n0.80 0\n0.90 1\n1.00 1\n",
    )
    .unwrap();
    let s = ok(&d, &["teval", "a.txt", "0.85"]);
    assert!(s.starts_with("0.5 = a.txt(0.85)"), "{s}");
    std::fs::write(d.join("h.txt"), "#range:=hsv\n0 0.9 1 1\n1 0.9 1 1\n").unwrap();
    let s = ok(&d, &["teval", "h.txt", "0.3"]);
    assert!(s.starts_with("1 0 0.6 = h.txt(0.3)"), "{s}");
    // The seed's levoy example, reading the file from stdin.
    let mut c = rendr()
        .current_dir(&d)
        .args([
            "levoy", "-i", "-", "-mm", "0", "1", "-gm", "1", "-o", "lev.nrrd",
        ])
        .stdin(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    use std::io::Write;
    c.stdin
        .take()
        .unwrap()
        .write_all(b"0.3 1 0.5\n0.7 0.3 1.3\n")
        .unwrap();
    assert!(c.wait().unwrap().success());
    let n = rnd_std::nrrd::read(&d.join("lev.nrrd")).unwrap();
    assert_eq!(n.sizes(), &[256, 256]);
    assert_eq!(n.header.axis_maxs.as_ref().unwrap(), &vec![1.0, 1.0]);
    let v = n.data.to_f64();
    // Cell (i, j): value (i+0.5)/256, |g| (j+0.5)/256; at value 0.3 and the largest |g|
    // the first contour gives ~0.5 and the second nothing (|0.3-0.7| > 0.3 |g|).
    let i = (0.3f64 * 256.0) as usize;
    let at = v[i + 256 * 255];
    assert!((at - 0.5).abs() < 0.01, "{at}");
    // LUT picture: lgen -oi writes a PNG len x h.
    ok(
        &d,
        &[
            "lgen", "-i", "x", "a.txt", "-mm", "0", "1", "-l", "64", "-h", "10", "-o", "l.nrrd",
            "-oi", "l.png",
        ],
    );
    let png = std::fs::read(d.join("l.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    assert_eq!(u32::from_be_bytes(png[16..20].try_into().unwrap()), 64);
    assert_eq!(u32::from_be_bytes(png[20..24].try_into().unwrap()), 10);
}

#[test]
fn info_on_real_ct() {
    let Some(sh) = rnd_tests::shared("info_on_real_ct") else {
        return;
    };
    let d = rnd_tests::tmpdir("info-ct");
    let ct = sh.join("volumes/imageio-stent-ct.nrrd");
    let s = ok(&d, &["info", ct.to_str().unwrap()]);
    assert!(
        s.contains("128 by 128 by 256 volume with type short voxels"),
        "{s}"
    );
    assert!(s.contains(" 1 1 1 (average 1)"), "{s}");
    assert!(s.contains("no spacing recorded"), "{s}");
    assert!(
        s.contains("63.5 63.5 127.5\t= ItoW(63.5 63.5 127.5)"),
        "{s}"
    );
}

/// Ctrl-C during `go` stops it with status 130 and leaves no output or temporary file.
#[test]
fn interrupt_leaves_nothing() {
    let d = rnd_tests::tmpdir("sigint");
    seed_cube(&d);
    let mut child = rendr()
        .current_dir(&d)
        .args([
            "go",
            "@cube-cam.txt",
            "-i",
            "cube.nrrd",
            "-k",
            "c4hexic",
            "-p",
            "gv",
            "-s",
            "0.001",
            "-sz",
            "1200",
            "1200",
            "-nt",
            "1",
            "-o",
            "big.nrrd",
        ])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(700));
    let st = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(st.success());
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130), "{status:?}");
    let names: Vec<String> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(!names.iter().any(|n| n.contains("big.nrrd")), "{names:?}");
}

#[test]
fn mgo_runs_many() {
    let d = rnd_tests::tmpdir("mgo");
    seed_cube(&d);
    std::fs::write(
        d.join("cmds.txt"),
        "# two renderings of one volume\n\
         rendr go @cube-cam.txt -i cube.nrrd -k tent -s 0.1 -p v -b max -o a.nrrd\n\
         ./rendr go @cube-cam.txt -i cube.nrrd -k bspln3 -s 0.1 -p v -b max -sz 30 20 -o b.nrrd\n\
         !!\n",
    )
    .unwrap();
    let s = ok(&d, &["mgo", "-i", "cmds.txt"]);
    assert_eq!(s.matches("================== running:").count(), 3, "{s}");
    assert_eq!(s.matches("================== done").count(), 3);
    let (sa, _) = read_floats(&d.join("a.nrrd"));
    let (sb, _) = read_floats(&d.join("b.nrrd"));
    assert_eq!(sa, vec![1, 300, 300]);
    assert_eq!(sb, vec![1, 30, 20]);
    // Same image as a single go.
    ok(
        &d,
        &[
            "go",
            "@cube-cam.txt",
            "-i",
            "cube.nrrd",
            "-k",
            "tent",
            "-s",
            "0.1",
            "-p",
            "v",
            "-b",
            "max",
            "-o",
            "c.nrrd",
        ],
    );
    assert_eq!(
        read_floats(&d.join("a.nrrd")).1,
        read_floats(&d.join("c.nrrd")).1
    );
    std::fs::write(d.join("bad.txt"), "rendr cam -fr 1 2 3\n").unwrap();
    fails(
        &d,
        &["mgo", "-i", "bad.txt"],
        "bad.txt line 1: not a \"rendr go ...\" command",
        None,
    );
    std::fs::write(
        d.join("bad2.txt"),
        "rendr go @cube-cam.txt -i cube.nrrd -k tent -p rgba -o z.nrrd\n",
    )
    .unwrap();
    fails(&d, &["mgo", "-i", "bad2.txt"], "line 1", Some("z.nrrd"));
}

/// `-fast false` (the plain one-sample loop, no empty-space skipping) and the default
/// accelerated loop write identical bytes on the bundled real MRI, in both engines
/// (`-ref true`, the default, and `-ref false`): lit `over` with the
/// bundled LUT (exercises skipping and early termination) and gradient-magnitude MIP
/// with several kernels, i16 voxels, a perspective camera partly outside the volume.
#[test]
fn fast_loop_matches_plain_on_real_volume() {
    // The response file names the bundled files relative to the repository root.
    let top = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let d = rnd_tests::tmpdir("fastplain");
    let cases: [&[&str]; 4] = [
        &["-sz", "96", "96", "-a1", "0.98"],
        &["-sz", "64", "64", "-p", "gm", "-b", "max", "-k", "ctmr"],
        &[
            "-sz", "64", "64", "-p", "v", "-b", "mean", "-k", "c4hexic", "-s", "2",
        ],
        &[
            "-sz", "64", "64", "-p", "gv", "-b", "sum", "-k", "tent", "-fov", "60",
        ],
    ];
    for (i, extra) in cases.iter().enumerate() {
        for engine in ["true", "false"] {
            let mut outs = Vec::new();
            for fast in ["true", "false"] {
                let o = d.join(format!("o{i}-{engine}-{fast}.nrrd"));
                let o = o.to_string_lossy();
                let mut args = vec![
                    "go",
                    "@data/head.txt",
                    "-ref",
                    engine,
                    "-fast",
                    fast,
                    "-ess",
                    fast,
                    "-o",
                    &o,
                ];
                args.extend_from_slice(extra);
                ok(&top, &args);
                // The data, bit for bit (the headers differ: they record the command).
                let (_, v) = read_floats(Path::new(&*o));
                outs.push(v.iter().map(|x| x.to_bits()).collect::<Vec<u32>>());
            }
            assert!(outs[0].len() > 1000);
            assert!(
                outs[0] == outs[1],
                "case {extra:?} -ref {engine}: fast and plain differ"
            );
        }
    }
}

/// Convolving with AVX2 (where the processor has it) gives the bits of the SSE path
/// (`RND_AVX2=0`), in both engines, on the bundled MRI for every probe that convolves
/// and both cubic kernels.
#[test]
fn avx2_matches_sse_on_real_volume() {
    if !rnd_core::simd::Simd::detect().avx2() {
        eprintln!("skipped: this processor has no AVX2");
        return;
    }
    let top = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let d = rnd_tests::tmpdir("avxsse");
    let cases: [&[&str]; 3] = [
        &["-sz", "96", "96"],
        &["-sz", "64", "64", "-p", "gm", "-b", "max", "-k", "ctmr"],
        &["-sz", "64", "64", "-p", "gv", "-b", "sum", "-ortho"],
    ];
    for (i, extra) in cases.iter().enumerate() {
        for engine in ["true", "false"] {
            let mut outs = Vec::new();
            for avx in ["1", "0"] {
                let o = d.join(format!("o{i}-{engine}-{avx}.nrrd"));
                let o = o.to_string_lossy();
                let mut args = vec!["go", "@data/head.txt", "-ref", engine, "-o", &o];
                args.extend_from_slice(extra);
                let r = rendr()
                    .current_dir(&top)
                    .env("RND_AVX2", avx)
                    .args(&args)
                    .output()
                    .expect("run rendr");
                assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
                let (_, v) = read_floats(Path::new(&*o));
                outs.push(v.iter().map(|x| x.to_bits()).collect::<Vec<u32>>());
            }
            assert!(outs[0].len() > 1000);
            assert!(
                outs[0] == outs[1],
                "case {extra:?} -ref {engine}: AVX2 and SSE differ"
            );
        }
    }
}

/// A reader that stops early (`rendr go -db ... | head -1`) ends rendr quietly (killed by
/// SIGPIPE, like a C tool) rather than with a panic about a failed print.
#[cfg(unix)]
#[test]
fn closed_pipe_is_not_a_panic() {
    use std::io::{BufRead, BufReader};
    use std::os::unix::process::ExitStatusExt;
    use std::process::Stdio;
    let top = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    for args in [
        &["go", "@data/head.txt", "-sz", "32", "32", "-db", "16", "16"][..],
        &["go", "@data/head.txt", "-sz", "64", "64", "-o", "-"][..],
    ] {
        let mut child = rendr()
            .current_dir(&top)
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut out = BufReader::new(child.stdout.take().unwrap());
        let mut line = String::new();
        out.read_line(&mut line).unwrap();
        assert!(!line.is_empty());
        drop(out);
        let o = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert!(
            // 13 = SIGPIPE
            o.status.success() || o.status.signal() == Some(13),
            "{args:?}: {:?}",
            o.status
        );
    }
}

/// An image too large for memory, and bad parameters the library checks, reach the user
/// as one line naming the option (the library names the parameter, the CLI its option).
#[test]
fn library_errors_name_the_option() {
    let d = rnd_tests::tmpdir("liberrors");
    seed_cube(&d);
    let go = |extra: &[&str], frag: &str| {
        let mut a = vec!["go", "@cube-cam.txt", "-i", "cube.nrrd"];
        a.extend_from_slice(&["-k", "tent"]);
        a.extend_from_slice(extra);
        a.extend_from_slice(&["-o", "o.nrrd"]);
        fails(&d, &a, frag, Some("o.nrrd"));
    };
    go(
        &["-sz", "1048576", "1048576"],
        "rendr go: -sz: a 1048576 x 1048576 image with 1 channel would need 4.0 TiB",
    );
    go(
        &["-fov", "0"],
        "rendr go: -fov: field of view must be in (0, 160)",
    );
    go(
        &["-up", "6", "12", "5"],
        "rendr go: -up: up vector (6 12 5)",
    );
    go(
        &["-a1", "0"],
        "rendr go: -a1: alpha_near1 0 must be in (0, 1]",
    );
    go(
        &["-ph", "0.1", "0.6", "0.3", "-2"],
        "rendr go: -ph: specular exponent -2",
    );
    fails(
        &d,
        &[
            "cam",
            "@cube-cam.txt",
            "-fr",
            "0",
            "0",
            "0",
            "-at",
            "0",
            "0",
            "0",
        ],
        "rendr cam: -fr: look-from equals look-at",
        None,
    );
    fails(
        &d,
        &["sdg", "-w", "2", "-l", "0", "1", "1", "-o", "s.nrrd"],
        "rendr sdg: -l: edge lengths must be > 0",
        Some("s.nrrd"),
    );
}

/// `ceval -h true`: the Hessian and the principal curvatures, after the value and
/// gradient lines. On f = |x|² (sampled exactly), Catmull-Rom reproduces the quadratic:
/// Hessian 2I everywhere, and the isosurface through p is the sphere of radius |p|,
/// whose curvatures with the normal −∇f/|∇f| are both −1/|p|.
#[test]
fn ceval_hessian_and_curvature() {
    let d = rnd_tests::tmpdir("cevalh");
    write_squared_distance(&d.join("sq.nrrd"), 12);
    // Off the sample planes on every axis: Catmull-Rom's second derivative jumps at
    // whole index positions.
    let p = [3.0, 0.3, -1.0];
    let s = ok(
        &d,
        &[
            "ceval", "-i", "sq.nrrd", "-k", "ctmr", "-w", "3", "0.3", "-1", "-g", "true", "-h",
            "true",
        ],
    );
    let lines: Vec<&str> = s.lines().collect();
    assert_eq!(lines.len(), 4, "{s}");
    let nums = |l: &str, tag: &str| -> Vec<f64> {
        let (v, t) = l.rsplit_once(' ').unwrap();
        assert_eq!(t, tag, "{l}");
        v.split_whitespace().map(|x| x.parse().unwrap()).collect()
    };
    assert!(lines[1].ends_with("=gradient"), "{s}");
    let h = nums(lines[2], "=hessian");
    let want = [2.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 2.0];
    for (a, b) in h.iter().zip(want) {
        assert!((a - b).abs() < 1e-6, "{s}");
    }
    let k = nums(lines[3], "=kappa");
    let r = p.iter().map(|x: &f64| x * x).sum::<f64>().sqrt();
    assert_eq!(k.len(), 2);
    for x in k {
        assert!((x + 1.0 / r).abs() < 1e-6, "{s}: want {}", -1.0 / r);
    }
    // Outside: said so on every line.
    let s = ok(
        &d,
        &[
            "ceval", "-i", "sq.nrrd", "-k", "ctmr", "-w", "5.4", "0", "0", "-h", "true",
        ],
    );
    assert!(s.ends_with("outside =hessian\noutside =kappa\n"), "{s}");
}

/// `go -p hess` writes 9 channels (2I for |x|², bspln3), `-p k1 -b min` / `-b max` bound
/// −1/r, `-gmc` and the new blends are parsed and refused with the option's name.
#[test]
fn go_second_order_probes_and_measures() {
    let d = rnd_tests::tmpdir("gohess");
    write_squared_distance(&d.join("sq.nrrd"), 16);
    let cam = [
        "-i", "sq.nrrd", "-k", "bspln3", "-fr", "2", "-40", "3", "-at", "2", "0", "3", "-up", "0",
        "0", "1", "-nc", "-4", "-fc", "4", "-fov", "1", "-sz", "5", "5", "-s", "0.3",
    ];
    let with = |extra: &[&str]| -> Vec<String> {
        let mut a: Vec<String> = ["go"].iter().map(|s| s.to_string()).collect();
        a.extend(cam.iter().map(|s| s.to_string()));
        a.extend(extra.iter().map(|s| s.to_string()));
        a
    };
    let run = |extra: &[&str], out: &str| -> (Vec<usize>, Vec<f32>) {
        let a = with(&[extra, &["-o", out]].concat());
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        ok(&d, &a);
        read_floats(&d.join(out))
    };
    let (sizes, h) = run(&["-p", "hess", "-b", "mean"], "h.nrrd");
    assert_eq!(sizes, vec![9, 5, 5]);
    for px in h.chunks(9) {
        for (i, &x) in px.iter().enumerate() {
            let want = if i % 4 == 0 { 2.0 } else { 0.0 };
            assert!((x - want).abs() < 1e-4, "hess[{i}] = {x}");
        }
    }
    // The rays pass (2, y, 3) within 0.35 for |y| ≤ 4: every sample is between
    // r = √(2² + 3²) − 0.5 and √(2² + 4² + 3²) + 0.5 from the centre, where κ1 = −1/r.
    let (r0, r1) = (13f32.sqrt(), 29f32.sqrt());
    let (_, lo) = run(&["-p", "k1", "-b", "min"], "lo.nrrd");
    let (_, hi) = run(&["-p", "k1", "-b", "max"], "hi.nrrd");
    for (&a, &b) in lo.iter().zip(&hi) {
        assert!(
            a >= -1.0 / (r0 - 0.5) && b <= -1.0 / (r1 + 0.5) && a <= b,
            "{a} {b}"
        );
    }
    // Above every gradient magnitude (2r ≤ 11.2 here), the curvature is 0.
    let (_, z) = run(&["-p", "gausscurv", "-b", "l2", "-gmc", "12"], "z.nrrd");
    assert!(z.iter().all(|&x| x == 0.0), "{z:?}");
    let a = with(&["-p", "k1", "-gmc", "-1", "-o", "x.nrrd"]);
    let a: Vec<&str> = a.iter().map(String::as_str).collect();
    fails(
        &d,
        &a,
        "-gmc: curvature gradient threshold -1 must be finite and >= 0",
        Some("x.nrrd"),
    );
    let a = with(&["-b", "mode", "-o", "x.nrrd"]);
    let a: Vec<&str> = a.iter().map(String::as_str).collect();
    fails(&d, &a, "unknown blend \"mode\"", Some("x.nrrd"));
}

/// Writes f = |x|² sampled on an n³ grid of unit spacing centred on the world origin.
fn write_squared_distance(path: &Path, n: usize) {
    use rnd_std::nrrd::{Data, Nrrd};
    let c = (n as f32 - 1.0) / 2.0;
    let data: Vec<f32> = (0..n * n * n)
        .map(|i| {
            let p = [i % n, (i / n) % n, i / (n * n)];
            p.iter().map(|&x| (x as f32 - c).powi(2)).sum()
        })
        .collect();
    let mut vol = Nrrd::new(vec![n, n, n], Data::F32(data)).unwrap();
    vol.header.space = Some("3D-right-handed".into());
    vol.header.space_directions = Some(
        (0..3)
            .map(|a| Some((0..3).map(|b| f64::from(u8::from(a == b))).collect()))
            .collect(),
    );
    vol.header.space_origin = Some(vec![-c as f64; 3]);
    rnd_std::nrrd::write(&vol, path, Default::default()).unwrap();
}

/// `lgen2` writes a 2-D LUT that `go -lut` classifies by: over κ1 × κ2 on |x|² (κ = −1/r
/// with r in [3.1, 5.9] on these rays), a box holding every sample's curvatures makes
/// every pixel's maximum opacity its 0.5 (corrected for the step), one holding none makes it 0; bad primitive
/// files and options are one-line errors that leave nothing behind.
#[test]
fn lgen2_luts_classify_go() {
    let d = rnd_tests::tmpdir("lgen2");
    write_squared_distance(&d.join("sq.nrrd"), 16);
    std::fs::write(
        d.join("all.txt"),
        "# both curvatures in [-0.33, -0.16]\nbox -0.33 -0.16 -0.33 -0.16  1 0 0 0.5\n",
    )
    .unwrap();
    std::fs::write(
        d.join("none.txt"),
        "box -0.1 0 -0.1 0  1 0 0 0.5 # flatter than any\n",
    )
    .unwrap();
    let lgen2 = |prims: &str, out: &str| {
        ok(
            &d,
            &[
                "lgen2", "-p", prims, "-q", "k1", "k2", "-mm", "-1", "0", "-1", "0", "-l", "100",
                "100", "-o", out, "-oi", "pic.png",
            ],
        );
    };
    lgen2("all.txt", "all.nrrd");
    let n = rnd_std::nrrd::read(&d.join("all.nrrd")).unwrap();
    assert_eq!(n.header.sizes, vec![4, 100, 100]);
    let labels = n.header.labels.clone().unwrap();
    assert_eq!(labels, ["RGBA", "gage(scalar:k1)", "gage(scalar:k2)"]);
    assert!(d.join("pic.png").exists());
    lgen2("none.txt", "none.nrrd");
    let go = |lut: &str, out: &str| -> Vec<f32> {
        ok(
            &d,
            &[
                "go", "-i", "sq.nrrd", "-k", "bspln3", "-fr", "2", "-40", "3", "-at", "2", "0",
                "3", "-up", "0", "0", "1", "-nc", "-4", "-fc", "4", "-fov", "1", "-sz", "5", "5",
                "-s", "0.3", "-p", "rgba", "-b", "max", "-lut", lut, "-o", out,
            ],
        );
        read_floats(&d.join(out)).1
    };
    let all = go("all.nrrd", "a.nrrd");
    // The opacity corrected for steps of 0.3 (a little longer off-axis, perspective):
    // 1 − (1 − 0.5)^0.3.
    let want = 1.0 - 0.5f32.powf(0.3);
    assert!(
        all.chunks(4)
            .all(|px| px[..3] == [1.0, 0.0, 0.0] && (px[3] - want).abs() < 2e-5),
        "{all:?}"
    );
    let none = go("none.nrrd", "n.nrrd");
    assert!(none.chunks(4).all(|px| px[3] == 0.0), "{none:?}");
    // Errors.
    std::fs::write(d.join("bad1.txt"), "box 0 1 0 1 1 1 1 1\nblob 1 2\n").unwrap();
    std::fs::write(d.join("bad2.txt"), "gauss 0 0 1 1 1 1 1\n").unwrap();
    std::fs::write(d.join("bad3.txt"), "levoy 0.5 1  1 1 1 1\n").unwrap();
    let base = |prims: &'static str| {
        vec![
            "lgen2", "-p", prims, "-q", "k1", "k2", "-mm", "-1", "0", "-1", "0", "-o", "x.nrrd",
        ]
    };
    fails(
        &d,
        &base("bad1.txt"),
        "bad1.txt: line 2: unknown primitive \"blob\"",
        Some("x.nrrd"),
    );
    fails(
        &d,
        &base("bad2.txt"),
        "line 1: gauss takes 4 numbers and then r g b a (8 in all), not 7",
        Some("x.nrrd"),
    );
    fails(
        &d,
        &base("bad3.txt"),
        "levoy primitive needs axes v and gm (the LUT's are k1 and k2)",
        Some("x.nrrd"),
    );
    let mut same = base("all.txt");
    same[4] = "k2";
    fails(&d, &same, "-q: both axes are k2", Some("x.nrrd"));
    let mut zero = base("all.txt");
    zero.extend(["-l", "0", "3"]);
    fails(&d, &zero, "-l: 0 entries along an axis", Some("x.nrrd"));
    let mut q = base("all.txt");
    q[4] = "hess";
    fails(&d, &q, "-q: unknown quantity \"hess\"", Some("x.nrrd"));
    // A 2-D LUT must say what its axes are.
    let mut n = rnd_std::nrrd::read(&d.join("all.nrrd")).unwrap();
    n.header.labels = None;
    rnd_std::nrrd::write(&n, &d.join("nolabel.nrrd"), Default::default()).unwrap();
    fails(
        &d,
        &[
            "go",
            "-i",
            "sq.nrrd",
            "-k",
            "tent",
            "-fr",
            "2",
            "-40",
            "3",
            "-at",
            "2",
            "0",
            "3",
            "-up",
            "0",
            "0",
            "1",
            "-nc",
            "-4",
            "-fc",
            "4",
            "-fov",
            "1",
            "-sz",
            "5",
            "5",
            "-p",
            "rgba",
            "-lut",
            "nolabel.nrrd",
            "-o",
            "x.nrrd",
        ],
        "nolabel.nrrd: 2-D LUT axis 1 has no label naming its quantity",
        Some("x.nrrd"),
    );
}
