//! Volume files of every format rendr reads, recognised by their content (not their
//! name): NRRD (and plain-text arrays), NIfTI-1 and NIfTI-2 (`.nii`, `.nii.gz`,
//! `.hdr`/`.img`), MetaImage (`.mha`, `.mhd` with its data file) and DICOM series (a
//! directory of slices, or one file of it).
//!
//! Every reader turns its file into a [`Nrrd`] whose header carries the geometry in
//! NRRD terms: `space` names the world frame the file uses (NIfTI: RAS,
//! `right-anterior-superior`; MetaImage and DICOM: LPS, `left-posterior-superior`),
//! `space directions` are the index-to-world columns, `space origin` the world position
//! of the first sample. So [`crate::volume_io`] builds renderable volumes from any of
//! them, and `rendr convert` writes any of them as NRRD that Teem reads.
//!
//! Each non-NRRD format sits behind a cargo feature of `rnd-std` (`nifti`, `metaimage`,
//! `dicom`; all on by default); a file of a format left out is refused with a message
//! naming the feature.
// Builds without some formats leave their helpers unused.
#![cfg_attr(
    not(all(feature = "nifti", feature = "metaimage", feature = "dicom")),
    allow(dead_code, unused_mut, unused_imports, unused_variables)
)]

use std::io::{BufRead, Read};
use std::path::{Path, PathBuf};

use crate::nrrd::{self, Data, Nrrd};
use crate::{Error, Result};

#[cfg(feature = "dicom")]
mod dicom;
#[cfg(feature = "metaimage")]
mod metaimage;
#[cfg(feature = "nifti")]
mod nifti;

/// The file formats rendr reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// NRRD (or a plain-text array).
    Nrrd,
    /// NIfTI-1 (348-byte header).
    Nifti1,
    /// NIfTI-2 (540-byte header).
    Nifti2,
    /// MetaImage (`.mha`/`.mhd`).
    MetaImage,
    /// DICOM (a series of slices).
    Dicom,
}

impl Format {
    /// The format's usual name.
    pub fn name(self) -> &'static str {
        match self {
            Format::Nrrd => "NRRD",
            Format::Nifti1 => "NIfTI-1",
            Format::Nifti2 => "NIfTI-2",
            Format::MetaImage => "MetaImage",
            Format::Dicom => "DICOM",
        }
    }

    /// The world frame the format's coordinates are in (NRRD: whatever its `space`
    /// says).
    pub fn frame(self) -> Option<&'static str> {
        match self {
            Format::Nrrd => None,
            Format::Nifti1 | Format::Nifti2 => Some("RAS"),
            Format::MetaImage | Format::Dicom => Some("LPS"),
        }
    }
}

/// A volume file read into memory.
#[derive(Debug, Clone, PartialEq)]
pub struct Loaded {
    /// The samples and the geometry, in NRRD terms.
    pub nrrd: Nrrd,
    /// The format the file was in.
    pub format: Format,
    /// What the reader decided, one sentence each (which of a NIfTI file's transforms
    /// was used, a rescale applied...).
    pub notes: Vec<String>,
}

/// Bytes looked at to recognise a format.
const PEEK: usize = 1024;

/// The format of a file that starts with `head` (at least its first 348 bytes, when
/// there are that many), or `None` for NRRD and anything unrecognised (which the NRRD
/// reader then reads or refuses, as it does text arrays). gzip-compressed data is
/// recognised after decompression by the caller.
pub fn detect(head: &[u8]) -> Option<Format> {
    let i32_at = |o: usize| -> Option<[i32; 2]> {
        let b: [u8; 4] = head.get(o..o + 4)?.try_into().ok()?;
        Some([i32::from_le_bytes(b), i32::from_be_bytes(b)])
    };
    if head.starts_with(b"NRRD") {
        return Some(Format::Nrrd);
    }
    if let Some(sz) = i32_at(0) {
        let magic = |o: usize, m: &[u8]| head.get(o..o + m.len()) == Some(m);
        if sz.contains(&348) && (magic(344, b"n+1\0") || magic(344, b"ni1\0")) {
            return Some(Format::Nifti1);
        }
        if sz.contains(&540) && (magic(4, b"n+2\0") || magic(4, b"ni2\0")) {
            return Some(Format::Nifti2);
        }
    }
    if head.get(128..132) == Some(b"DICM") {
        return Some(Format::Dicom);
    }
    if is_metaimage(head) {
        return Some(Format::MetaImage);
    }
    None
}

