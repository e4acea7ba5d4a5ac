//! Robustness against attackers and careless users (issue #18): output safety, bounded
//! reads, no panics on odd input, clean refusals. Each case states the rule it checks.
//!
//! Every failing case must end with status 1 and one line on stderr (never 101 = panic,
//! 134 = abort, nor a hang: each run is killed after a minute and the test fails), leave
//! no output and no temporary file behind, and keep existing files as they were. Memory
//! bounds are checked by running rendr under an address-space limit (`ulimit -v`) far
//! below what the unbounded behaviour would take; the big inputs are sparse files, so
//! they cost no disk.

#![cfg(unix)]

use std::ffi::OsStr;
use std::io::Read;
use std::os::unix::ffi::OsStrExt;
use std::os::unix::fs::FileTypeExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_rendr");

/// What a run gave.
struct Ran {
    code: Option<i32>,
    stdout: Vec<u8>,
    stderr: String,
}

fn wait_limited(mut child: Child, what: &str) -> Ran {
    let t0 = Instant::now();
    loop {
        if let Some(st) = child.try_wait().unwrap() {
            let mut out = Vec::new();
            let mut err = String::new();
            if let Some(mut o) = child.stdout.take() {
                o.read_to_end(&mut out).unwrap();
            }
            if let Some(mut e) = child.stderr.take() {
                e.read_to_string(&mut err).unwrap();
            }
            return Ran {
                code: st.code(),
                stdout: out,
                stderr: err,
            };
        }
        if t0.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            panic!("{what}: still running after 60 s (a hang)");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Runs `rendr args` in `dir` with stdin from `stdin` (or nothing), under an
/// address-space limit of `vmem_mb` MiB when given. Stdout goes to a file (so a large
/// output can't fill a pipe) and is returned.
fn run(dir: &Path, args: &[&OsStr], stdin: Option<&Path>, vmem_mb: Option<u64>) -> Ran {
    let mut c = match vmem_mb {
        Some(mb) => {
            let mut c = Command::new("sh");
            c.arg("-c")
                .arg(format!("ulimit -v {}; exec \"$0\" \"$@\"", mb * 1024))
                .arg(BIN);
            c
        }
        None => Command::new(BIN),
    };
    let out_file = dir.join(format!(
        ".stdout-{:?}-{}",
        std::thread::current().id(),
        std::process::id()
    ));
    let out_file = PathBuf::from(out_file.to_string_lossy().replace(
        |c: char| !c.is_ascii_alphanumeric() && c != '/' && c != '.' && c != '-',
        "",
    ));
    c.current_dir(dir)
        .args(args)
        .stdout(std::fs::File::create(&out_file).unwrap())
        .stderr(Stdio::piped())
        .stdin(match stdin {
            Some(p) => Stdio::from(std::fs::File::open(p).unwrap()),
            None => Stdio::null(),
        });
    let what = format!("rendr {args:?}");
    let mut r = wait_limited(c.spawn().unwrap(), &what);
    r.stdout = std::fs::read(&out_file).unwrap_or_default();
    let _ = std::fs::remove_file(&out_file);
    r
}

fn os<'a>(args: &[&'a str]) -> Vec<&'a OsStr> {
    args.iter().map(|a| OsStr::new(*a)).collect()
}

/// The names in `dir` (hidden helper files of this test excluded).
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !n.starts_with(".stdout-"))
        .collect();
    v.sort();
    v
}

/// Status 1 and one stderr line containing `frag`, no panic.
fn assert_refusal(r: &Ran, ctx: &str, frag: &str) {
    assert_eq!(
        r.code,
        Some(1),
        "{ctx}: status {:?}, stderr {}",
        r.code,
        r.stderr
    );
    assert!(
        r.stderr.contains(frag),
        "{ctx}: stderr {:?} lacks {frag:?}",
        r.stderr
    );
    let lines = r.stderr.trim_end().lines().count();
    assert_eq!(lines, 1, "{ctx}: not one line: {:?}", r.stderr);
    assert!(!r.stderr.contains("panicked"), "{ctx}: {}", r.stderr);
    // Nothing half-done on standard output either: a refusal prints no results first.
    assert!(
        r.stdout.is_empty(),
        "{ctx}: printed before failing: {:?}",
        String::from_utf8_lossy(&r.stdout)
    );
}

