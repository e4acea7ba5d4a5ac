//! NRRD and text IO: round trips of every type × encoding × endian, geometry, and
//! interop with Teem's `unu` in both directions.

use std::path::Path;
use std::process::Command;

use proptest::prelude::*;
use rnd_std::nrrd::{self, Centering, Data, Encoding, Endian, Nrrd, ScalarType, WriteOptions};

fn data_of(t: ScalarType, raw: &[u64]) -> Data {
    let f = |i: usize| raw[i];
    let n = raw.len();
    match t {
        ScalarType::I8 => Data::I8((0..n).map(|i| f(i) as i8).collect()),
        ScalarType::U8 => Data::U8((0..n).map(|i| f(i) as u8).collect()),
        ScalarType::I16 => Data::I16((0..n).map(|i| f(i) as i16).collect()),
        ScalarType::U16 => Data::U16((0..n).map(|i| f(i) as u16).collect()),
        ScalarType::I32 => Data::I32((0..n).map(|i| f(i) as i32).collect()),
        ScalarType::U32 => Data::U32((0..n).map(|i| f(i) as u32).collect()),
        // 64-bit integers stay within 2^53 so the ascii encoding is exact too.
        ScalarType::I64 => Data::I64((0..n).map(|i| (f(i) >> 11) as i64 - (1 << 52)).collect()),
        ScalarType::U64 => Data::U64((0..n).map(|i| f(i) >> 11).collect()),
        ScalarType::F32 => Data::F32(
            (0..n)
                .map(|i| f32::from_bits(f(i) as u32 & 0x7f7f_ffff))
                .collect(),
        ),
        ScalarType::F64 => Data::F64(
            (0..n)
                .map(|i| f64::from_bits(f(i) & 0x7fef_ffff_ffff_ffff))
                .collect(),
        ),
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, .. ProptestConfig::default() })]

    #[test]
    fn round_trip_every_type_encoding_endian(
        ti in 0usize..10,
        ei in 0usize..5,
        big in any::<bool>(),
        sizes in prop::collection::vec(1usize..5, 1..4),
        seed in prop::collection::vec(any::<u64>(), 64),
    ) {
        let t = ScalarType::ALL[ti];
        let enc = Encoding::ALL[ei];
        let n: usize = sizes.iter().product();
        let raw: Vec<u64> = (0..n).map(|i| seed[i % 64].rotate_left(i as u32)).collect();
        let mut a = Nrrd::new(sizes.clone(), data_of(t, &raw)).unwrap();
        a.header.content = Some("round trip".into());
        let opt = WriteOptions { encoding: enc, endian: if big { Endian::Big } else { Endian::Little } };
        let mut bytes = Vec::new();
        nrrd::write_to(&a, opt, &mut bytes).unwrap();
        let b = nrrd::read_bytes(&bytes, Path::new(".")).unwrap();
        prop_assert_eq!(b.sizes(), a.sizes());
        prop_assert_eq!(b.header.scalar, t);
        prop_assert_eq!(b.header.content.as_deref(), Some("round trip"));
        // Bit-exact: compare through the bit patterns for floats.
        match (&a.data, &b.data) {
            (Data::F32(x), Data::F32(y)) => prop_assert!(x.iter().zip(y).all(|(p, q)| p.to_bits() == q.to_bits())),
            (Data::F64(x), Data::F64(y)) => prop_assert!(x.iter().zip(y).all(|(p, q)| p.to_bits() == q.to_bits())),
            (x, y) => prop_assert_eq!(x, y),
        }
    }

    #[test]
    fn geometry_round_trip(
        dirs in prop::array::uniform9(-10.0f64..10.0),
        origin in prop::array::uniform3(-100.0f64..100.0),
        mins in prop::array::uniform3(-5.0f64..5.0),
    ) {
        let mut a = Nrrd::new(vec![2, 3, 4], Data::F32(vec![0.5; 24])).unwrap();
        let h = &mut a.header;
        h.space = Some("left-posterior-superior".into());
        h.space_directions = Some(vec![Some(dirs[0..3].to_vec()), Some(dirs[3..6].to_vec()), Some(dirs[6..9].to_vec())]);
        h.space_origin = Some(origin.to_vec());
        h.axis_mins = Some(mins.to_vec());
        h.centerings = Some(vec![Centering::Cell, Centering::Node, Centering::Unknown]);
        h.kinds = Some(vec!["domain".into(), "domain".into(), "space".into()]);
        h.key_values = vec![("space".into(), "rgb".into())];
        let mut bytes = Vec::new();
        nrrd::write_to(&a, WriteOptions::default(), &mut bytes).unwrap();
        let b = nrrd::read_bytes(&bytes, Path::new(".")).unwrap();
        prop_assert_eq!(&b.header.space_directions, &a.header.space_directions);
        prop_assert_eq!(&b.header.space_origin, &a.header.space_origin);
        prop_assert_eq!(&b.header.axis_mins, &a.header.axis_mins);
        prop_assert_eq!(&b.header.centerings, &a.header.centerings);
        prop_assert_eq!(&b.header.kinds, &a.header.kinds);
        prop_assert_eq!(b.header.key("space"), Some("rgb"));
        prop_assert_eq!(b.header.space.as_deref(), Some("left-posterior-superior"));
    }
}

