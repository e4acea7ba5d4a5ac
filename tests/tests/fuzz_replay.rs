//! Replays the fuzz seeds and every minimized crash input kept under
//! `fuzz/corpus/<target>/regressions/` through the same code the fuzz targets drive:
//! each must give a value or an error, never a panic.

use std::path::{Path, PathBuf};

use rnd_std::{files, nrrd, volume_io};

fn inputs(target: &str) -> Vec<PathBuf> {
    let root = rnd_tests::root().join("fuzz");
    let mut v = Vec::new();
    for dir in [
        root.join("seeds").join(target),
        root.join("corpus").join(target).join("regressions"),
    ] {
        if let Ok(rd) = std::fs::read_dir(&dir) {
            v.extend(
                rd.filter_map(|e| e.ok())
                    .map(|e| e.path())
                    .filter(|p| p.is_file()),
            );
        }
    }
    v.sort();
    v
}

#[test]
fn replay_nrrd_read() {
    let v = inputs("nrrd_read");
    assert!(v.len() >= 10, "seeds missing: {v:?}");
    for p in v {
        let data = std::fs::read(&p).unwrap();
        if let Ok(n) = nrrd::read_bytes(&data, Path::new("/nonexistent")) {
            let _ = volume_io::volume_from_nrrd(n);
        }
    }
}

#[test]
fn replay_loaders_and_text() {
    let mut all = inputs("loaders");
    all.extend(inputs("text_array"));
    assert!(all.len() >= 10);
    for p in all {
        let data = std::fs::read(&p).unwrap();
        if let Ok(s) = std::str::from_utf8(&data) {
            let _ = nrrd::parse_text(s);
        }
        let Ok(n) = nrrd::read_bytes(&data, Path::new("/nonexistent")) else {
            continue;
        };
        let _ = files::txf_from_nrrd(&p, n.clone()).map(|t| t.eval(0.5));
        let _ = files::lut_from_nrrd(&p, n.clone()).map(|l| l.lookup(f32::NAN));
        let _ = files::levoy_from_nrrd(&p, n.clone()).map(|l| l.opacity(0.5, 0.0));
        let _ = files::lights_from_nrrd(&p, n);
    }
}