/// A refusal: status 1, one stderr line containing `frag`, no panic, no temporary file,
/// and the directory's contents unchanged (nothing created, nothing removed).
fn refused(
    dir: &Path,
    rule: &str,
    args: &[&OsStr],
    stdin: Option<&Path>,
    vmem: Option<u64>,
    frag: &str,
) {
    let before = listing(dir);
    let r = run(dir, args, stdin, vmem);
    let ctx = format!("rule \"{rule}\": rendr {args:?}");
    assert_refusal(&r, &ctx, frag);
    assert_eq!(listing(dir), before, "{ctx}: files created or removed");
}

/// A success: status 0, no temporary file left.
fn succeeds(
    dir: &Path,
    rule: &str,
    args: &[&OsStr],
    stdin: Option<&Path>,
    vmem: Option<u64>,
) -> Ran {
    let r = run(dir, args, stdin, vmem);
    assert_eq!(
        r.code,
        Some(0),
        "rule \"{rule}\": rendr {args:?}: status {:?}, stderr {}",
        r.code,
        r.stderr
    );
    assert!(
        !listing(dir).iter().any(|n| n.contains("rendr-tmp")),
        "rule \"{rule}\": temporary file left"
    );
    r
}

fn corpus(kind: &str, name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/corpus")
        .join(kind)
        .join(name)
        .to_string_lossy()
        .into_owned()
}

/// A small volume, a camera file and a LUT in a fresh directory.
fn scene(name: &str) -> PathBuf {
    let d = rnd_tests::tmpdir(name);
    let r = run(
        &d,
        &os(&[
            "sdg",
            "-w",
            "2",
            "-sz",
            "16",
            "16",
            "16",
            "-l",
            "4",
            "4",
            "4",
            "-o",
            "cube.nrrd",
        ]),
        None,
        None,
    );
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    std::fs::write(
        d.join("cam.txt"),
        "-fr 6 12 5 -at 0 0 0 -up 0 0 1 -nc -2.6 -fc 2.6 -fov 16 -sz 40 30 -k tent\n",
    )
    .unwrap();
    d
}

const GO: [&str; 6] = ["go", "@cam.txt", "-i", "cube.nrrd", "-k", "tent"];

/// The words of `s` (a command line without quoting).
fn w(s: &str) -> Vec<&str> {
    s.split_whitespace().collect()
}

fn go_args<'a>(extra: &[&'a str]) -> Vec<&'a str> {
    let mut v = GO.to_vec();
    v.extend_from_slice(extra);
    v
}

/// A raw float volume whose data is a detached, sparse file of `len` bytes.
fn sparse(dir: &Path, name: &str, len: u64) -> PathBuf {
    let p = dir.join(name);
    let f = std::fs::File::create(&p).unwrap();
    f.set_len(len).unwrap();
    p
}

// ---------------------------------------------------------------------------------------
// Output safety

/// Rule: an output that is a symbolic link is replaced, never followed (a planted link
/// can't make rendr write over another file).
#[test]
fn output_link_is_replaced_not_followed() {
    let d = scene("olink");
    std::fs::write(d.join("victim"), b"victim").unwrap();
    std::os::unix::fs::symlink(d.join("victim"), d.join("o.nrrd")).unwrap();
    succeeds(
        &d,
        "link replaced",
        &os(&go_args(&["-o", "o.nrrd"])),
        None,
        None,
    );
    assert_eq!(std::fs::read(d.join("victim")).unwrap(), b"victim");
    let m = std::fs::symlink_metadata(d.join("o.nrrd")).unwrap();
    assert!(m.file_type().is_file());
    assert!(std::fs::read(d.join("o.nrrd"))
        .unwrap()
        .starts_with(b"NRRD0004"));
}

