//! MetaImage volumes (ITK, 3D Slicer): a text header of `Key = Value` lines, then the
//! samples (`ElementDataFile = LOCAL`, `.mha`) or a data file the header names
//! (`.mhd` + `.raw`/`.zraw`), raw or zlib-compressed.
//!
//! Geometry: `ElementSpacing` (default 1), `Offset` (or its synonyms `Position`,
//! `Origin`; default 0) and `TransformMatrix` (or `Rotation`, `Orientation`; default
//! identity), whose consecutive triples are the world directions of the index axes, as
//! ITK writes them. Coordinates are in ITK's LPS world (`left-posterior-superior`);
//! `AnatomicalOrientation`, which ITK derives from the matrix, is not read.
//! There is no crate for this small format that is kept up, so it is read here.

use std::io::{BufRead, Read};
use std::path::{Path, PathBuf};

use super::{Format, Loaded};
use crate::nrrd::{Endian, ScalarType};
use crate::{Error, Result};

/// The header's lines, up to and including `ElementDataFile` (always last).
#[derive(Debug, Default)]
struct Header {
    fields: Vec<(String, String)>,
}

impl Header {
    fn get(&self, keys: &[&str]) -> Option<&str> {
        self.fields
            .iter()
            .find(|(k, _)| keys.iter().any(|w| k.eq_ignore_ascii_case(w)))
            .map(|(_, v)| v.as_str())
    }
    fn nums(&self, keys: &[&str], n: usize) -> Result<Option<Vec<f64>>> {
        let Some(v) = self.get(keys) else {
            return Ok(None);
        };
        let x: Vec<f64> = v
            .split_whitespace()
            .map(|w| crate::nrrd::read::parse_f64(w).filter(|x| x.is_finite()))
            .collect::<Option<_>>()
            .ok_or_else(|| Error::msg(format!("{}: \"{v}\" is not a list of numbers", keys[0])))?;
        if x.len() != n {
            return Err(Error::msg(format!(
                "{}: {} numbers, need {n}",
                keys[0],
                x.len()
            )));
        }
        Ok(Some(x))
    }
    fn flag(&self, keys: &[&str]) -> Result<bool> {
        match self.get(keys) {
            None => Ok(false),
            Some(v) if v.eq_ignore_ascii_case("true") || v == "1" => Ok(true),
            Some(v) if v.eq_ignore_ascii_case("false") || v == "0" => Ok(false),
            Some(v) => Err(Error::msg(format!(
                "{}: \"{v}\" is not True or False",
                keys[0]
            ))),
        }
    }
}

/// Longest header read.
const HEADER_MAX: usize = 1 << 20;

/// Reads header lines from `r` until `ElementDataFile`.
fn read_header(r: &mut dyn BufRead) -> Result<Header> {
    let mut h = Header::default();
    let mut total = 0usize;
    loop {
        let mut line = Vec::new();
        let n = r
            .take((HEADER_MAX - total) as u64 + 1)
            .read_until(b'\n', &mut line)
            .map_err(|e| Error::msg(format!("can't read: {e}")))?;
        total += n;
        if total > HEADER_MAX {
            return Err(Error::msg(format!(
                "MetaImage header: longer than {} without ElementDataFile",
                crate::human_bytes(HEADER_MAX as u64)
            )));
        }
        if n == 0 {
            return Err(Error::msg(
                "MetaImage header: ends without ElementDataFile (the last line of a header)",
            ));
        }
        let text = String::from_utf8_lossy(&line);
        let text = text.trim();
        if text.is_empty() {
            continue;
        }
        let (k, v) = text.split_once('=').ok_or_else(|| {
            Error::msg(format!(
                "MetaImage header: \"{}\" is not a \"Key = Value\" line",
                crate::nrrd::read::short(text)
            ))
        })?;
        let (k, v) = (k.trim().to_string(), v.trim().to_string());
        let last = k.eq_ignore_ascii_case("ElementDataFile");
        h.fields.push((k, v));
        if last {
            return Ok(h);
        }
    }
}

