//! rendr under MPI (cargo feature `mpi`; `cargo test -p rendr --features mpi --test mpi`):
//! `mpirun -np N rendr turn` deals frames to ranks and writes exactly the frames one
//! process writes; a rank that fails stops the whole job with its message, without a
//! hang or any output; `mpirun -np N rendr go` renders N bricks and composites them:
//! `max` and `median` bit-identical to one process, `over`, `sum` and `mean` within
//! 1e-6, the time channel filled. Skipped without `mpirun` unless `RENDR_REQUIRE_MPI=1`
//! (CI).
#![cfg(feature = "mpi")]

use std::path::Path;
use std::process::{Command, Output};
use std::time::{Duration, Instant};

const RENDR: &str = env!("CARGO_BIN_EXE_rendr");

fn have_mpirun() -> bool {
    if Command::new("mpirun").arg("--version").output().is_ok() {
        return true;
    }
    if std::env::var("RENDR_REQUIRE_MPI").is_ok_and(|v| v == "1") {
        panic!("mpirun is missing and RENDR_REQUIRE_MPI=1 (apt-get install openmpi-bin libopenmpi-dev)");
    }
    eprintln!("skipped: mpi: mpirun is not installed (apt-get install openmpi-bin libopenmpi-dev)");
    false
}

/// Runs `mpirun` with `args` (after its own options) in `dir`, failing the test if it
/// takes more than a minute (a hang).
fn mpirun(dir: &Path, args: &[String]) -> Output {
    let mut child = Command::new("mpirun")
        .args(["--allow-run-as-root", "--oversubscribe"])
        .args(args)
        .current_dir(dir)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("mpirun");
    let t0 = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if t0.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            panic!("mpirun {args:?} hung");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

/// `mpirun -np np rendr go ARGS EXTRA` in `dir`.
fn go_np(dir: &Path, np: usize, args: &[String], extra: &[&str]) -> Output {
    let mut m = vec![
        "-np".to_string(),
        np.to_string(),
        RENDR.to_string(),
        "go".into(),
    ];
    m.extend(args.iter().cloned());
    m.extend(extra.iter().map(|x| x.to_string()));
    mpirun(dir, &m)
}

/// Runs `rendr ARGS` (one process) in `dir`, failing the test when it fails.
fn rendr_ok(dir: &Path, args: &[String]) {
    let out = Command::new(RENDR)
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "rendr {args:?}: {err}");
}

/// A synthetic volume (`rendr sdg -w 12`, Marschner-Lobb) of `sizes` as `out` in `dir`.
fn sdg(dir: &Path, sizes: [&str; 3], out: &str) {
    let mut a: Vec<String> = ["sdg", "-w", "12", "-sz"].map(String::from).to_vec();
    a.extend(sizes.map(String::from));
    a.extend(["-r", "0.1", "0.2", "0", "-o", out].map(String::from));
    rendr_ok(dir, &a);
}

/// `mpirun` arguments that start one rank per argument list (MPMD: `-np 1 rendr ARGS :
/// -np 1 rendr ARGS ...`), rank i running `ranks[i]`.
fn mpmd(ranks: &[&Vec<String>]) -> Vec<String> {
    let mut args: Vec<String> = Vec::new();
    for (i, a) in ranks.iter().enumerate() {
        if i > 0 {
            args.push(":".into());
        }
        args.extend(["-np".to_string(), "1".to_string(), RENDR.to_string()]);
        args.extend(a.iter().cloned());
    }
    args
}

fn turn_args(prefix: &str) -> Vec<String> {
    let mut v: Vec<String> = ["turn", "-i"].map(String::from).to_vec();
    v.push(rnd_tests::data("itk-t1-head.nrrd").display().to_string());
    v.extend(
        [
            "-k", "tent", "-p", "v", "-b", "max", "-s", "2", "-nc", "-150", "-fc", "150", "-sz",
            "48", "40", "-nt", "1", "-fr", "323", "-12.5", "260", "-at", "-127", "-162.5", "110",
            "-up", "0", "0", "1", "-fov", "30", "-n", "7", "-apng",
        ]
        .map(String::from),
    );
    v.push(format!("{prefix}.png"));
    v.extend(["-o".to_string(), prefix.to_string()]);
    v
}