#[test]
fn replay_formats() {
    let v = inputs("formats");
    assert!(v.len() >= 10, "seeds missing: {v:?}");
    let mut loaded = 0;
    for p in &v {
        // Each input alone in a folder, as the fuzz target reads it.
        let dir = rnd_tests::tmpdir(&format!(
            "replay-formats-{}",
            p.file_name().unwrap().to_string_lossy()
        ));
        let file = dir.join("volume");
        std::fs::copy(p, &file).unwrap();
        if let Ok(l) = rnd_std::formats::read(&file, 1) {
            loaded += usize::from(volume_io::volume_from_nrrd(l.nrrd).is_ok());
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
    // The seeds written by nibabel, SimpleITK and pydicom load; the broken ones don't.
    let broken = v
        .iter()
        .filter(|p| {
            let n = p.file_name().unwrap().to_string_lossy();
            n.starts_with("truncated") || n.starts_with("jpeg2000")
        })
        .count();
    assert!(
        loaded >= 9 && loaded + broken <= v.len(),
        "{loaded} of {} loaded",
        v.len()
    );
}

/// Asserts that reading the kept formats regression `name`, alone in a folder as
/// `volume` (as the fuzz target reads it), is an error naming the file and saying
/// `want`.
fn refused(name: &str, want: &str) {
    let src = rnd_tests::root()
        .join("fuzz/corpus/formats/regressions")
        .join(name);
    let dir = rnd_tests::tmpdir(&format!("formats-error-{name}"));
    let file = dir.join("volume");
    std::fs::copy(&src, &file).unwrap();
    let m = match rnd_std::formats::read(&file, 1) {
        Ok(_) => panic!("{} loaded", src.display()),
        Err(e) => e.to_string(),
    };
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(m.contains("volume") && m.contains(want), "{m}");
}

/// An RLE Lossless DICOM whose segment decodes to fewer bytes than Rows x Columns (found
/// by the formats target: `dicom-pixeldata`'s decoder indexed past it and panicked) is
/// an error naming the file, the frame and the segment.
#[test]
fn rle_segment_that_decodes_short_is_an_error() {
    refused(
        "crash-rle-short-segment",
        "frame 0: segment 0 decodes to 36 bytes, fewer than Rows x Columns (42)",
    );
}

/// A JPEG Baseline DICOM whose JPEG frame is 8 x 6 where Rows x Columns is 3 x 8 (found
/// by the formats target: the registry's JPEG adapter copied the 48 decoded bytes into
/// the 24 it had sized and panicked) is an error naming the file and both sizes.
#[test]
fn jpeg_frame_larger_than_rows_columns_is_an_error() {
    refused(
        "crash-jpeg-larger-than-rows-columns",
        "JPEG pixel data: frame 0 is a 8 x 6 JPEG of 48 bytes; Rows x Columns x \
         SamplesPerPixel x BitsAllocated/8 is 24 (8 x 3 x 1 x 1)",
    );
    // A JPEG Baseline slice whose frame fits (the seed) passes the check and loads.
    let dir = rnd_tests::tmpdir("formats-jpeg-seed");
    let file = dir.join("slice.dcm");
    std::fs::copy(
        rnd_tests::root().join("fuzz/seeds/formats/slice-jpeg.dcm"),
        &file,
    )
    .unwrap();
    let l = rnd_std::formats::read(&file, 1).expect("the JPEG seed loads");
    assert!(volume_io::volume_from_nrrd(l.nrrd).is_ok());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// An element with an unknown VR (`ES`) is read by `dicom-encoding` as UN, with a
/// 4-byte length: here 2.1 GB, which its parser reserved before failing (found by the
/// formats target, out of memory). The length check reads it the same way and refuses
/// it before the parser runs.
#[test]
fn unknown_vr_lengths_are_bounded_by_the_file() {
    refused(
        "oom-unknown-vr-length",
        "element (0028,1053) claims 2145394737 bytes",
    );
}

/// A DICOM sequence item whose defined length (942 MB) is far past the end of its
/// 1.7 kB file (found by the formats target, out of memory: the parser took 2.4 GB
/// before failing). The length check bounds items and sequences by the file as it
/// bounds other elements.
#[test]
fn item_lengths_are_bounded_by_the_file() {
    refused(
        "oom-item-length",
        "element (FFFE,E000) claims 942669874 bytes",
    );
}

/// A deflated DICOM data set whose element claims 2.1 GB where 30 inflated bytes are
/// left (made by hand after the fuzz finds above: the walk did not enter deflated data
/// sets, and the parser took 2 GB before failing). The data set is inflated and walked.
#[test]
fn deflated_lengths_are_bounded_by_the_inflated_data_set() {
    refused(
        "oom-deflated-length",
        "element (0009,1010) claims 2130706432 bytes; the inflated data set has 30 left",
    );
}

/// An RLE DICOM whose (0002,0013) is a 14-byte SL in the data set (found by the formats
/// target: out of memory over a run, 775 MB for this file). The parser reads three
/// whole numbers and the next header 2 bytes early, there an unknown VR with a 775 MB
/// length; the walk reads numbers whole as the parser does, and refuses the claim.
#[test]
fn values_of_numbers_are_walked_as_the_parser_reads_them() {
    refused(
        "oom-short-value-desync",
        "element (2032,0008) claims 774963226 bytes",
    );
}

/// A JPEG DICOM whose pixel data has a defined length, so that its fragments' closing
/// sequence delimiter stands outside any sequence: the parser reads it as an element
/// with the delimiter's length, 4.29 GB (found by the formats target under a 300 MB
/// limit: 4.2 GB and 6 s). Delimiters' lengths are bounded by the file too.
#[test]
fn delimiter_lengths_are_bounded_by_the_file() {
    refused(
        "oom-delimiter-length",
        "element (FFFE,E0DD) claims 4294770688 bytes",
    );
}

/// A DICOM whose DS inside a nested sequence claims the bytes of the items after it,
/// so its item and sequence end (by their lengths) where an item header stands; the
/// parser reads that header as an element with a value of its length, and the header
/// after the value claims 1.4 GB (found by the formats target under a 300 MB limit:
/// 1.4 GB and 2.4 s). The walk follows the parser's stack of sequences and items.
#[test]
fn item_headers_after_an_item_ends_are_read_as_elements() {
    refused(
        "oom-in-sequence",
        "element (00FF,46E0) claims 1402016512 bytes",
    );
}

/// A NIfTI-2 header claiming 2 GB of samples over 845 bytes of data (found by the
/// formats target, out of memory: the whole claim was reserved and its pages mapped
/// before reading) is an error, and the memory it took grows with the data read.
#[test]
fn claimed_sizes_cost_no_memory_before_the_data_arrives() {
    refused(
        "oom-nifti2-claims-2gb",
        "data is truncated: 845 bytes of samples, need 2013237120",
    );
    // The process's peak resident memory (Linux), far below the claim.
    if let Ok(s) = std::fs::read_to_string("/proc/self/status") {
        let kb: u64 = s
            .lines()
            .find_map(|l| l.strip_prefix("VmHWM:"))
            .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
            .expect("VmHWM in /proc/self/status");
        assert!(kb < 512 * 1024, "peak resident memory {kb} kB");
    }
}