/// Rule: character devices are written into, never replaced: a null device takes the
/// image and stays a device; a full device (`/dev/full`) reports the failed write.
///
/// As root the devices are private nodes made with mknod in the test's directory (a
/// regression must not replace the system's `/dev/null`; an earlier rendr did); as
/// another user the system's own, which that user can't replace.
#[test]
fn devices_are_written_not_replaced() {
    let d = scene("odev");
    let private = Command::new("mknod")
        .args([
            d.join("null").as_os_str(),
            OsStr::new("c"),
            OsStr::new("1"),
            OsStr::new("3"),
        ])
        .status()
        .is_ok_and(|s| s.success())
        && Command::new("mknod")
            .args([
                d.join("full").as_os_str(),
                OsStr::new("c"),
                OsStr::new("1"),
                OsStr::new("7"),
            ])
            .status()
            .is_ok_and(|s| s.success());
    let (null, full) = if private {
        (d.join("null"), d.join("full"))
    } else {
        let _ = std::fs::remove_file(d.join("null"));
        (PathBuf::from("/dev/null"), PathBuf::from("/dev/full"))
    };
    let (nulls, fulls) = (
        null.to_string_lossy().into_owned(),
        full.to_string_lossy().into_owned(),
    );
    succeeds(
        &d,
        "write into a null device",
        &os(&go_args(&["-o", &nulls])),
        None,
        None,
    );
    assert!(std::fs::metadata(&null)
        .unwrap()
        .file_type()
        .is_char_device());
    if full.exists() {
        refused(
            &d,
            "a failed write to a device is an error",
            &os(&go_args(&["-o", &fulls])),
            None,
            None,
            "No space left on device",
        );
        assert!(std::fs::metadata(&full)
            .unwrap()
            .file_type()
            .is_char_device());
    }
}

/// Rule: a FIFO output is written into (the reader gets the image), not replaced.
#[test]
fn fifo_output_is_written_into() {
    let d = scene("ofifo");
    let fifo = d.join("pipe.nrrd");
    let st = Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(st.success());
    let f2 = fifo.clone();
    let reader = std::thread::spawn(move || std::fs::read(f2).unwrap());
    succeeds(
        &d,
        "write into a FIFO",
        &os(&go_args(&["-o", "pipe.nrrd"])),
        None,
        None,
    );
    // Checked before joining: a FIFO replaced by a file would leave the reader waiting.
    assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());
    let got = reader.join().unwrap();
    assert!(
        got.starts_with(b"NRRD0004"),
        "{:?}",
        &got[..got.len().min(20)]
    );
}

/// Rule: an output that is one of the inputs (by identity: another spelling, a hard
/// link, a volume's detached data file, an @file, lgen's and levoy's inputs) is refused
/// before anything is written; the input survives byte for byte.
#[test]
fn output_that_is_an_input_is_refused() {
    let d = scene("oinput");
    // A detached header whose data file is data.raw.
    let vals: Vec<u8> = (0..8u32).flat_map(|i| (i as f32).to_le_bytes()).collect();
    std::fs::write(d.join("data.raw"), &vals).unwrap();
    std::fs::write(
        d.join("vol.nhdr"),
        "NRRD0004\ntype: float\ndimension: 3\nsizes: 2 2 2\nendian: little\nencoding: raw\ndata file: data.raw\n",
    )
    .unwrap();
    std::fs::hard_link(d.join("cube.nrrd"), d.join("hard.nrrd")).unwrap();
    std::fs::write(d.join("alpha.txt"), "#space:=alpha\n0 0\n1 1\n").unwrap();
    std::fs::write(d.join("lev.txt"), "0.5 0.1 1\n").unwrap();
    let cube = std::fs::read(d.join("cube.nrrd")).unwrap();
    let cases: &[(&str, Vec<&str>)] = &[
        ("same name", go_args(&["-o", "cube.nrrd"])),
        ("another spelling", go_args(&["-o", "./cube.nrrd"])),
        ("a hard link", go_args(&["-o", "hard.nrrd"])),
        ("the @file", go_args(&["-o", "cam.txt"])),
        (
            "a detached data file",
            w("go @cam.txt -i vol.nhdr -o data.raw"),
        ),
        (
            "lgen's input",
            w("lgen -i x alpha.txt -mm 0 1 -o alpha.txt"),
        ),
        (
            "lgen's two outputs",
            w("lgen -i x alpha.txt -mm 0 1 -o l.nrrd -oi l.nrrd"),
        ),
        (
            "levoy's input",
            w("levoy -i lev.txt -mm 0 1 -gm 1 -o lev.txt"),
        ),
    ];
    for (rule, args) in cases {
        let frag = if *rule == "lgen's two outputs" {
            "would overwrite the LUT output"
        } else {
            "would overwrite the input"
        };
        refused(&d, rule, &os(args), None, None, frag);
    }
    assert_eq!(std::fs::read(d.join("cube.nrrd")).unwrap(), cube);
    assert_eq!(std::fs::read(d.join("data.raw")).unwrap(), vals);
    assert!(std::fs::read_to_string(d.join("cam.txt"))
        .unwrap()
        .starts_with("-fr"));
    assert!(std::fs::read_to_string(d.join("alpha.txt"))
        .unwrap()
        .starts_with("#space"));
    assert_eq!(
        std::fs::read_to_string(d.join("lev.txt")).unwrap(),
        "0.5 0.1 1\n"
    );
}