#[test]
fn turn_under_mpi_writes_the_frames_of_one_process() {
    if !have_mpirun() {
        return;
    }
    let dir = rnd_tests::tmpdir("mpi-turn");
    let one = Command::new(RENDR)
        .args(turn_args("one"))
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(
        one.status.success(),
        "{}",
        String::from_utf8_lossy(&one.stderr)
    );
    for np in 1..=4 {
        let prefix = format!("np{np}");
        let mut args = vec!["-np".to_string(), np.to_string(), RENDR.to_string()];
        args.extend(turn_args(&prefix));
        let out = mpirun(&dir, &args);
        assert!(
            out.status.success(),
            "np {np}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        for i in 0..7 {
            let a = std::fs::read(dir.join(format!("one-{i:04}.png"))).unwrap();
            let b = std::fs::read(dir.join(format!("{prefix}-{i:04}.png"))).unwrap();
            assert!(a == b, "np {np}: frame {i} differs");
        }
        let a = std::fs::read(dir.join("one.png")).unwrap();
        let b = std::fs::read(dir.join(format!("{prefix}.png"))).unwrap();
        assert!(a == b, "np {np}: the animations differ");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_failing_rank_stops_the_job_with_its_message_and_no_output() {
    if !have_mpirun() {
        return;
    }
    let dir = rnd_tests::tmpdir("mpi-fail");
    // Rank 1 alone is given a lights file that does not exist (MPMD: one program line
    // per rank).
    let good = turn_args("bad");
    let mut bad = good.clone();
    bad.extend(["-lit".to_string(), "/nonexistent/lights.txt".to_string()]);
    let out = mpirun(&dir, &mpmd(&[&good, &bad, &good]));
    assert!(!out.status.success(), "the job succeeded");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("rendr turn: rank 1 of 3: ") && err.contains("/nonexistent/lights.txt"),
        "{err}"
    );
    assert!(
        !err.contains("rank 0 of 3"),
        "only the failing rank reports: {err}"
    );
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert!(left.is_empty(), "output left behind: {left:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The floats of a NRRD image `rendr go` wrote.
fn floats(path: &Path) -> Vec<f32> {
    match rnd_std::nrrd::read(path).unwrap().data {
        rnd_std::nrrd::Data::F32(v) => v,
        d => panic!("{}: not float data: {d:?}", path.display()),
    }
}

/// `go` options of the test scenes: the bundled head (i16) lit `over` with its LUT and
/// lights, and MIPs and sums of a synthetic float volume, perspective and orthographic.
fn go_scenes() -> Vec<(&'static str, bool, Vec<String>)> {
    let head = rnd_tests::data("itk-t1-head.nrrd").display().to_string();
    let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
    let head_cam = s(&[
        "-fr", "323", "-12.5", "260", "-at", "-127", "-162.5", "110", "-up", "0", "0", "1", "-nc",
        "-150", "-fc", "150", "-fov", "30", "-sz", "64", "56",
    ]);
    let syn_cam = s(&[
        "-fr", "4", "3", "2.5", "-at", "0", "0", "0", "-up", "0", "0", "1", "-nc", "-3", "-fc",
        "3", "-fov", "25", "-sz", "41", "37",
    ]);
    let mut out = Vec::new();
    let mut lit = s(&[
        "-i", &head, "-k", "bspln3", "-p", "rgbalit", "-b", "over", "-s", "1", "-us", "2",
    ]);
    lit.extend(head_cam.clone());
    lit.extend(s(&[
        "-lut",
        &rnd_tests::data("head-lut.nrrd").display().to_string(),
    ]));
    lit.extend(s(&[
        "-lit",
        &rnd_tests::data("head-lights.txt").display().to_string(),
    ]));
    out.push(("head over", false, lit));
    let mut mip = s(&[
        "-i", &head, "-k", "tent", "-p", "v", "-b", "max", "-s", "0.7",
    ]);
    mip.extend(head_cam);
    out.push(("head max", true, mip));
    for (name, exact, k, p, b, ortho) in [
        ("syn max gm", true, "bspln3", "gm", "max", false),
        ("syn max v ortho", true, "ctmr", "v", "max", true),
        ("syn sum", false, "tent", "v", "sum", false),
        ("syn mean ref false", false, "bspln2", "v", "mean", true),
        ("syn median", true, "tent", "gv", "median", false),
    ] {
        let mut v = s(&["-i", "syn.nrrd", "-k", k, "-p", p, "-b", b, "-s", "0.05"]);
        v.extend(syn_cam.clone());
        if ortho {
            v.push("-ortho".into());
        }
        if name.ends_with("ref false") {
            v.extend(s(&["-ref", "false"]));
        }
        out.push((name, exact, v));
    }
    out
}

#[test]
fn go_under_mpi_renders_in_bricks_the_image_of_one_process() {
    if !have_mpirun() {
        return;
    }
    let dir = rnd_tests::tmpdir("mpi-go");
    sdg(&dir, ["45", "38", "31"], "syn.nrrd");
    for (name, exact, args) in go_scenes() {
        let mut one = vec!["go".to_string()];
        one.extend(args.iter().cloned());
        one.extend(["-o", "one.nrrd"].map(String::from));
        rendr_ok(&dir, &one);
        let a = floats(&dir.join("one.nrrd"));
        assert!(a.iter().any(|&x| x != 0.0), "{name}: an empty image");
        for np in 1..=4 {
            let o = format!("np{np}.nrrd");
            let out = go_np(&dir, np, &args, &["-nt", "1", "-o", &o]);
            assert!(
                out.status.success(),
                "{name} np {np}: {}",
                String::from_utf8_lossy(&out.stderr)
            );
            let b = floats(&dir.join(format!("np{np}.nrrd")));
            assert_eq!(a.len(), b.len());
            if exact {
                let same = a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits());
                assert!(same, "{name} np {np}: max is not bit-identical");
            } else {
                for (i, (x, y)) in a.iter().zip(&b).enumerate() {
                    let tol = 1e-6 * x.abs().max(y.abs()).max(1.0);
                    assert!(
                        (x - y).abs() <= tol,
                        "{name} np {np}: float {i}: {x} vs {y}"
                    );
                }
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn go_under_mpi_fills_the_time_channel() {
    if !have_mpirun() {
        return;
    }
    let dir = rnd_tests::tmpdir("mpi-time");
    let (_, _, mip) = go_scenes().remove(1);
    let out = go_np(&dir, 3, &mip, &["-t", "-o", "t.nrrd"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // Two channels: the MIP and the milliseconds every rank spent on the pixel's ray.
    let n = rnd_std::nrrd::read(&dir.join("t.nrrd")).unwrap();
    assert_eq!(n.header.sizes[0], 2);
    let f = floats(&dir.join("t.nrrd"));
    let times: Vec<f32> = f.iter().skip(1).step_by(2).copied().collect();
    assert!(times.iter().all(|t| t.is_finite() && *t >= 0.0));
    assert!(times.iter().any(|&t| t > 0.0), "no time measured");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `RENDR_VERBOSE_BRICKS` makes each rank say which samples it holds and whether it
/// read them alone: the brick of the k-d split plus the kernel's ghost layers (bspln3:
/// two below, three above), read by itself from a raw NRRD.
#[test]
fn go_under_mpi_reports_each_ranks_brick_on_request() {
    if !have_mpirun() {
        return;
    }
    let dir = rnd_tests::tmpdir("mpi-bricks");
    sdg(&dir, ["45", "38", "31"], "syn.nrrd");
    let (name, _, gm) = go_scenes().remove(2);
    assert_eq!(name, "syn max gm");
    // Each rank's stderr in a file of its own (mpirun's combined stream may splice
    // the ranks' output together): ranks/1/rank.R/stderr.
    let mut m: Vec<String> = [
        "-x",
        "RENDR_VERBOSE_BRICKS=1",
        "--output-filename",
        "ranks",
        "-np",
        "2",
        RENDR,
        "go",
    ]
    .map(String::from)
    .to_vec();
    m.extend(gm);
    m.extend(["-nt", "1", "-o", "b.nrrd"].map(String::from));
    let out = mpirun(&dir, &m);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // 45 samples along the longest axis: rank 0 owns 0..22, rank 1 22..45.
    for (rank, line) in [
        "rendr go: rank 0 of 2: samples [0, 0, 0]..[25, 38, 31] of [45, 38, 31], read alone",
        "rendr go: rank 1 of 2: samples [20, 0, 0]..[45, 38, 31] of [45, 38, 31], read alone",
    ]
    .into_iter()
    .enumerate()
    {
        let f = dir.join(format!("ranks/1/rank.{rank}/stderr"));
        let err = std::fs::read_to_string(&f)
            .unwrap_or_else(|e| panic!("{}: {e} (mpirun's --output-filename)", f.display()));
        assert!(
            err.lines().any(|l| l == line),
            "no line {line:?} in {err:?}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn go_under_mpi_stops_on_one_failing_rank_and_refuses_what_it_cannot_split() {
    if !have_mpirun() {
        return;
    }
    let dir = rnd_tests::tmpdir("mpi-gofail");
    let (_, _, good) = go_scenes().remove(1);
    let mut go = vec!["go".to_string()];
    go.extend(good);
    go.extend(["-o".to_string(), "x.png".to_string()]);
    let mut bad = go.clone();
    bad.extend(["-lut".to_string(), "/nonexistent/lut.nrrd".to_string()]);
    let out = mpirun(&dir, &mpmd(&[&go, &go, &bad]));
    assert!(!out.status.success(), "the job succeeded");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("rendr go: rank 2 of 3: ") && err.contains("/nonexistent/lut.nrrd"),
        "{err}"
    );
    assert!(!dir.join("x.png").exists());
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert!(left.is_empty(), "output left behind: {left:?}");
    // A brick that cannot be read: a gzip volume cut short, whose lower half (rank 0's
    // brick, split along z) is intact and whose upper half is missing.
    sdg(&dir, ["20", "20", "40"], "cut.nrrd");
    let whole = std::fs::read(dir.join("cut.nrrd")).unwrap();
    std::fs::write(dir.join("cut.nrrd"), &whole[..whole.len() * 4 / 5]).unwrap();
    let (_, _, mut syn) = go_scenes().remove(2);
    syn[1] = "cut.nrrd".into();
    let out = go_np(&dir, 2, &syn, &["-o", "x.png"]);
    assert!(!out.status.success(), "a truncated brick was rendered");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("rendr go: rank 1 of 2: cut.nrrd") && err.contains("truncated"),
        "{err}"
    );
    assert!(!err.contains("rank 0 of 2"), "rank 0 read its brick: {err}");
    assert!(!dir.join("x.png").exists());
    std::fs::remove_file(dir.join("cut.nrrd")).unwrap();
    // -db traces one ray in one process: refused with a message, nothing written.
    let out = go_np(&dir, 2, &go[1..], &["-db", "3", "3"]);
    assert!(!out.status.success(), "-db under mpirun");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("-db traces a ray in one process"), "{err}");
    assert!(!dir.join("x.png").exists());
    let _ = std::fs::remove_dir_all(&dir);
}