/// A MetaImage header starts with one of its keys followed by `=`.
fn is_metaimage(head: &[u8]) -> bool {
    const KEYS: [&str; 6] = [
        "ObjectType",
        "NDims",
        "Comment",
        "ObjectSubType",
        "TransformType",
        "Name",
    ];
    let line = head.split(|&b| b == b'\n').next().unwrap_or_default();
    let Ok(line) = std::str::from_utf8(line) else {
        return false;
    };
    let Some((k, _)) = line.split_once('=') else {
        return false;
    };
    KEYS.iter().any(|key| k.trim().eq_ignore_ascii_case(key))
}

/// The first bytes of an input and a reader that starts over from them.
type Peeked<'a> = (Vec<u8>, std::io::BufReader<Box<dyn Read + 'a>>);

/// Reads up to [`PEEK`] bytes of `src` (fewer only at its end) and returns them with a
/// reader that yields them again, followed by the rest of `src`.
fn peek<'a>(mut src: Box<dyn Read + 'a>) -> Result<Peeked<'a>> {
    let mut head = Vec::new();
    (&mut src)
        .take(PEEK as u64)
        .read_to_end(&mut head)
        .map_err(read_error)?;
    let again: Box<dyn Read + 'a> = Box::new(std::io::Cursor::new(head.clone()).chain(src));
    Ok((head, std::io::BufReader::with_capacity(1 << 16, again)))
}

fn read_error(e: std::io::Error) -> Error {
    Error::msg(format!("can't read: {e}"))
}

/// Reads the volume file `path` (`-` = stdin; a directory = a DICOM series) in whatever
/// format it is, `threads` threads reading large raw NRRD data at once.
///
/// # Errors
/// When the file can't be read, its format isn't one rendr reads (or was left out of
/// this build), or it is malformed; the error names the file.
pub fn read(path: &Path, threads: usize) -> Result<Loaded> {
    read_inner(path, threads).map_err(|e| e.with_path(path))
}

fn read_inner(path: &Path, threads: usize) -> Result<Loaded> {
    let stdin = path.as_os_str() == "-";
    let mut regular = false;
    if !stdin {
        let meta = std::fs::metadata(path).map_err(|e| Error::io(path, "can't read", e))?;
        if meta.is_dir() {
            return read_dicom(path);
        }
        regular = meta.is_file();
    }
    let src: Box<dyn Read> = if stdin {
        Box::new(std::io::stdin().lock())
    } else {
        Box::new(std::fs::File::open(path).map_err(|e| Error::io(path, "can't read", e))?)
    };
    let (head, mut r) = peek(src)?;
    if head.starts_with(b"\x1f\x8b") {
        // Only NIfTI is stored as a whole gzip stream (`.nii.gz`, `.hdr.gz`).
        let (zhead, mut z) = peek(crate::codec::gunzip(r)?)?;
        return match detect(&zhead) {
            Some(f @ (Format::Nifti1 | Format::Nifti2)) => read_nifti(f, &mut z, path, true),
            _ => Err(Error::msg(
                "a gzip stream that does not hold a NIfTI file (a gzip-compressed NRRD \
                 keeps its header uncompressed; decompress this file first)",
            )),
        };
    }
    let format = detect(&head);
    match format {
        Some(f @ (Format::Nifti1 | Format::Nifti2)) => read_nifti(f, &mut r, path, false),
        Some(Format::MetaImage) => read_metaimage(&mut r, path),
        Some(Format::Dicom) if regular => read_dicom(path),
        Some(Format::Dicom) => Err(Error::msg(
            "a DICOM file read from a stream: DICOM series are read from files (name the \
             folder or one file of the series)",
        )),
        Some(Format::Nrrd) | None => {
            let nrrd = if regular {
                // Reopened: regular files are read with seeks and several threads.
                drop(r);
                nrrd::read_with_threads(path, threads)?
            } else {
                // A pipe or stdin: the bytes already peeked are read again from `r`.
                let dir = match path.parent() {
                    Some(d) if !stdin => d,
                    _ => Path::new("."),
                };
                nrrd::read::read_from(r, dir, false)?
            };
            Ok(Loaded {
                nrrd,
                format: Format::Nrrd,
                notes: Vec::new(),
            })
        }
    }
}

#[cfg_attr(
    all(feature = "nifti", feature = "metaimage", feature = "dicom"),
    allow(dead_code)
)]
fn missing(feature: &str, what: &str) -> Error {
    Error::msg(format!(
        "this is a {what} file, and this build of rnd-std was made without its feature \
         \"{feature}\""
    ))
}

#[cfg(feature = "nifti")]
fn read_nifti(f: Format, r: &mut dyn BufRead, path: &Path, gz: bool) -> Result<Loaded> {
    nifti::read(f, r, path, gz)
}
#[cfg(not(feature = "nifti"))]
fn read_nifti(f: Format, _: &mut dyn BufRead, _: &Path, _: bool) -> Result<Loaded> {
    Err(missing("nifti", f.name()))
}