/// Rule: the output's directory is checked before any work: a missing directory is
/// named, even when the input is missing too (the output is checked first).
#[test]
fn missing_output_directory_is_found_first() {
    let d = scene("odir");
    refused(
        &d,
        "missing directory named before reading",
        &os(&["go", "@cam.txt", "-i", "missing.nrrd", "-o", "nodir/o.nrrd"]),
        None,
        None,
        "directory nodir does not exist",
    );
}

/// Rule: a legal 250-character output name works (the temporary name is short).
#[test]
fn long_output_name_works() {
    let d = scene("olong");
    let name = format!("{}.nrrd", "n".repeat(245));
    succeeds(&d, "long name", &os(&go_args(&["-o", &name])), None, None);
    assert!(d.join(&name).exists());
}

/// Rule: writing to a closed standard output is an error naming standard output (not
/// "(stdin)"), not a silent success.
#[test]
fn closed_stdout_is_an_error() {
    let d = scene("ostdout");
    let mut c = Command::new("sh");
    c.current_dir(&d)
        .arg("-c")
        .arg("exec \"$0\" \"$@\" >&-")
        .arg(BIN)
        .args(go_args(&["-o", "-"]))
        .stderr(Stdio::piped())
        .stdout(Stdio::null());
    let r = wait_limited(c.spawn().unwrap(), "go -o - with stdout closed");
    assert_refusal(
        &r,
        "go -o - with stdout closed",
        "standard output is closed",
    );
    assert!(!r.stderr.contains("(stdin)"), "{}", r.stderr);
}

/// Rule: SIGTERM, SIGHUP and SIGINT during a run remove the temporary output and leave
/// an existing output as it was; the status is 128 + the signal.
#[test]
fn signals_leave_nothing_behind() {
    let d = scene("osig");
    std::fs::write(
        d.join("big.txt"),
        "-fr 6 12 5 -at 0 0 0 -up 0 0 1 -nc -2.6 -fc 2.6 -fov 16 -sz 3000 3000 -s 0.001\n",
    )
    .unwrap();
    std::fs::write(d.join("keep.nrrd"), b"precious").unwrap();
    for (sig, name) in [(15, "TERM"), (1, "HUP"), (2, "INT")] {
        let child = Command::new(BIN)
            .current_dir(&d)
            .args([
                "go",
                "@big.txt",
                "-i",
                "cube.nrrd",
                "-k",
                "bspln3",
                "-nt",
                "1",
                "-o",
                "keep.nrrd",
            ])
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // The temporary file exists as soon as the output is prepared, before the
        // render: wait for it, then signal.
        let t0 = Instant::now();
        while !listing(&d).iter().any(|n| n.contains("rendr-tmp")) {
            assert!(
                t0.elapsed() < Duration::from_secs(30),
                "no temporary file appeared"
            );
            std::thread::sleep(Duration::from_millis(5));
        }
        let st = Command::new("kill")
            .args([format!("-{name}"), child.id().to_string()])
            .status()
            .unwrap();
        assert!(st.success());
        let r = wait_limited(child, "signalled go");
        assert_eq!(r.code, Some(128 + sig), "SIG{name}: {}", r.stderr);
        assert!(
            !listing(&d).iter().any(|n| n.contains("rendr-tmp")),
            "SIG{name}: temporary file left"
        );
        assert_eq!(std::fs::read(d.join("keep.nrrd")).unwrap(), b"precious");
    }
}

// ---------------------------------------------------------------------------------------
// No panics

/// Rule: an argument that is not UTF-8 is refused by position, not a panic.
#[test]
fn non_utf8_argument_is_refused() {
    let d = scene("utf8");
    let bad = OsStr::from_bytes(b"caf\xe9.nrrd");
    let args: Vec<&OsStr> = vec![OsStr::new("info"), bad];
    refused(
        &d,
        "non-UTF-8 argument",
        &args,
        None,
        None,
        "not valid UTF-8",
    );
}