#[test]
fn text_arrays() {
    let n = nrrd::parse_text("#space:=alpha\n# comment\n0 0  # trailing\n\n1 1\n").unwrap();
    assert_eq!(n.sizes(), &[2, 2]);
    assert_eq!(n.header.key("space"), Some("alpha"));
    assert_eq!(n.data.to_f64(), vec![0.0, 0.0, 1.0, 1.0]);
    let e = nrrd::parse_text("1 2 3\n4 5\n").unwrap_err();
    assert!(e.msg.contains("ragged"), "{e}");
    assert!(nrrd::parse_text("# only comments\n").is_err());
    assert!(nrrd::parse_text("1 x 3\n")
        .unwrap_err()
        .msg
        .contains("can't parse \"x\""));
}

fn unu(args: &[&str]) -> String {
    rnd_tests::run("teem-unu", args)
}

fn unu_text_values(file: &Path) -> Vec<f64> {
    // `unu save -f text` needs 1-D or 2-D data: flatten with `unu reshape` first.
    let n: usize = rnd_std::nrrd::read(file).unwrap().data.len();
    let cmd = format!(
        "teem-unu reshape -i '{}' -s {n} | teem-unu save -f text -o -",
        file.display()
    );
    let out = Command::new("sh").args(["-c", &cmd]).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter(|l| !l.starts_with('#'))
        .flat_map(|l| {
            l.split_whitespace()
                .map(|w| w.parse::<f64>().unwrap())
                .collect::<Vec<_>>()
        })
        .collect()
}

#[test]
fn teem_reads_what_rendr_writes() {
    if !rnd_tests::teem("teem_reads_what_rendr_writes", "teem-unu") {
        return;
    }
    let d = rnd_tests::tmpdir("teem-reads");
    let vals: Vec<f32> = (0..24).map(|i| i as f32 * 0.37 - 3.0).collect();
    for enc in Encoding::ALL {
        for (t, data) in [
            (ScalarType::F32, Data::F32(vals.clone())),
            (
                ScalarType::I16,
                Data::I16(vals.iter().map(|&v| (v * 100.0) as i16).collect()),
            ),
            (
                ScalarType::F64,
                Data::F64(vals.iter().map(|&v| v as f64 / 3.0).collect()),
            ),
            (ScalarType::U8, Data::U8((0..24).collect())),
        ] {
            let mut n = Nrrd::new(vec![2, 3, 4], data).unwrap();
            n.header.space = Some("left-posterior-superior".into());
            n.header.space_directions = Some(vec![
                Some(vec![0.5, 0., 0.]),
                Some(vec![0., 2., 0.]),
                Some(vec![0., 0., 1.]),
            ]);
            n.header.space_origin = Some(vec![1.0, 2.0, 3.0]);
            n.header.centerings = Some(vec![Centering::Cell; 3]);
            for endian in [Endian::Little, Endian::Big] {
                let p = d.join(format!("a-{}-{t:?}-{endian:?}.nrrd", enc.as_str()));
                nrrd::write(
                    &n,
                    &p,
                    WriteOptions {
                        encoding: enc,
                        endian,
                    },
                )
                .unwrap();
                let head = unu(&["head", p.to_str().unwrap()]);
                assert!(head.contains("sizes: 2 3 4"), "{head}");
                let got = unu_text_values(&p);
                let want = n.data.to_f64();
                assert_eq!(got.len(), want.len());
                for (g, w) in got.iter().zip(&want) {
                    assert!(
                        (g - w).abs() <= 1e-6 * (1.0 + w.abs()),
                        "{p:?}: {got:?} vs {want:?}"
                    );
                }
            }
        }
    }
}