fn scalar(t: &str) -> Result<ScalarType> {
    Ok(match t.to_ascii_uppercase().as_str() {
        "MET_CHAR" => ScalarType::I8,
        "MET_UCHAR" => ScalarType::U8,
        "MET_SHORT" => ScalarType::I16,
        "MET_USHORT" => ScalarType::U16,
        // MetaIO's LONG types are 4 bytes wide, LONG_LONG 8.
        "MET_INT" | "MET_LONG" => ScalarType::I32,
        "MET_UINT" | "MET_ULONG" => ScalarType::U32,
        "MET_LONG_LONG" => ScalarType::I64,
        "MET_ULONG_LONG" => ScalarType::U64,
        "MET_FLOAT" => ScalarType::F32,
        "MET_DOUBLE" => ScalarType::F64,
        _ => {
            return Err(Error::msg(format!(
                "ElementType {t} is not a scalar sample type rendr reads"
            )))
        }
    })
}

/// Reads a MetaImage whose header starts `r`; `path` locates a separate data file.
pub(super) fn read(r: &mut dyn BufRead, path: &Path) -> Result<Loaded> {
    let h = read_header(r)?;
    let mi = |e: Error| Error::msg(format!("MetaImage: {}", e.msg));
    let (sizes, t, endian, dirs, origin, mut notes) = describe(&h).map_err(mi)?;
    let n = sizes[0] * sizes[1] * sizes[2];
    let nbytes = n * t.size();
    let compressed = h.flag(&["CompressedData"]).map_err(mi)?;
    let binary = h.get(&["BinaryData"]).is_none() || h.flag(&["BinaryData"]).map_err(mi)?;
    let file = h.get(&["ElementDataFile"]).unwrap_or_default();
    let header_size = match h.get(&["HeaderSize"]) {
        None => 0i64,
        Some(v) => v.parse::<i64>().ok().filter(|&x| x >= -1).ok_or_else(|| {
            Error::msg(format!(
                "MetaImage: HeaderSize \"{v}\" is not a byte count or -1"
            ))
        })?,
    };
    let mut local;
    let mut opened;
    let src: &mut dyn Read = if file.eq_ignore_ascii_case("LOCAL") {
        if header_size != 0 {
            return Err(Error::msg(
                "MetaImage: HeaderSize with LOCAL data is not supported",
            ));
        }
        local = r;
        &mut local
    } else {
        let data = data_path(path, file).map_err(mi)?;
        let mut f = std::fs::File::open(&data).map_err(|e| Error::io(&data, "can't read", e))?;
        if header_size == -1 {
            if compressed {
                return Err(Error::msg("MetaImage: HeaderSize -1 with compressed data"));
            }
            use std::io::Seek;
            let len = f.metadata().map(|m| m.len()).unwrap_or(0);
            let start = len.checked_sub(nbytes as u64).ok_or_else(|| {
                Error::at(
                    &data,
                    format!("holds {len} bytes, fewer than the {nbytes} of the data"),
                )
            })?;
            f.seek(std::io::SeekFrom::Start(start))
                .map_err(|e| Error::io(&data, "can't seek", e))?;
        }
        opened = std::io::BufReader::new(f);
        if header_size > 0 {
            super::skip(&mut opened, header_size as u64, "HeaderSize")
                .map_err(|e| e.with_path(&data))?;
        }
        notes.push(format!("data read from {}", data.display()));
        &mut opened
    };
    let data = if !binary {
        if compressed {
            return Err(Error::msg("MetaImage: compressed text data"));
        }
        let limit = (n as u64).saturating_mul(64) + (1 << 20);
        let mut text = Vec::new();
        src.take(limit)
            .read_to_end(&mut text)
            .map_err(|e| Error::msg(format!("can't read: {e}")))?;
        let text = String::from_utf8_lossy(&text);
        crate::nrrd::read::text_samples(t, &text, n)?
    } else if compressed {
        // zlib; CompressedDataSize, when given, bounds what is read.
        let csize = match h.get(&["CompressedDataSize"]) {
            Some(v) => Some(v.parse::<u64>().map_err(|_| {
                Error::msg(format!(
                    "MetaImage: CompressedDataSize \"{v}\" is not a byte count"
                ))
            })?),
            None => None,
        };
        let bounded = src.take(csize.unwrap_or(u64::MAX));
        let mut z = crate::codec::unzlib(bounded)?;
        crate::nrrd::read::read_samples(&mut z, t, endian, n)?
    } else {
        crate::nrrd::read::read_samples(src, t, endian, n)?
    };
    let nrrd = super::volume_nrrd(sizes, data, "left-posterior-superior", dirs, origin)?;
    Ok(Loaded {
        nrrd,
        format: Format::MetaImage,
        notes,
    })
}