/// Rule: a failed write to standard output (a full disk) is a one-line error, status 1,
/// for every printing command.
#[test]
fn full_stdout_is_an_error() {
    if !Path::new("/dev/full").exists() {
        eprintln!("skipped: no /dev/full");
        return;
    }
    let d = scene("full");
    let cases: &[&[&str]] = &[
        &["info", "cube.nrrd"],
        &["klist"],
        &["about"],
        &["go", "@cam.txt", "-i", "cube.nrrd", "-db", "20", "15"],
        &["go", "@cam.txt", "-i", "cube.nrrd", "-o", "-"],
    ];
    for a in cases {
        let mut c = Command::new(BIN);
        c.current_dir(&d)
            .args(*a)
            .stdout(
                std::fs::OpenOptions::new()
                    .write(true)
                    .open("/dev/full")
                    .unwrap(),
            )
            .stderr(Stdio::piped());
        let r = wait_limited(c.spawn().unwrap(), "to /dev/full");
        assert_refusal(&r, &format!("{a:?} > /dev/full"), "No space left on device");
    }
}

// ---------------------------------------------------------------------------------------
// The bad-input corpus: one file each, with the rule it checks.

/// Rule per file: a clear one-line refusal from `info` and from `go`, no output.
#[test]
fn new_bad_input_corpus() {
    let d = scene("corpus18");
    let cases: &[(&str, &str, &str)] = &[
        (
            "gzip-bad-crc.nrrd",
            "a corrupt gzip stream (bad CRC-32) is refused",
            "gzip data is corrupt",
        ),
        (
            "duplicate-type.nrrd",
            "a header field given twice is refused",
            "field \"type\" given twice",
        ),
        (
            "escape-in-header.nrrd",
            "header text echoed in an error has its control characters escaped",
            "\\u{1b}[2J",
        ),
        (
            "format-width.nhdr",
            "a data file name field width out of range is refused",
            "field width",
        ),
        (
            "format-range.nhdr",
            "a data file range overflowing 64 bits is refused",
            "does not give 1 to",
        ),
        (
            "format-wrap.nhdr",
            "a data file counter near the 64-bit end ends (no wrap)",
            "can't read detached data",
        ),
        (
            "list-no-files.nrrd",
            "a LIST of data files naming none is refused (not read as attached data)",
            "LIST names no files",
        ),
    ];
    for (f, rule, frag) in cases {
        let p = corpus("bad", f);
        refused(&d, rule, &os(&["info", &p]), None, None, frag);
        refused(
            &d,
            rule,
            &os(&["go", "@cam.txt", "-i", &p, "-o", "o.nrrd"]),
            None,
            None,
            frag,
        );
    }
    // No raw escape byte reaches the terminal.
    let r = run(
        &d,
        &os(&["info", &corpus("bad", "escape-in-header.nrrd")]),
        None,
        None,
    );
    assert!(!r.stderr.contains('\u{1b}'), "{:?}", r.stderr);
    refused(
        &d,
        "control points whose span overflows a double are refused",
        &os(&[
            "lgen",
            "-i",
            "x",
            &corpus("bad", "txf-huge-span.txt"),
            "-mm",
            "0",
            "1",
            "-o",
            "l.nrrd",
        ]),
        None,
        None,
        "wider than a double can hold",
    );
    refused(
        &d,
        "a LUT domain whose width overflows a double is refused",
        &os(&[
            "lgen", "-i", "x", "x", "-mm", "-1e308", "1e308", "-o", "l.nrrd",
        ]),
        None,
        None,
        "wider than a double can hold",
    );
    refused(
        &d,
        "keval -a nan is refused",
        &os(&["keval", "-a", "nan", "ctmr", "0.5"]),
        None,
        None,
        "-a: alpha",
    );
    refused(
        &d,
        "keval at NaN is refused",
        &os(&["keval", "ctmr", "nan"]),
        None,
        None,
        "NaN",
    );
}

/// Rule: valid odd input succeeds: Latin-1 bytes in a header comment and in a text
/// array's comment (as Teem reads them), Latin-1 in an @file comment.
#[test]
fn odd_but_valid_input_is_read() {
    let d = scene("odd");
    let r = succeeds(
        &d,
        "Latin-1 header comment",
        &os(&["info", &corpus("odd", "latin1-comment.nrrd")]),
        None,
        None,
    );
    assert!(String::from_utf8_lossy(&r.stdout).contains("2 by 2 by 2 volume"));
    succeeds(
        &d,
        "Latin-1 text array comment",
        &os(&[
            "lgen",
            "-i",
            "x",
            &corpus("odd", "latin1-txf.txt"),
            "-mm",
            "0",
            "1",
            "-o",
            "l.nrrd",
        ]),
        None,
        None,
    );
    let mut cam = b"# cam\xe9ra\n".to_vec();
    cam.extend_from_slice(&std::fs::read(d.join("cam.txt")).unwrap());
    std::fs::write(d.join("cam1.txt"), cam).unwrap();
    succeeds(
        &d,
        "Latin-1 @file comment",
        &os(&["go", "@cam1.txt", "-i", "cube.nrrd", "-o", "o.nrrd"]),
        None,
        None,
    );
}

