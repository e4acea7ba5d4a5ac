//! NIfTI and MetaImage volumes: files written by independent writers (nibabel,
//! SimpleITK; `tests/writers/write_volumes.py`) load with the writer's own values and
//! index-to-world affine, convert to NRRD that Teem reads, and render byte-identical
//! to the NRRD of the same array where the geometry is exact; bad files give one-line
//! errors.

use std::path::{Path, PathBuf};
use std::process::Command;

use rnd_std::formats::{self, Format};
use rnd_std::volume_io::{load_volume, Samples};

fn rendr(dir: &Path, args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_rendr"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("run rendr")
}

fn ok(dir: &Path, args: &[&str]) {
    let o = rendr(dir, args);
    assert!(
        o.status.success(),
        "rendr {args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// One line of the writers' manifest.
struct Case {
    name: String,
    file: PathBuf,
    sizes: [usize; 3],
    kind: String,
    affine: [f64; 12],
    values: Vec<f64>,
}

fn write_cases(test: &str) -> Option<(PathBuf, Vec<Case>)> {
    let py = rnd_tests::writers(test)?;
    let dir = rnd_tests::tmpdir(test);
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/writers/write_volumes.py");
    let o = Command::new(&py)
        .arg(&script)
        .arg(&dir)
        .output()
        .expect("run the writers");
    assert!(
        o.status.success(),
        "{}: {}",
        script.display(),
        String::from_utf8_lossy(&o.stderr)
    );
    let text = std::fs::read_to_string(dir.join("manifest.txt")).unwrap();
    let cases = text
        .lines()
        .map(|l| {
            let f: Vec<&str> = l.split('\t').collect();
            let nums = |s: &str| -> Vec<f64> {
                s.split_whitespace().map(|w| w.parse().unwrap()).collect()
            };
            let sz = nums(f[2]);
            let raw = std::fs::read(dir.join(format!("{}.f64", f[0]))).unwrap();
            Case {
                name: f[0].to_string(),
                file: dir.join(f[1]),
                sizes: [sz[0] as usize, sz[1] as usize, sz[2] as usize],
                kind: f[3].to_string(),
                affine: nums(f[4]).try_into().unwrap(),
                values: raw
                    .chunks_exact(8)
                    .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
                    .collect(),
            }
        })
        .collect();
    Some((dir, cases))
}

fn values(d: Samples<'_>) -> Vec<f64> {
    match d {
        Samples::F32(v) => v.iter().map(|&x| x as f64).collect(),
        Samples::I16(v) => v.iter().map(|&x| x as f64).collect(),
    }
}

#[test]
fn independent_writers_round_trip() {
    let Some((dir, cases)) = write_cases("independent_writers_round_trip") else {
        return;
    };
    assert!(cases.len() >= 19);
    let teem = rnd_tests::teem("independent_writers_round_trip", "teem-unu");
    for c in &cases {
        let v = load_volume(&c.file).unwrap_or_else(|e| panic!("{}: {e}", c.name));
        assert_eq!(v.sizes(), c.sizes, "{}", c.name);
        let want_type = if c.kind == "short" { "short" } else { "real" };
        assert_eq!(v.type_name(), want_type, "{}", c.name);
        assert_eq!(values(v.data()), c.values, "{}: values", c.name);
        for r in 0..3 {
            for col in 0..4 {
                let (got, want) = (v.itow().m[4 * r + col], c.affine[4 * r + col]);
                assert!(
                    (got - want).abs() <= 1e-6 * want.abs().max(1.0),
                    "{}: itow[{r}][{col}] = {got}, the writer says {want}",
                    c.name
                );
            }
        }
        let (format, frame) = if c.name.starts_with("dcm") {
            (Format::Dicom, "left-posterior-superior")
        } else if c.name.starts_with("nii2") {
            (Format::Nifti2, "right-anterior-superior")
        } else if c.name.starts_with("nii") {
            (Format::Nifti1, "right-anterior-superior")
        } else {
            (Format::MetaImage, "left-posterior-superior")
        };
        assert_eq!(v.format, format, "{}", c.name);
        assert_eq!(v.space.as_deref(), Some(frame), "{}", c.name);

        // convert: a NRRD with the same samples (in the type read) and geometry.
        let out = dir.join(format!("{}.nrrd", c.name));
        ok(
            &dir,
            &["convert", c.file.to_str().unwrap(), out.to_str().unwrap()],
        );
        let read = formats::read(&c.file, 1).unwrap();
        let back = rnd_std::nrrd::read(&out).unwrap();
        assert_eq!(back.data, read.nrrd.data, "{}: converted samples", c.name);
        assert_eq!(
            back.header.key("rendr source format"),
            Some(format.name()),
            "{}",
            c.name
        );
        let again = load_volume(&out).unwrap();
        assert_eq!(
            (again.itow(), again.data()),
            (v.itow(), v.data()),
            "{}",
            c.name
        );
        if teem {
            // Teem reads the geometry the same way.
            let head = rnd_tests::run("teem-unu", &["head", out.to_str().unwrap()]);
            assert!(head.contains(&format!("space: {frame}")), "{head}");
        }
    }
}

#[test]
fn bad_dicom_series_are_refused_clearly() {
    let Some((dir, _)) = write_cases("bad_dicom_series_are_refused_clearly") else {
        return;
    };
    for (sub, frag) in [
        ("two-series", "holds 2 DICOM series"),
        ("missing-slice", "uneven slice spacing"),
        ("jpeg2000", "JPEG 2000"),
    ] {
        let o = rendr(&dir, &["info", &format!("bad/{sub}")]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{sub}: {err}");
        assert!(err.contains(frag), "{sub}: {err:?} lacks {frag:?}");
        assert_eq!(err.trim().lines().count(), 1, "{sub}: {err}");
    }
    // A lying element length is refused before anything is allocated for it.
    let src = dir.join("dcm-oblique");
    let first = std::fs::read_dir(&src)
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    let mut bytes = std::fs::read(&first).unwrap();
    let at = bytes
        .windows(6)
        .position(|w| w == [0xE0, 0x7F, 0x10, 0x00, b'O', b'W'])
        .expect("pixel data element");
    bytes[at + 8..at + 12].copy_from_slice(&0xFFFF_FF00u32.to_le_bytes());
    let lying = dir.join("bad/lying");
    std::fs::create_dir_all(&lying).unwrap();
    std::fs::write(lying.join("slice"), &bytes).unwrap();
    let o = rendr(&dir, &["info", "bad/lying"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("(7FE0,0010) claims 4294967040 bytes"), "{err}");
    // Sequences nested 10,000 deep before the pixel data (200 kB: the parser, which
    // builds them by recursion, overflowed the stack and aborted) are refused.
    let mut bytes = std::fs::read(&first).unwrap();
    let level = [
        &[9, 0, 0x10, 0x10, b'S', b'Q', 0, 0, 0xFF, 0xFF, 0xFF, 0xFF][..],
        &[0xFE, 0xFF, 0x00, 0xE0, 0xFF, 0xFF, 0xFF, 0xFF],
    ]
    .concat();
    let close = [
        &[0xFE, 0xFF, 0x0D, 0xE0, 0, 0, 0, 0][..],
        &[0xFE, 0xFF, 0xDD, 0xE0, 0, 0, 0, 0],
    ]
    .concat();
    let nested = [level.repeat(10_000), close.repeat(10_000)].concat();
    bytes.splice(at..at, nested);
    let deep = dir.join("bad/deep");
    std::fs::create_dir_all(&deep).unwrap();
    std::fs::write(deep.join("slice"), &bytes).unwrap();
    let o = rendr(&dir, &["info", "bad/deep"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("sequences nest more than 128 deep"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    // One file of a folder with two series picks its own series.
    let d = dir.join("bad/two-series");
    let mut names: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    names.sort();
    let v = load_volume(&names[0]).unwrap();
    assert_eq!(v.sizes(), [7, 6, 5]);
    // A series beside reports (no pixels; one in the series) and an undecodable slice
    // of another series: one of its files reads it, and they are not counted as series.
    let d = dir.join("bad/with-others");
    let slice = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.file_name().unwrap().len() == 8)
        .unwrap();
    let v = load_volume(&slice).unwrap();
    assert_eq!(v.sizes(), [7, 6, 5]);
    let o = rendr(&dir, &["info", slice.to_str().unwrap()]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("DICOM series of 5 slices (5 files;"), "{out}");
    // A bare file name: its folder is the current directory.
    let name = slice.file_name().unwrap().to_str().unwrap();
    let o = rendr(&d, &["info", name]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("DICOM series of 5 slices (5 files;"), "{out}");
    let o = rendr(&dir, &["info", "bad/with-others"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("holds 2 DICOM series"), "{err}");
    let o = rendr(&dir, &["info", "bad/with-others/report-own"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("no Rows: not an image"), "{err}");
}

/// The NRRD rendr writes for a case's array and affine, in the format's frame.
fn nrrd_of(c: &Case, frame: &str, path: &Path) {
    let data = rnd_std::nrrd::Data::I16(c.values.iter().map(|&x| x as i16).collect());
    let mut n = rnd_std::nrrd::Nrrd::new(c.sizes.to_vec(), data).unwrap();
    let a = &c.affine;
    n.header.space = Some(frame.into());
    n.header.space_directions = Some(
        (0..3)
            .map(|col| Some(vec![a[col], a[4 + col], a[8 + col]]))
            .collect(),
    );
    n.header.space_origin = Some(vec![a[3], a[7], a[11]]);
    n.header.centerings = Some(vec![rnd_std::nrrd::Centering::Cell; 3]);
    rnd_std::nrrd::write(&n, path, Default::default()).unwrap();
}

#[test]
fn exact_geometry_renders_like_the_nrrd() {
    let Some((dir, cases)) = write_cases("exact_geometry_renders_like_the_nrrd") else {
        return;
    };
    for (name, frame) in [
        ("nii-aligned", "right-anterior-superior"),
        ("mha-aligned", "left-posterior-superior"),
        ("dcm-aligned", "left-posterior-superior"),
    ] {
        let c = cases.iter().find(|c| c.name == name).unwrap();
        let nrrd = dir.join(format!("{name}-ref.nrrd"));
        nrrd_of(c, frame, &nrrd);
        for (probe, blend) in [("v", "max"), ("gv", "mean"), ("gm", "sum")] {
            let mut outs = Vec::new();
            for (i, input) in [&c.file, &nrrd].iter().enumerate() {
                let out = dir.join(format!("{name}-{probe}-{i}.nrrd"));
                ok(
                    &dir,
                    &[
                        "go",
                        "-i",
                        input.to_str().unwrap(),
                        "-fr",
                        "11.5",
                        "20.6",
                        "6",
                        "-at",
                        "-6.5",
                        "-3.4",
                        "6",
                        "-up",
                        "0",
                        "0",
                        "1",
                        "-nc",
                        "-8",
                        "-fc",
                        "8",
                        "-fov",
                        "22",
                        "-sz",
                        "16",
                        "48",
                        "-k",
                        "ctmr",
                        "-p",
                        probe,
                        "-b",
                        blend,
                        "-s",
                        "0.05",
                        "-o",
                        out.to_str().unwrap(),
                    ],
                );
                outs.push(rnd_std::nrrd::read(&out).unwrap().data.to_f64());
            }
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(
                bits(&outs[0]),
                bits(&outs[1]),
                "{name} -p {probe}: images differ"
            );
            let hits = outs[0].iter().filter(|&&x| x != 0.0).count();
            assert!(
                hits > outs[0].len() / 10,
                "{name} -p {probe}: {hits} pixels hit the volume"
            );
        }
    }
}

/// A little-endian NIfTI-1 single file: a 2x3x4 short volume with an sform.
fn nifti1(dims: [i16; 4], datatype: i16, bitpix: i16, vox_offset: f32, nbytes: usize) -> Vec<u8> {
    let mut b = vec![0u8; 352];
    b[..4].copy_from_slice(&348i32.to_le_bytes());
    for (i, d) in dims.iter().enumerate() {
        b[40 + 2 * i..42 + 2 * i].copy_from_slice(&d.to_le_bytes());
    }
    b[70..72].copy_from_slice(&datatype.to_le_bytes());
    b[72..74].copy_from_slice(&bitpix.to_le_bytes());
    for i in 0..4 {
        b[76 + 4 * i..80 + 4 * i].copy_from_slice(&1f32.to_le_bytes());
    }
    b[108..112].copy_from_slice(&vox_offset.to_le_bytes());
    b[254..256].copy_from_slice(&1i16.to_le_bytes());
    for (r, o) in [280usize, 296, 312].iter().enumerate() {
        b[o + 4 * r..o + 4 * r + 4].copy_from_slice(&2f32.to_le_bytes());
    }
    b[344..348].copy_from_slice(b"n+1\0");
    b.extend((0..nbytes).map(|i| i as u8));
    b
}

#[test]
fn hand_made_nifti_reads_and_bad_files_fail_clearly() {
    let dir = rnd_tests::tmpdir("nifti-bad");
    std::fs::write(dir.join("good.nii"), nifti1([3, 2, 3, 4], 4, 16, 352.0, 48)).unwrap();
    let v = load_volume(&dir.join("good.nii")).unwrap();
    assert_eq!(v.sizes(), [2, 3, 4]);
    assert_eq!(v.itow().m[0], 2.0);
    match v.data() {
        Samples::I16(d) => assert_eq!(d[1], i16::from_le_bytes([2, 3])),
        _ => panic!("short expected"),
    }
    // From stdin, too (recognised by the same peek, nothing read twice).
    let mut child = Command::new(env!("CARGO_BIN_EXE_rendr"))
        .args(["info", "-"])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let bytes = std::fs::read(dir.join("good.nii")).unwrap();
    std::io::Write::write_all(&mut child.stdin.take().unwrap(), &bytes).unwrap();
    let o = child.wait_with_output().unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success() && text.contains("read as NIfTI-1"),
        "{text}"
    );
    assert!(text.contains("2 by 3 by 4 volume"), "{text}");
    let bad: [(&str, Vec<u8>, &str); 7] = [
        (
            "trunc.nii",
            nifti1([3, 2, 3, 4], 4, 16, 352.0, 47),
            "truncated",
        ),
        (
            "huge.nii",
            nifti1([3, 32767, 32767, 32767], 16, 32, 352.0, 8),
            "memory",
        ),
        (
            "bitpix.nii",
            nifti1([3, 2, 3, 4], 4, 8, 352.0, 48),
            "bitpix",
        ),
        (
            "rgb.nii",
            nifti1([3, 2, 3, 4], 128, 24, 352.0, 72),
            "colour",
        ),
        ("2d.nii", nifti1([2, 2, 3, 1], 4, 16, 352.0, 12), "axes"),
        (
            "negative.nii",
            nifti1([3, 2, -3, 4], 4, 16, 352.0, 48),
            "positive",
        ),
        (
            "offset.nii",
            nifti1([3, 2, 3, 4], 4, 16, 100.0, 48),
            "vox_offset",
        ),
    ];
    for (name, bytes, frag) in bad {
        std::fs::write(dir.join(name), bytes).unwrap();
        let o = rendr(&dir, &["info", name]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{name}: {err}");
        assert!(
            err.contains(name) && err.contains(frag),
            "{name}: {err:?} lacks {frag:?}"
        );
        assert_eq!(err.trim().lines().count(), 1, "{name}: {err}");
    }
    // A gzip stream that is not NIfTI, a MetaImage whose data file is missing.
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    std::io::Write::write_all(&mut gz, b"hello, not a volume").unwrap();
    std::fs::write(dir.join("x.gz"), gz.finish().unwrap()).unwrap();
    std::fs::write(
        dir.join("m.mhd"),
        "NDims = 3\nDimSize = 2 2 2\nElementType = MET_SHORT\nElementDataFile = m.raw\n",
    )
    .unwrap();
    for (name, frag) in [("x.gz", "gzip"), ("m.mhd", "m.raw")] {
        let o = rendr(&dir, &["info", name]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{name}: {err}");
        assert!(err.contains(frag), "{name}: {err:?} lacks {frag:?}");
    }
    // convert never clobbers its input's data file.
    std::fs::write(dir.join("m.raw"), [0u8; 16]).unwrap();
    let o = rendr(&dir, &["convert", "m.mhd", "m.raw"]);
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(std::fs::read(dir.join("m.raw")).unwrap(), [0u8; 16]);
}
