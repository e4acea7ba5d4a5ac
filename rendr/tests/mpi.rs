//! rendr under MPI (cargo feature `mpi`; `cargo test -p rendr --features mpi --test mpi`):
//! `mpirun -np N rendr turn` deals frames to ranks and writes exactly the frames one
//! process writes; a rank that fails stops the whole job with its message, without a
//! hang or any output; `go` refuses more than one process (bricked rendering is not
//! built yet). Skipped without `mpirun` unless `RENDR_REQUIRE_MPI=1` (CI).
#![cfg(feature = "mpi")]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

const RENDR: &str = env!("CARGO_BIN_EXE_rendr");

fn data(f: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../data")
        .join(f)
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("rendr-test-{}-mpi-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

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

fn turn_args(prefix: &str) -> Vec<String> {
    let mut v: Vec<String> = ["turn", "-i"].map(String::from).to_vec();
    v.push(data("itk-t1-head.nrrd").display().to_string());
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
    let dir = tmp("turn");
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
    let dir = tmp("fail");
    // Rank 1 alone is given a lights file that does not exist (MPMD: one program line
    // per rank).
    let good = turn_args("bad");
    let mut bad = good.clone();
    bad.extend(["-lit".to_string(), "/nonexistent/lights.txt".to_string()]);
    let mut args: Vec<String> = Vec::new();
    for (i, a) in [&good, &bad, &good].iter().enumerate() {
        if i > 0 {
            args.push(":".into());
        }
        args.extend(["-np".to_string(), "1".to_string(), RENDR.to_string()]);
        args.extend(a.iter().cloned());
    }
    let out = mpirun(&dir, &args);
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

#[test]
fn go_refuses_more_than_one_process() {
    if !have_mpirun() {
        return;
    }
    let dir = tmp("go");
    let mut args: Vec<String> = ["-np", "2", RENDR, "go", "-i"].map(String::from).to_vec();
    args.push(data("itk-t1-head.nrrd").display().to_string());
    args.extend(
        [
            "-k", "tent", "-fr", "323", "-12.5", "260", "-at", "-127", "-162.5", "110", "-up", "0",
            "0", "1", "-nc", "-150", "-fc", "150", "-fov", "30", "-sz", "16", "16", "-o", "x.png",
        ]
        .map(String::from),
    );
    let out = mpirun(&dir, &args);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("one process"), "{err}");
    assert!(!dir.join("x.png").exists());
    // One process under mpirun renders as without it.
    args[1] = "1".into();
    let out = mpirun(&dir, &args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(dir.join("x.png").exists());
    let _ = std::fs::remove_dir_all(&dir);
}