// ---------------------------------------------------------------------------------------
// Bounded memory and time

/// Rule: inputs without end (`/dev/zero`, stdin of zeros, an @file of zeros) are
/// refused after a bounded read.
#[test]
fn endless_inputs_are_bounded() {
    let d = scene("zero");
    let z = Path::new("/dev/zero");
    refused(
        &d,
        "info /dev/zero",
        &os(&["info", "/dev/zero"]),
        None,
        Some(400),
        "NUL bytes",
    );
    refused(
        &d,
        "stdin of zeros",
        &os(&["info", "-"]),
        Some(z),
        Some(400),
        "NUL bytes",
    );
    refused(
        &d,
        "@/dev/zero",
        &os(&["go", "@/dev/zero"]),
        None,
        Some(400),
        "NUL bytes",
    );
    refused(
        &d,
        "mgo commands from /dev/zero",
        &os(&["mgo", "-i", "/dev/zero"]),
        None,
        Some(400),
        "NUL bytes",
    );
    refused(
        &d,
        "LUT from /dev/zero",
        &os(&go_args(&[
            "-p",
            "rgba",
            "-lut",
            "/dev/zero",
            "-o",
            "o.nrrd",
        ])),
        None,
        Some(400),
        "NUL bytes",
    );
}

/// Rule: a detached data file far larger than the volume, or one big file named many
/// times in a LIST, is read only as far as the volume needs.
#[test]
fn detached_data_is_read_only_as_needed() {
    let d = scene("detached");
    sparse(&d, "huge.raw", 4 << 30);
    std::fs::write(
        d.join("small.nhdr"),
        "NRRD0004\ntype: float\ndimension: 3\nsizes: 4 4 4\nendian: little\nencoding: raw\ndata file: huge.raw\n",
    )
    .unwrap();
    let list: String = std::iter::repeat_n("huge.raw\n", 1000).collect();
    std::fs::write(
        d.join("list.nhdr"),
        format!(
            "NRRD0004\ntype: float\ndimension: 3\nsizes: 4 4 1000\nendian: little\nencoding: raw\ndata file: LIST\n{list}"
        ),
    )
    .unwrap();
    succeeds(
        &d,
        "big data file",
        &os(&["info", "small.nhdr"]),
        None,
        Some(300),
    );
    succeeds(
        &d,
        "one big file listed 1000 times",
        &os(&["info", "list.nhdr"]),
        None,
        Some(300),
    );
}

/// Rule: @files that include each other, or fan out to huge expansions, are refused.
#[test]
fn response_file_expansion_is_bounded() {
    let d = scene("atfiles");
    std::fs::write(d.join("a.txt"), "@b.txt").unwrap();
    std::fs::write(d.join("b.txt"), "-k tent @a.txt").unwrap();
    refused(
        &d,
        "cycle",
        &os(&["go", "@a.txt"]),
        None,
        None,
        "includes itself",
    );
    for i in 0..7 {
        let next = format!("@f{} ", i + 1).repeat(10);
        std::fs::write(d.join(format!("f{i}")), next).unwrap();
    }
    std::fs::write(d.join("f7"), "-k tent").unwrap();
    refused(
        &d,
        "fan-out",
        &os(&["go", "@f0"]),
        None,
        None,
        "response files read in all",
    );
}

