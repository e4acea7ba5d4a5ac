//! `rendr turn`: each frame is `rendr go` with the camera PREFIX-cams.txt gives it (byte
//! for byte), turntable and key-frame cameras where geometry puts them, the animated
//! PNG holds the frames, and bad input fails before anything is written.

use std::path::Path;
use std::process::Command;

const RENDR: &str = env!("CARGO_BIN_EXE_rendr");

/// The render options shared by `turn` and `go` (camera position given separately).
const COMMON: &[&str] = &[
    "-k", "tent", "-p", "v", "-b", "max", "-s", "2", "-nc", "-150", "-fc", "150", "-sz", "40",
    "32", "-nt", "2",
];

/// Lit `over` with the head's LUT and lights (the options after `COMMON`'s, which they
/// override): every frame has an opacity grid, which the volume keeps between frames.
fn lit_over() -> Vec<String> {
    let d = |f: &str| rnd_tests::data(f).to_string_lossy().into_owned();
    let mut o: Vec<String> = ["-k", "bspln3", "-p", "rgbalit", "-b", "over", "-lut"]
        .map(String::from)
        .to_vec();
    o.extend([d("head-lut.nrrd"), "-lit".into(), d("head-lights.txt")]);
    o
}

fn turn(dir: &Path, extra: &[&str]) -> std::process::Output {
    turn_with(dir, &[], extra)
}

fn turn_with(dir: &Path, opts: &[String], extra: &[&str]) -> std::process::Output {
    Command::new(RENDR)
        .arg("turn")
        .arg("-i")
        .arg(rnd_tests::data("itk-t1-head.nrrd"))
        .args(COMMON)
        .args(opts)
        .args(extra)
        .current_dir(dir)
        .output()
        .unwrap()
}

/// Each line of PREFIX-cams.txt: the frame's file and its camera words.
fn cams(dir: &Path, prefix: &str) -> Vec<(String, Vec<String>)> {
    std::fs::read_to_string(dir.join(format!("{prefix}-cams.txt")))
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| {
            let mut w = l.split_whitespace().map(str::to_string);
            (w.next().unwrap(), w.collect())
        })
        .collect()
}

fn nums(words: &[String], opt: &str, n: usize) -> Vec<f64> {
    let i = words.iter().position(|w| w == opt).unwrap();
    words[i + 1..i + 1 + n]
        .iter()
        .map(|w| w.parse().unwrap())
        .collect()
}