type Described = (
    [usize; 3],
    ScalarType,
    Endian,
    [[f64; 3]; 3],
    [f64; 3],
    Vec<String>,
);

/// Sizes, sample type, byte order and geometry from a header.
fn describe(h: &Header) -> Result<Described> {
    if let Some(o) = h.get(&["ObjectType"]) {
        if !o.eq_ignore_ascii_case("Image") {
            return Err(Error::msg(format!("ObjectType {o}: only Image is read")));
        }
    }
    let nd = h
        .get(&["NDims"])
        .ok_or_else(|| Error::msg("no NDims"))?
        .parse::<usize>()
        .ok()
        .filter(|d| (1..=8).contains(d))
        .ok_or_else(|| Error::msg("NDims is not a number of axes (1 to 8)"))?;
    let dims = h
        .nums(&["DimSize"], nd)?
        .ok_or_else(|| Error::msg("no DimSize"))?;
    if dims.iter().any(|d| d.fract() != 0.0) {
        return Err(Error::msg(format!(
            "DimSize {dims:?} are not whole numbers"
        )));
    }
    let di: Vec<i64> = dims.iter().map(|&d| d as i64).collect();
    let sizes = super::sizes3(&di, "DimSize")?;
    if let Some(c) = h.get(&["ElementNumberOfChannels"]) {
        if c.trim() != "1" {
            return Err(Error::msg(format!(
                "ElementNumberOfChannels {c}: rendr renders scalar volumes (1 channel)"
            )));
        }
    }
    let t = scalar(
        h.get(&["ElementType"])
            .ok_or_else(|| Error::msg("no ElementType"))?,
    )?;
    let msb = h.flag(&["BinaryDataByteOrderMSB"])? || h.flag(&["ElementByteOrderMSB"])?;
    let endian = if msb { Endian::Big } else { Endian::Little };
    // Only the first three axes carry geometry; later ones (of size 1) are dropped.
    let first3 = |v: Vec<f64>, stride: usize| -> Vec<f64> {
        (0..3)
            .flat_map(|i| (0..3).map(move |j| (i, j)))
            .map(|(i, j)| v[i * stride + j])
            .collect()
    };
    let sp = h
        .nums(&["ElementSpacing"], nd)?
        .unwrap_or_else(|| vec![1.0; nd]);
    let o = h
        .nums(&["Offset", "Position", "Origin"], nd)?
        .unwrap_or_else(|| vec![0.0; nd]);
    let m = match h.nums(&["TransformMatrix", "Rotation", "Orientation"], nd * nd)? {
        Some(m) => first3(m, nd),
        None => first3(identity(nd), nd),
    };
    if sp[..3].contains(&0.0) {
        return Err(Error::msg(format!("ElementSpacing {sp:?} has a zero")));
    }
    let dirs: [[f64; 3]; 3] =
        core::array::from_fn(|i| core::array::from_fn(|j| m[3 * i + j] * sp[i]));
    Ok((sizes, t, endian, dirs, [o[0], o[1], o[2]], Vec::new()))
}

fn identity(n: usize) -> Vec<f64> {
    (0..n * n)
        .map(|i| if i % (n + 1) == 0 { 1.0 } else { 0.0 })
        .collect()
}