/// Rule: a compressed stream whose header claims more than this process may allocate
/// is refused before allocating; one that claims less but ends early costs what it
/// holds, not what it claims.
#[test]
fn compressed_claims_are_bounded() {
    let d = scene("bz");
    // bzip2 of 1000 zero bytes.
    let mut enc = bzip2::write::BzEncoder::new(Vec::new(), bzip2::Compression::default());
    std::io::Write::write_all(&mut enc, &[0u8; 1000]).unwrap();
    let stream = enc.finish().unwrap();
    for (sizes, frag) in [
        ("1000 1000 4000", "may use at most"),
        ("1000 1000 40", "data is truncated"),
    ] {
        let mut f = format!(
            "NRRD0004\ntype: float\ndimension: 3\nsizes: {sizes}\nendian: little\nencoding: bzip2\n\n"
        )
        .into_bytes();
        f.extend_from_slice(&stream);
        std::fs::write(d.join("bz.nrrd"), &f).unwrap();
        refused(
            &d,
            "bzip2 claim",
            &os(&["info", "bz.nrrd"]),
            None,
            Some(300),
            frag,
        );
        refused(
            &d,
            "bzip2 claim on stdin",
            &os(&["info", "-"]),
            Some(&d.join("bz.nrrd")),
            Some(300),
            frag,
        );
        std::fs::remove_file(d.join("bz.nrrd")).unwrap();
    }
}

/// Rule: an image larger than the process may allocate (here under `ulimit -v`) is a
/// clear error naming -sz, not an abort.
#[test]
fn image_memory_guard_respects_limits() {
    let d = scene("bigimg");
    refused(
        &d,
        "image beyond ulimit",
        &os(&[
            "go",
            "@cam.txt",
            "-i",
            "cube.nrrd",
            "-sz",
            "20000",
            "20000",
            "-o",
            "o.nrrd",
        ]),
        None,
        Some(1024),
        "may use at most",
    );
}

/// Rule: mgo keeps one volume in memory, so many volumes in turn cost one.
#[test]
fn mgo_keeps_one_volume() {
    let d = scene("mgo");
    let mut cmds = String::new();
    for i in 0..4 {
        sparse(&d, &format!("v{i}.raw"), 4 * 256 * 256 * 512);
        std::fs::write(
            d.join(format!("v{i}.nhdr")),
            format!("NRRD0004\ntype: float\ndimension: 3\nsizes: 256 256 512\nendian: little\nencoding: raw\ndata file: v{i}.raw\n"),
        )
        .unwrap();
        cmds.push_str(&format!(
            "rendr go -fr 600 1200 500 -at 128 128 256 -up 0 0 1 -nc -300 -fc 300 -fov 30 -sz 8 8 -i v{i}.nhdr -k tent -nt 1 -o o{i}.nrrd\n"
        ));
    }
    std::fs::write(d.join("cmds.txt"), cmds).unwrap();
    // Each volume is 128 MiB; four kept at once would pass 512 MiB.
    succeeds(
        &d,
        "four volumes in turn",
        &os(&["mgo", "-i", "cmds.txt"]),
        None,
        Some(480),
    );
    for i in 0..4 {
        assert!(d.join(format!("o{i}.nrrd")).exists());
    }
}

/// Rule: a light file with more lights than allowed is refused at once.
#[test]
fn too_many_lights_are_refused() {
    let d = scene("lights");
    let line = "1 1 1 0 0 1 1\n";
    std::fs::write(d.join("many.txt"), line.repeat(1_000_000)).unwrap();
    let r = run(
        &d,
        &os(&["lgen", "-i", "x", "x", "-mm", "0", "1", "-o", "lut.nrrd"]),
        None,
        None,
    );
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    refused(
        &d,
        "a million lights",
        &os(&go_args(&[
            "-p", "rgbalit", "-lut", "lut.nrrd", "-lit", "many.txt", "-o", "o.nrrd",
        ])),
        None,
        None,
        "at most 256 are allowed",
    );
}

// ---------------------------------------------------------------------------------------
// Hygiene

/// Rule: a 10 MB @file gives an output whose content line is capped, so rendr (and
/// Teem) read the output back.
#[test]
fn content_line_is_capped() {
    let d = scene("content");
    let mut big = std::fs::read_to_string(d.join("cam.txt")).unwrap();
    big.push_str(&"-fov 16 ".repeat(1_300_000));
    std::fs::write(d.join("big.txt"), big).unwrap();
    succeeds(
        &d,
        "10 MB @file",
        &os(&["go", "@big.txt", "-i", "cube.nrrd", "-o", "o.nrrd"]),
        None,
        None,
    );
    let r = succeeds(&d, "read back", &os(&["info", "o.nrrd"]), None, None);
    assert!(!r.stdout.is_empty());
    let head = std::fs::read(d.join("o.nrrd")).unwrap();
    let text = String::from_utf8_lossy(&head[..head.len().min(20_000)]).into_owned();
    let line = text.lines().find(|l| l.starts_with("content:")).unwrap();
    assert!(
        line.len() <= rnd_std::nrrd::CONTENT_MAX + 20,
        "{}",
        line.len()
    );
    assert!(line.ends_with(" ..."));
}