#[test]
fn rendr_reads_what_teem_writes() {
    if !rnd_tests::teem("rendr_reads_what_teem_writes", "teem-unu") {
        return;
    }
    let d = rnd_tests::tmpdir("rendr-reads");
    // A float volume written by unu from text, then re-encoded every way unu can.
    let txt = d.join("v.txt");
    let vals: Vec<f64> = (0..60).map(|i| (i as f64 * 0.731).sin() * 100.0).collect();
    let lines: Vec<String> = vals
        .chunks(5)
        .map(|c| {
            c.iter()
                .map(|x| format!("{x}"))
                .collect::<Vec<_>>()
                .join(" ")
        })
        .collect();
    std::fs::write(&txt, lines.join("\n") + "\n").unwrap();
    let base = d.join("base.nrrd");
    unu(&[
        "reshape",
        "-i",
        txt.to_str().unwrap(),
        "-s",
        "5",
        "3",
        "4",
        "-o",
        base.to_str().unwrap(),
    ]);
    let want = nrrd::read(&base).unwrap().data.to_f64();
    assert_eq!(want.len(), 60);
    for (args, name) in [
        (vec!["-e", "raw"], "raw.nrrd"),
        (vec!["-e", "gzip"], "gz.nrrd"),
        (vec!["-e", "bzip2"], "bz.nrrd"),
        (vec!["-e", "ascii"], "ascii.nrrd"),
        (vec!["-e", "hex"], "hex.nrrd"),
        (vec!["-e", "raw", "-en", "big"], "big.nrrd"),
        (vec!["-e", "gzip", "-en", "big"], "biggz.nrrd"),
        (vec!["-e", "raw"], "detached.nhdr"),
    ] {
        let out = d.join(name);
        let mut a = vec![
            "save",
            "-f",
            "nrrd",
            "-i",
            base.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ];
        a.extend(args.iter());
        unu(&a);
        let got = nrrd::read(&out).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(got.sizes(), &[5, 3, 4], "{name}");
        let g = got.data.to_f64();
        for (x, y) in g.iter().zip(&want) {
            assert!(
                (x - y).abs() <= 1e-6 * (1.0 + y.abs()),
                "{name}: {x} vs {y}"
            );
        }
    }
    // Other types converted by unu.
    for t in ["short", "uchar", "int", "double", "ushort"] {
        let out = d.join(format!("t-{t}.nrrd"));
        unu(&[
            "convert",
            "-t",
            t,
            "-i",
            base.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ]);
        let got = nrrd::read(&out).unwrap_or_else(|e| panic!("{t}: {e}"));
        assert_eq!(got.data.len(), 60);
        let v = rnd_std::volume_io::volume_from_nrrd(got).unwrap();
        assert_eq!(v.sizes(), [5, 3, 4]);
        assert!(
            v.notes.iter().any(|n| n.contains("spacing")),
            "{t}: {:?}",
            v.notes
        );
    }
}