#[cfg(feature = "metaimage")]
fn read_metaimage(r: &mut dyn BufRead, path: &Path) -> Result<Loaded> {
    metaimage::read(r, path)
}
#[cfg(not(feature = "metaimage"))]
fn read_metaimage(_: &mut dyn BufRead, _: &Path) -> Result<Loaded> {
    Err(missing("metaimage", "MetaImage"))
}

#[cfg(feature = "dicom")]
fn read_dicom(path: &Path) -> Result<Loaded> {
    dicom::read(path)
}
#[cfg(not(feature = "dicom"))]
fn read_dicom(_: &Path) -> Result<Loaded> {
    Err(missing("dicom", "DICOM"))
}

/// The files reading `path` reads: the file itself, and a NRRD's detached data files, a
/// NIfTI header's `.img`, a MetaImage header's data file, a DICOM series' slices. For
/// checking that an output does not overwrite an input; a file that can't be read
/// gives just itself (the reader reports the problem).
pub fn input_files(path: &Path) -> Vec<PathBuf> {
    let mut out = nrrd::input_files(path);
    // Only regular files and folders are looked into: reading a pipe would eat its data.
    let kind = std::fs::metadata(path).map(|m| (m.is_file(), m.is_dir()));
    if path.as_os_str() == "-" || !matches!(kind, Ok((true, _)) | Ok((_, true))) {
        return out;
    }
    #[cfg(feature = "dicom")]
    out.extend(dicom::input_files(path));
    #[cfg(feature = "nifti")]
    out.extend(nifti::pair_data_file(path));
    #[cfg(feature = "metaimage")]
    out.extend(metaimage::data_file(path));
    out
}

/// The NRRD header for a volume read from another format: `sizes` and `data`, world
/// frame `space`, index-to-world columns `dirs` and `origin`; cell-centred domain axes.
pub(crate) fn volume_nrrd(
    sizes: [usize; 3],
    data: Data,
    space: &str,
    dirs: [[f64; 3]; 3],
    origin: [f64; 3],
) -> Result<Nrrd> {
    let mut n = Nrrd::new(sizes.to_vec(), data)?;
    let h = &mut n.header;
    h.space = Some(space.to_string());
    h.space_directions = Some(dirs.iter().map(|d| Some(d.to_vec())).collect());
    h.space_origin = Some(origin.to_vec());
    h.centerings = Some(vec![nrrd::Centering::Cell; 3]);
    h.kinds = Some(vec!["domain".into(); 3]);
    Ok(n)
}

/// Sizes from a header's numbers: exactly three positive axes (later axes of size 1
/// dropped), their product within `usize`.
pub(crate) fn sizes3(dims: &[i64], what: &str) -> Result<[usize; 3]> {
    let mut d: Vec<i64> = dims.to_vec();
    while d.len() > 3 && d.last() == Some(&1) {
        d.pop();
    }
    if d.len() != 3 {
        return Err(Error::msg(format!(
            "{what}: the volume has {} axes (sizes {dims:?}); rendr renders 3-D scalar volumes",
            d.len()
        )));
    }
    if d.iter().any(|&s| s < 1) {
        return Err(Error::msg(format!(
            "{what}: sizes {dims:?} must be positive"
        )));
    }
    let s: [usize; 3] = core::array::from_fn(|i| usize::try_from(d[i]).unwrap_or(usize::MAX));
    s.iter()
        .try_fold(1usize, |a, &x| a.checked_mul(x))
        .ok_or_else(|| Error::msg(format!("{what}: sizes {dims:?} overflow")))?;
    Ok(s)
}