/// Rule: an OS error is printed once.
#[test]
fn os_errors_are_printed_once() {
    let d = scene("oserr");
    let r = run(&d, &os(&["info", "missing.nrrd"]), None, None);
    assert_eq!(r.code, Some(1));
    assert_eq!(
        r.stderr.matches("No such file or directory").count(),
        1,
        "{}",
        r.stderr
    );
}

/// Rule: skips are passed over without being kept: a byte skip of -1 reads the last
/// bytes of a regular file (attached or detached), skips in a regular data file far
/// larger than the volume cost nothing, and a stream refuses a byte skip beyond what
/// it passes over instead of reading on forever.
#[test]
fn skips_are_bounded_and_exact() {
    let d = scene("skips");
    let vals: Vec<u8> = (0..8u32)
        .flat_map(|i| (i as f32 + 0.5).to_le_bytes())
        .collect();
    let head = "NRRD0004\ntype: float\ndimension: 3\nsizes: 2 2 2\nendian: little\nencoding: raw\n";
    // Attached, byte skip -1, junk before the data.
    let mut f = format!("{head}byte skip: -1\n\n").into_bytes();
    f.extend_from_slice(b"junk junk junk");
    f.extend_from_slice(&vals);
    std::fs::write(d.join("end.nrrd"), &f).unwrap();
    // Detached: a sparse 3 GiB file whose last 32 bytes are the data, and one whose
    // data follow a 3 GiB byte skip.
    let big = sparse(&d, "big.raw", 3 << 30);
    {
        use std::io::{Seek, SeekFrom, Write};
        let mut w = std::fs::OpenOptions::new().write(true).open(&big).unwrap();
        w.seek(SeekFrom::End(-32)).unwrap();
        w.write_all(&vals).unwrap();
    }
    std::fs::write(
        d.join("end.nhdr"),
        format!("{head}byte skip: -1\ndata file: big.raw\n"),
    )
    .unwrap();
    std::fs::write(
        d.join("skip.nhdr"),
        format!(
            "{head}byte skip: {}\ndata file: big.raw\n",
            (3u64 << 30) - 32
        ),
    )
    .unwrap();
    for f in ["end.nrrd", "end.nhdr", "skip.nhdr"] {
        let r = succeeds(&d, "skips", &os(&["info", f]), None, Some(300));
        let out = String::from_utf8_lossy(&r.stdout).into_owned();
        assert!(out.contains("0.5") && out.contains("7.5"), "{f}: {out}");
    }
    // A stream: the skip is refused, not read through.
    let mut s = format!("{head}byte skip: 9223372036854775807\n\n").into_bytes();
    s.extend_from_slice(&vals);
    std::fs::write(d.join("stream.nrrd"), &s).unwrap();
    refused(
        &d,
        "byte skip beyond a stream's bound",
        &os(&["info", "-"]),
        Some(&d.join("stream.nrrd")),
        Some(300),
        "passes over in a stream",
    );
}

/// Rule: an empty file is named as empty (not "a text array with no numbers"), whether
/// it is read as a volume, a matrix, a transfer function or from standard input.
#[test]
fn empty_files_are_called_empty() {
    let d = scene("empty");
    std::fs::write(d.join("empty.nrrd"), b"").unwrap();
    let frag = "empty.nrrd: empty (0 bytes): neither a NRRD file nor a text array";
    refused(&d, "info", &os(&["info", "empty.nrrd"]), None, None, frag);
    refused(
        &d,
        "go",
        &os(&["go", "@cam.txt", "-i", "empty.nrrd", "-o", "o.nrrd"]),
        None,
        None,
        frag,
    );
    refused(&d, "4mi", &os(&["4mi", "empty.nrrd"]), None, None, frag);
    refused(
        &d,
        "teval",
        &os(&["teval", "empty.nrrd", "0.5"]),
        None,
        None,
        frag,
    );
    refused(
        &d,
        "4mi from stdin",
        &os(&["4mi", "-"]),
        Some(&d.join("empty.nrrd")),
        None,
        "empty (0 bytes)",
    );
}