/// The data file a header names, resolved beside the header. Lists and file-name
/// patterns (one file per slice) are refused.
fn data_path(header: &Path, file: &str) -> Result<PathBuf> {
    if file.is_empty() {
        return Err(Error::msg("ElementDataFile is empty"));
    }
    let upper = file.to_ascii_uppercase();
    if upper == "LIST" || upper.starts_with("LIST ") || file.contains('%') {
        return Err(Error::msg(format!(
            "ElementDataFile {file}: data split over several files is not read; join them into \
             one file (or convert with ITK)"
        )));
    }
    if header.as_os_str() == "-" {
        return Err(Error::msg(format!(
            "ElementDataFile {file}: a header read from stdin can't name a data file"
        )));
    }
    let dir = header.parent().unwrap_or(Path::new(""));
    Ok(dir.join(file))
}

/// The data file of the MetaImage header `path`, if it names one.
pub(super) fn data_file(path: &Path) -> Option<PathBuf> {
    let f = std::fs::File::open(path).ok()?;
    let mut r = std::io::BufReader::new(f.take(HEADER_MAX as u64));
    if !super::is_metaimage(r.fill_buf().ok()?) {
        return None;
    }
    let h = read_header(&mut r).ok()?;
    let file = h.get(&["ElementDataFile"])?;
    if file.eq_ignore_ascii_case("LOCAL") {
        return None;
    }
    data_path(path, file).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hdr(text: &str) -> Header {
        read_header(&mut text.as_bytes()).unwrap()
    }

    #[test]
    fn transform_triples_are_axis_directions() {
        let h = hdr(
            "ObjectType = Image\nNDims = 3\nDimSize = 2 3 4\nElementType = MET_SHORT\n\
                     ElementSpacing = 1 2 3\nOffset = 5 6 7\n\
                     TransformMatrix = 0 1 0 -1 0 0 0 0 1\nElementDataFile = LOCAL\n",
        );
        let (sizes, t, e, dirs, o, _) = describe(&h).unwrap();
        assert_eq!((sizes, t, e), ([2, 3, 4], ScalarType::I16, Endian::Little));
        assert_eq!(dirs, [[0.0, 1.0, 0.0], [-2.0, 0.0, 0.0], [0.0, 0.0, 3.0]]);
        assert_eq!(o, [5.0, 6.0, 7.0]);
    }

    #[test]
    fn local_data_and_errors() {
        let mut bytes = b"NDims = 3\nDimSize = 2 1 1\nElementType = MET_USHORT\n\
                          ElementByteOrderMSB = True\nElementDataFile = LOCAL\n"
            .to_vec();
        bytes.extend_from_slice(&[1, 2, 3, 4]);
        let l = read(&mut &bytes[..], Path::new("x.mha")).unwrap();
        assert_eq!(l.nrrd.data, crate::nrrd::Data::U16(vec![0x0102, 0x0304]));
        let short = &bytes[..bytes.len() - 1];
        let e = read(&mut &short[..], Path::new("x.mha")).unwrap_err();
        assert!(e.msg.contains("truncated"), "{e}");
        for bad in [
            "NDims = 3\nDimSize = 2 2\nElementType = MET_SHORT\nElementDataFile = LOCAL\n",
            "NDims = 3\nDimSize = 2 2 2\nElementType = MET_RGB\nElementDataFile = LOCAL\n",
            "NDims = 3\nDimSize = 2 2 2\nElementType = MET_SHORT\nElementNumberOfChannels = 3\nElementDataFile = LOCAL\n",
            "NDims = 3\nDimSize = 2 2 2\nElementType = MET_SHORT\nElementDataFile = a%03d.raw\n",
            "NDims = 3\nDimSize = 2 2 2\nElementType = MET_SHORT\n",
        ] {
            assert!(read(&mut bad.as_bytes(), Path::new("x.mha")).is_err(), "{bad}");
        }
    }
}