/// Large raw data read with several threads (each filling its own part) equals the
/// one-thread read, for every type and both byte orders, also after byte and line
/// skips and with sample counts that do not split evenly.
#[test]
fn threaded_raw_read_equals_one_thread() {
    let dir = std::env::temp_dir().join(format!("rendr-par-read-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let n = (5 << 20) / 8 + 3; // over 4 MiB for the widest types
    for (ti, &t) in ScalarType::ALL.iter().enumerate() {
        let size = t.size();
        // Enough samples that the data exceeds the threaded-read threshold (4 MiB).
        let n = n * 8 / size + ti;
        let raw: Vec<u64> = (0..n as u64)
            .map(|i| i.wrapping_mul(0x9e37_79b9_7f4a_7c15))
            .collect();
        for big in [false, true] {
            let a = Nrrd::new(vec![n], data_of(t, &raw)).unwrap();
            let opt = WriteOptions {
                encoding: Encoding::Raw,
                endian: if big { Endian::Big } else { Endian::Little },
            };
            let mut bytes = Vec::new();
            nrrd::write_to(&a, opt, &mut bytes).unwrap();
            // The same data after a line skip and a byte skip.
            let cut = bytes.windows(2).position(|w| w == b"\n\n").unwrap() + 1;
            let mut skipped = bytes[..cut].to_vec();
            skipped.extend_from_slice(b"line skip: 1\nbyte skip: 3\n\nfirst line\nxyz");
            skipped.extend_from_slice(&bytes[cut + 1..]);
            for (name, b) in [("plain", &bytes), ("skips", &skipped)] {
                let p = dir.join(format!("{t}-{big}-{name}.nrrd"));
                std::fs::write(&p, b).unwrap();
                let one = nrrd::read(&p).unwrap();
                for threads in [2, 3, 7] {
                    let many = nrrd::read_with_threads(&p, threads).unwrap();
                    assert_eq!(many.sizes(), one.sizes());
                    assert!(
                        many.data
                            .iter_f64()
                            .map(f64::to_bits)
                            .eq(one.data.iter_f64().map(f64::to_bits)),
                        "{t} big={big} {name} threads={threads}"
                    );
                }
                assert!(one
                    .data
                    .iter_f64()
                    .map(f64::to_bits)
                    .eq(a.data.iter_f64().map(f64::to_bits)));
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `bytes` (a NRRD with attached data) with a comment line after the magic that puts
/// the data's offset at `r` modulo 8.
fn data_at(bytes: &[u8], r: usize) -> Vec<u8> {
    let off = bytes.windows(2).position(|w| w == b"\n\n").unwrap() + 2;
    // A comment line "#" + k spaces + "\n" adds k + 2 bytes.
    let k = (r + 16 - (off + 2) % 8) % 8;
    let mut out = b"NRRD0004\n#".to_vec();
    out.extend(std::iter::repeat_n(b' ', k));
    out.push(b'\n');
    out.extend_from_slice(&bytes[9..]);
    assert_eq!(
        (out.windows(2).position(|w| w == b"\n\n").unwrap() + 2) % 8,
        r
    );
    out
}

/// Volumes used in place from a map of the file equal the ones read into memory (same
/// samples, sizes, geometry, notes and type), for float and short data at aligned
/// offsets, attached, detached and after a byte skip; everything else (unaligned data,
/// the other byte order, gzip, other types) is read, and a file too short for its sizes
/// gives the same error either way.
#[test]
fn mapped_volumes_equal_read_ones() {
    fn parts(
        v: &rnd_std::volume_io::VolumeBuf,
    ) -> (
        rnd_std::volume_io::Samples<'_>,
        [usize; 3],
        rnd_core::affine::Affine4,
    ) {
        (v.data(), v.sizes(), v.itow())
    }
    use rnd_core::affine::Affine4;
    use rnd_std::volume_io::{load_volume_mapped, load_volume_threads, VolumeBuf, VolumeData};
    let dir = rnd_tests::tmpdir("mapped");
    let sizes = [5, 6, 7];
    let itow = Affine4::from_columns(
        [0.5, 0.0, 0.0],
        [0.0, 2.0, 0.0],
        [0.0, 0.1, 1.0],
        [1.0, 2.0, 3.0],
    );
    let f: Vec<f32> = (0..210).map(|i| (i as f32 * 0.37).sin() * 100.0).collect();
    let s: Vec<i16> = (0..210).map(|i| (i * 311 % 65536 - 32768) as i16).collect();
    let le = WriteOptions {
        encoding: Encoding::Raw,
        endian: Endian::Little,
    };
    for data in [VolumeData::F32(f), VolumeData::I16(s)] {
        let size = if matches!(data, VolumeData::F32(_)) {
            4
        } else {
            2
        };
        let vb = VolumeBuf::new(data, sizes, itow).unwrap();
        let n = nrrd::volume_nrrd(&vb).unwrap();
        let file = |name: &str, bytes: &[u8]| {
            let p = dir.join(format!("{size}-{name}"));
            std::fs::write(&p, bytes).unwrap();
            p
        };
        let bytes_with = |opt: WriteOptions| {
            let mut b = Vec::new();
            nrrd::write_to(&n, opt, &mut b).unwrap();
            b
        };
        let raw = bytes_with(le);
        let mut cases = vec![
            (file("aligned.nrrd", &data_at(&raw, 0)), true),
            (file("half.nrrd", &data_at(&raw, 2)), size == 2),
            (file("odd.nrrd", &data_at(&raw, 3)), false),
            (
                file(
                    "big.nrrd",
                    &data_at(
                        &bytes_with(WriteOptions {
                            endian: Endian::Big,
                            ..le
                        }),
                        0,
                    ),
                ),
                false,
            ),
            (
                file(
                    "gzip.nrrd",
                    &data_at(
                        &bytes_with(WriteOptions {
                            encoding: Encoding::Gzip,
                            ..le
                        }),
                        0,
                    ),
                ),
                false,
            ),
        ];
        // A byte skip line (13 bytes) and 5 skipped bytes after a header whose data would
        // start at 6 mod 8: the data at 0 mod 8.
        let base = data_at(&raw, 6);
        let cut = base.windows(2).position(|w| w == b"\n\n").unwrap() + 1;
        let mut skipped = base[..cut].to_vec();
        skipped.extend_from_slice(b"byte skip: 5\n\n12345");
        skipped.extend_from_slice(&base[cut + 1..]);
        cases.push((file("skip.nrrd", &skipped), true));
        // Detached: data from offset 0 of its own file.
        let head_end = raw.windows(2).position(|w| w == b"\n\n").unwrap() + 1;
        let name = format!("{size}-det.raw");
        let mut head = raw[..head_end].to_vec();
        head.extend_from_slice(format!("data file: {name}\n").as_bytes());
        std::fs::write(dir.join(&name), &raw[head_end + 1..]).unwrap();
        cases.push((file("det.nhdr", &head), true));
        for (p, mapped) in &cases {
            let read = load_volume_threads(p, 1).unwrap();
            let m = load_volume_mapped(p, 1).unwrap();
            assert!(!read.is_mapped());
            assert_eq!(m.is_mapped(), *mapped, "{}", p.display());
            assert_eq!(m, read, "{}", p.display());
            assert_eq!(parts(&m), parts(&vb), "{}", p.display());
            assert_eq!(
                (&m.notes, &m.file_type, &m.space),
                (&read.notes, &read.file_type, &read.space)
            );
            // A clone keeps the map after the original goes.
            let c = m.clone();
            drop(m);
            assert_eq!(parts(&c), parts(&vb));
        }
        // Too short for its sizes: the same error, mapped or read.
        let short = data_at(&raw, 0);
        let p = file("short.nrrd", &short[..short.len() - 3]);
        let (a, b) = (
            load_volume_threads(&p, 1).unwrap_err(),
            load_volume_mapped(&p, 1).unwrap_err(),
        );
        assert_eq!(a.to_string(), b.to_string());
        assert!(a.to_string().contains("truncated"), "{a}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The header's fields are public, so a caller can make it disagree with the data:
/// such an array is refused (a Format error naming the field) before a byte is written,
/// as NRRD or as text (where a first axis of 0 would otherwise never end a row), and a
/// file is left unwritten.
#[test]
fn headers_that_disagree_with_the_data_are_not_written() {
    let good = || {
        let mut n = Nrrd::new(vec![2, 3], Data::F32(vec![0.5; 6])).unwrap();
        n.header.space = Some("3D-right-handed".into());
        n.header.space_directions = Some(vec![Some(vec![1.0, 0.0, 0.0]), None]);
        n.header.space_origin = Some(vec![0.0; 3]);
        n.header.spacings = Some(vec![f64::NAN, 1.0]);
        n.header.labels = Some(vec!["x".into(), "y".into()]);
        n
    };
    let mut out = Vec::new();
    nrrd::write_to(&good(), WriteOptions::default(), &mut out).unwrap();
    let back = nrrd::read_bytes(&out, Path::new("/nonexistent")).unwrap();
    assert_eq!(back.sizes(), &[2, 3]);
    type Edit = fn(&mut Nrrd);
    let edits: &[(Edit, &str)] = &[
        (|n| n.header.scalar = ScalarType::F64, "type double"),
        (|n| n.header.sizes = vec![3, 3], "sizes [3, 3]"),
        (|n| n.header.sizes = vec![], "sizes []"),
        (|n| n.header.sizes = vec![0, 6], "sizes [0, 6]"),
        (|n| n.header.sizes = vec![1; 17], "sizes [1, 1"),
        (|n| n.header.sizes = vec![usize::MAX, 2], "sizes ["),
        (
            |n| n.header.labels = Some(vec!["x".into()]),
            "labels: 1 entries",
        ),
        (
            |n| n.header.spacings = Some(vec![1.0; 3]),
            "spacings: 3 entries",
        ),
        (
            |n| n.header.space_origin = Some(vec![0.0; 2]),
            "space origin: 2 values",
        ),
        (
            |n| n.header.space_directions = Some(vec![None, Some(vec![1.0; 4])]),
            "space directions: 4 values",
        ),
    ];
    let dir = std::env::temp_dir().join(format!("rnd-nrrd-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (edit, what) in edits {
        let mut n = good();
        edit(&mut n);
        let mut out = Vec::new();
        let e = nrrd::write_to(&n, WriteOptions::default(), &mut out).unwrap_err();
        assert_eq!(e.kind, rnd_std::ErrorKind::Format, "{e}");
        assert!(e.to_string().contains(what), "{what}: {e}");
        assert!(out.is_empty());
        assert!(
            nrrd::write_text(&n, &mut out).is_err() && out.is_empty(),
            "{what}"
        );
        let path = dir.join("x.nrrd");
        assert!(nrrd::write(&n, &path, WriteOptions::default()).is_err());
        assert!(!path.exists());
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A volume made from an array whose header disagrees with its data (made by hand) is a
/// Format error, not a panic on a short per-axis field.
#[test]
fn volumes_from_disagreeing_headers_are_errors() {
    let n = || Nrrd::new(vec![2, 2, 2], Data::F32(vec![1.0; 8])).unwrap();
    assert!(rnd_std::volume_io::volume_from_nrrd(n()).is_ok());
    type Edit = fn(&mut Nrrd);
    let edits: &[Edit] = &[
        |n| n.header.space_directions = Some(vec![Some(vec![1.0, 0.0, 0.0])]),
        |n| n.header.spacings = Some(vec![1.0]),
        |n| n.header.axis_mins = Some(vec![0.0; 2]),
        |n| n.header.sizes = vec![2, 2, 3],
        |n| n.header.scalar = ScalarType::I16,
    ];
    for edit in edits {
        let mut bad = n();
        edit(&mut bad);
        let e = rnd_std::volume_io::volume_from_nrrd(bad).unwrap_err();
        assert_eq!(e.kind, rnd_std::ErrorKind::Format, "{e}");
    }
}