/// Applies a rescale `slope · v + inter` (NIfTI `scl_slope`/`scl_inter`, DICOM
/// RescaleSlope/Intercept) to the samples. Integer samples that the rescale keeps
/// integral and inside the 16-bit range become `short` (exactly); all others become
/// `float` (computed in double, then rounded). An identity rescale changes nothing.
/// Returns the new samples and a sentence saying what was done (`None` for identity).
pub(crate) fn rescale(d: Data, slope: f64, inter: f64) -> Result<(Data, Option<String>)> {
    if slope == 1.0 && inter == 0.0 {
        return Ok((d, None));
    }
    if !slope.is_finite() || !inter.is_finite() {
        return Err(Error::msg(format!(
            "rescale slope {slope} and intercept {inter} must be finite numbers"
        )));
    }
    let n = d.len();
    let integral = slope.fract() == 0.0 && inter.fract() == 0.0;
    if integral && !d.scalar_type().is_float() {
        let (lo, hi) = min_max_f64(&d);
        let ends = [lo * slope + inter, hi * slope + inter];
        let fits = |x: f64| (i16::MIN as f64..=i16::MAX as f64).contains(&x);
        if n == 0 || ends.iter().all(|&x| fits(x)) {
            let mut v: Vec<i16> = Vec::new();
            crate::try_reserve(&mut v, n, "the rescaled samples")?;
            #[allow(clippy::unnecessary_cast)]
            {
                nrrd::each_data!(&d, src => v.extend(src.iter().map(|&x| (x as f64 * slope + inter) as i16)));
            }
            return Ok((
                Data::I16(v),
                Some(format!(
                    "{} samples rescaled by {slope} · v + {inter} into short (exact)",
                    d.scalar_type()
                )),
            ));
        }
    }
    crate::check_memory((n as u64).saturating_mul(4), "the rescaled samples")?;
    let mut v: Vec<f32> = Vec::new();
    crate::try_reserve(&mut v, n, "the rescaled samples")?;
    #[allow(clippy::unnecessary_cast)]
    {
        nrrd::each_data!(&d, src => v.extend(src.iter().map(|&x| (x as f64 * slope + inter) as f32)));
    }
    Ok((
        Data::F32(v),
        Some(format!(
            "{} samples rescaled by {slope} · v + {inter} into float",
            d.scalar_type()
        )),
    ))
}

#[allow(clippy::unnecessary_cast)]
fn min_max_f64(d: &Data) -> (f64, f64) {
    nrrd::each_data!(d, v => v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
        let x = x as f64;
        (a.min(x), b.max(x))
    }))
}

/// Discards `n` bytes of `r` (space between a header and its data), refusing more than
/// [`nrrd::SKIP_MAX`] so a lying offset can't make the reader run through a stream.
pub(crate) fn skip(r: &mut dyn Read, n: u64, what: &str) -> Result<()> {
    if n > nrrd::SKIP_MAX {
        return Err(Error::msg(format!(
            "{what}: {n} bytes before the data; at most {} are skipped",
            nrrd::SKIP_MAX
        )));
    }
    let got = std::io::copy(&mut r.take(n), &mut std::io::sink()).map_err(read_error)?;
    if got < n {
        return Err(Error::msg(format!(
            "{what}: the file ends {got} bytes in, before its data starts ({n} bytes in)"
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rescale_keeps_integral_results_short() {
        let (d, note) = rescale(Data::U16(vec![0, 1000, 4095]), 1.0, -1024.0).unwrap();
        assert_eq!(d, Data::I16(vec![-1024, -24, 3071]));
        assert!(note.unwrap().contains("short"));
        let (d, _) = rescale(Data::I16(vec![0, 30000]), 2.0, 0.0).unwrap();
        assert_eq!(d, Data::F32(vec![0.0, 60000.0]));
        let (d, _) = rescale(Data::I16(vec![1, 3]), 0.5, 0.25).unwrap();
        assert_eq!(d, Data::F32(vec![0.75, 1.75]));
        let (d, note) = rescale(Data::U8(vec![7]), 1.0, 0.0).unwrap();
        assert_eq!((d, note), (Data::U8(vec![7]), None));
        assert!(rescale(Data::U8(vec![7]), f64::NAN, 0.0).is_err());
    }

    #[test]
    fn detects_by_content() {
        let mut n1 = vec![0u8; 352];
        n1[..4].copy_from_slice(&348i32.to_be_bytes());
        n1[344..348].copy_from_slice(b"n+1\0");
        assert_eq!(detect(&n1), Some(Format::Nifti1));
        let mut n2 = vec![0u8; 544];
        n2[..4].copy_from_slice(&540i32.to_le_bytes());
        n2[4..8].copy_from_slice(b"ni2\0");
        assert_eq!(detect(&n2), Some(Format::Nifti2));
        assert_eq!(
            detect(b"ObjectType = Image\nNDims = 3\n"),
            Some(Format::MetaImage)
        );
        assert_eq!(detect(b"NRRD0004\n"), Some(Format::Nrrd));
        assert_eq!(detect(b"1 2 3\n4 5 6\n"), None);
        let mut dcm = vec![0u8; 132];
        dcm[128..].copy_from_slice(b"DICM");
        assert_eq!(detect(&dcm), Some(Format::Dicom));
    }

    #[test]
    fn sizes_drop_trailing_unit_axes() {
        assert_eq!(sizes3(&[4, 5, 6, 1, 1], "t").unwrap(), [4, 5, 6]);
        assert!(sizes3(&[4, 5], "t").is_err());
        assert!(sizes3(&[4, 5, 6, 2], "t").is_err());
        assert!(sizes3(&[4, 0, 6], "t").is_err());
        assert!(sizes3(&[i64::MAX, i64::MAX, 2], "t").is_err());
    }
}