#[test]
fn every_frame_is_go_with_its_camera() {
    let dir = rnd_tests::tmpdir("turn-frames");
    // A value MIP, then lit `over` (whose frames after the first take the grid the
    // volume kept: still go's bytes).
    let mut cams = Vec::new();
    for opts in [Vec::new(), lit_over()] {
        let out = turn_with(
            &dir,
            &opts,
            &[
                "-fr", "323", "-12.5", "260", "-at", "-127", "-162.5", "110", "-up", "0", "0", "1",
                "-fov", "30", "-n", "4", "-o", "f", "-apng", "anim.png",
            ],
        );
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        cams = self::cams(&dir, "f");
        assert_eq!(cams.len(), 4);
        let mut seen = Vec::new();
        for (file, words) in &cams {
            let go = Command::new(RENDR)
                .arg("go")
                .arg("-i")
                .arg(rnd_tests::data("itk-t1-head.nrrd"))
                .args(COMMON)
                .args(&opts)
                .args(words)
                .args(["-o", "go.png"])
                .current_dir(&dir)
                .status()
                .unwrap();
            assert!(go.success());
            let a = std::fs::read(dir.join(file)).unwrap();
            let b = std::fs::read(dir.join("go.png")).unwrap();
            assert!(a == b, "{file} differs from rendr go {}", words.join(" "));
            seen.push(a);
        }
        // (Frames that show something, and not all the same.)
        assert!(seen.iter().any(|f| f != &seen[0]), "{opts:?}");
    }
    // A quarter turn apart about the up vector (z) through the look-at point: frame 2 is
    // half a turn from frame 0, so its look-from point is mirrored through the axis.
    let fr2 = nums(&cams[2].1, "-fr", 3);
    let want = [-127.0 - 450.0, -162.5 - 150.0, 260.0];
    for a in 0..3 {
        assert!((fr2[a] - want[a]).abs() < 1e-9, "{fr2:?} vs {want:?}");
    }
    assert_eq!(nums(&cams[2].1, "-at", 3), vec![-127.0, -162.5, 110.0]);
    // The animated PNG: an acTL chunk saying 4 frames, and its default image is frame 0.
    let apng = std::fs::read(dir.join("anim.png")).unwrap();
    let at = apng
        .windows(4)
        .position(|w| w == b"acTL")
        .expect("an acTL chunk");
    assert_eq!(&apng[at + 4..at + 8], &4u32.to_be_bytes());
    let first = image::load_from_memory(&apng).unwrap().to_luma8();
    let f0 = image::load_from_memory(&std::fs::read(dir.join("f-0000.png")).unwrap())
        .unwrap()
        .to_luma8();
    assert!(first == f0, "the animation's first frame is not frame 0");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn key_frames_are_passed_through_and_interpolated() {
    let dir = rnd_tests::tmpdir("turn-keys");
    std::fs::write(
        dir.join("keys.txt"),
        "# fr at up fov\n\
         323 -12.5 260   -127 -162.5 110   0 0 1   30\n\
         -127 -612.5 110 -127 -162.5 110   0 0 1   20  # from the front\n\
         -577 -312.5 260 -127 -162.5 110   0 0 1   30\n",
    )
    .unwrap();
    let cam = [
        "-fr", "1", "2", "3", "-at", "0", "0", "0", "-up", "0", "0", "1", "-fov", "9",
    ];
    let out = turn(
        &dir,
        &[&cam[..], &["-key", "keys.txt", "-n", "5", "-o", "k"]].concat(),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let c = cams(&dir, "k");
    assert_eq!(c.len(), 5);
    assert_eq!(nums(&c[0].1, "-fr", 3), vec![323.0, -12.5, 260.0]);
    assert_eq!(nums(&c[2].1, "-fr", 3), vec![-127.0, -612.5, 110.0]);
    assert_eq!(nums(&c[2].1, "-fov", 1), vec![20.0]);
    assert_eq!(nums(&c[4].1, "-fr", 3), vec![-577.0, -312.5, 260.0]);
    assert_eq!(nums(&c[1].1, "-fr", 3), vec![98.0, -312.5, 185.0]);
    assert_eq!(nums(&c[1].1, "-fov", 1), vec![25.0]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_input_fails_before_writing() {
    let dir = rnd_tests::tmpdir("turn-bad");
    let cam = [
        "-fr", "323", "-12.5", "260", "-at", "-127", "-162.5", "110", "-up", "0", "0", "1", "-fov",
        "30",
    ];
    std::fs::write(dir.join("short.txt"), "1 2 3 4 5 6 7 8 9 10\n").unwrap();
    std::fs::write(
        dir.join("par.txt"),
        "0 0 9 0 0 0 0 0 1 30\n9 0 0 0 0 0 0 0 1 30\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("nan.txt"),
        "1 2 3 4 5 6 7 8 9\n1 2 3 4 5 6 7 8 9 10\n",
    )
    .unwrap();
    for (extra, msg) in [
        (&["-n", "0", "-o", "x"][..], "-n"),
        (&["-n", "3", "-o", "x", "-f", "gif"], "-f"),
        (&["-n", "3", "-o", "x", "-axis", "0", "0", "0"], "-axis"),
        (
            &["-n", "3", "-o", "x", "-key", "short.txt"],
            "at least 2 key frames",
        ),
        (&["-n", "3", "-o", "x", "-key", "nan.txt"], "line 1"),
        (
            &["-n", "3", "-o", "x", "-key", "missing.txt"],
            "missing.txt",
        ),
        (&["-n", "3", "-o", "no/such/dir/x"], "-o"),
        (&["-n", "3", "-o", "x", "-fps", "0"], "-fps"),
        // Up parallel to the view direction on a frame of the path.
        (&["-n", "4", "-o", "x", "-key", "par.txt"], "frame 0"),
    ] {
        let out = turn(&dir, &[&cam[..], extra].concat());
        assert!(!out.status.success(), "{extra:?} succeeded");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(msg), "{extra:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{extra:?}: one line: {err}");
    }
    let left: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|f| f.starts_with('x') || f.starts_with(".x"))
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A raw float NRRD of n³ samples in this machine's byte order whose samples start at a
/// multiple of four bytes: one that can be mapped.
fn raw_nrrd(path: &Path, n: usize) {
    let endian = if cfg!(target_endian = "little") {
        "little"
    } else {
        "big"
    };
    let mut head = format!(
        "NRRD0004\ntype: float\ndimension: 3\nsizes: {n} {n} {n}\nendian: {endian}\nencoding: raw\n"
    );
    // A comment line of the length that brings the header (with its blank line) to a
    // multiple of four bytes.
    let pad = (4 - (head.len() + 3) % 4) % 4;
    head.insert_str(9, &format!("#{}\n", " ".repeat(pad)));
    head.push('\n');
    assert_eq!(head.len() % 4, 0);
    let mut bytes = head.into_bytes();
    for i in 0..n * n * n {
        bytes.extend_from_slice(&((i % 37) as f32 * 0.25).to_ne_bytes());
    }
    std::fs::write(path, bytes).unwrap();
}

/// A turn of several frames holds the volume's samples in memory (its frames render
/// quicker from pages the system can make large); one frame uses a raw NRRD in place
/// from a map of the file, as `go` does. `RENDR_MMAP=0` and `=1` choose either way, and
/// the frames are the same bytes whichever holds the samples.
#[test]
fn many_frames_hold_the_samples_in_memory() {
    let dir = rnd_tests::tmpdir("turn-hold");
    raw_nrrd(&dir.join("v.nrrd"), 8);
    let run = |n: &str, mmap: Option<&str>, prefix: &str| -> (String, Vec<u8>) {
        let mut c = Command::new(RENDR);
        c.args([
            "turn", "-i", "v.nrrd", "-fr", "90", "-200", "70", "-at", "4", "4", "4",
        ])
        .args([
            "-up", "0", "0", "1", "-fov", "30", "-n", n, "-f", "nrrd", "-o", prefix,
        ])
        .args(COMMON)
        .env("RND_VERBOSE", "1")
        .env_remove("RENDR_MMAP")
        .current_dir(&dir);
        if let Some(m) = mmap {
            c.env("RENDR_MMAP", m);
        }
        let o = c.output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(o.status.success(), "turn -n {n}: {err}");
        let frame = std::fs::read(dir.join(format!("{prefix}-0000.nrrd"))).unwrap();
        (err, frame)
    };
    let held = "the volume's samples are held in memory";
    let mapped = "the volume's samples are mapped from its file";
    let mut frames = Vec::new();
    for (n, mmap, says) in [
        ("3", None, held),
        ("1", None, mapped),
        ("3", Some("1"), mapped),
        ("1", Some("0"), held),
    ] {
        let prefix = format!("f{}{}", n, mmap.unwrap_or("-"));
        let (err, frame) = run(n, mmap, &prefix);
        assert!(
            err.contains(says),
            "turn -n {n}, RENDR_MMAP {mmap:?}: {err}"
        );
        // (The header names the file; the samples after it must agree.)
        frames.push(frame[frame.len() - 40 * 32 * 4..].to_vec());
    }
    assert!(frames.windows(2).all(|w| w[0] == w[1]));
    // (Rays that hit the volume: not an empty image.)
    assert!(frames[0].iter().any(|&b| b != 0));
}

/// A volume that would take more than half the memory the process may use stays mapped
/// however many frames are rendered: a 10 MB volume under a 16 MiB data-segment limit
/// (`ulimit -d`, which a read-only map of a file does not count against).
#[cfg(target_os = "linux")]
#[test]
fn a_volume_too_big_to_hold_stays_mapped() {
    let dir = rnd_tests::tmpdir("turn-big");
    raw_nrrd(&dir.join("mid.nrrd"), 136);
    for (limit, says) in [
        ("16384", "the volume's samples are mapped from its file"),
        ("65536", "the volume's samples are held in memory"),
    ] {
        let o = Command::new("sh")
            .arg("-c")
            .arg(format!(
                "ulimit -d {limit} && exec \"$0\" turn -i mid.nrrd -fr 900 -2000 700 \
                 -at 60 60 60 -up 0 0 1 -fov 30 -sz 16 16 -k tent -nc -150 -fc 150 -n 2 \
                 -f nrrd -o f"
            ))
            .arg(RENDR)
            .env("RND_VERBOSE", "1")
            .env_remove("RENDR_MMAP")
            .current_dir(&dir)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "ulimit -d {limit}: {err}");
        assert!(err.contains(says), "ulimit -d {limit}: {err}");
    }
}
