//! DICOM series: a directory of single-frame slices, one file of such a series (its
//! siblings of the same SeriesInstanceUID are read with it), or an enhanced multi-frame
//! file whose frames carry their own plane positions.
//!
//! Files are parsed by `dicom-object`; pixel data of every transfer syntax that
//! `dicom-pixeldata` decodes (native, deflated, RLE, JPEG baseline/extended/lossless) is
//! read, others are refused naming the transfer syntax.
//!
//! Geometry, in DICOM's LPS patient frame (`left-posterior-superior`):
//! - `ImageOrientationPatient` gives the row direction `r` (the world direction of
//!   increasing column index, rendr's fast axis) and the column direction `c`;
//!   `PixelSpacing` is (row spacing, column spacing), so the index-to-world columns are
//!   `r · PixelSpacing[1]` and `c · PixelSpacing[0]`;
//! - slices are sorted by the position of `ImagePositionPatient` along the normal
//!   `r × c` (never by file name or instance number); the spacings between consecutive
//!   positions must agree (to 1/1000 of the slice step) or the series is refused
//!   (uneven spacing, a missing slice, two slices at one position);
//! - the third column is the mean step between consecutive `ImagePositionPatient`s
//!   (parallel to the normal, or sheared for a gantry tilt), the origin the first
//!   slice's position.
//!
//! Values: stored values are kept in their type (8/16/32 bits, signed or not) and
//! `RescaleSlope`/`RescaleIntercept` applied as [`super::rescale`] says; slices with
//! different rescales become float.

use std::path::{Path, PathBuf};

use dicom_dictionary_std::tags;
use dicom_object::mem::InMemElement;
use dicom_object::{InMemDicomObject, OpenFileOptions};
use dicom_pixeldata::{ConvertOptions, ModalityLutOption, PixelDecoder};

use super::{Format, Loaded};
use crate::nrrd::Data;
use crate::{Error, Result};

/// Most files a series directory may hold.
const FILES_MAX: usize = 100_000;

/// One frame (plane) of the volume and where its pixels are.
#[derive(Debug, Clone)]
struct Frame {
    file: PathBuf,
    /// Frame index in its file.
    index: u32,
    pos: [f64; 3],
    orient: [f64; 6],
    spacing: [f64; 2],
    rescale: (f64, f64),
}

/// What every frame of a series must share.
#[derive(Debug, Clone, PartialEq)]
struct Layout {
    rows: u32,
    cols: u32,
    bits: u16,
    signed: bool,
}

fn elem(o: &InMemDicomObject, tag: dicom_object::Tag) -> Option<&InMemElement> {
    o.element_opt(tag).ok().flatten()
}

fn floats(
    o: &InMemDicomObject,
    tag: dicom_object::Tag,
    name: &str,
    n: usize,
) -> Result<Option<Vec<f64>>> {
    let Some(e) = elem(o, tag) else {
        return Ok(None);
    };
    let v = e
        .to_multi_float64()
        .map_err(|err| Error::msg(format!("{name}: {err}")))?;
    if v.len() != n || v.iter().any(|x| !x.is_finite()) {
        return Err(Error::msg(format!("{name}: {v:?} is not {n} numbers")));
    }
    Ok(Some(v))
}

fn int(o: &InMemDicomObject, tag: dicom_object::Tag, name: &str) -> Result<Option<i64>> {
    elem(o, tag)
        .map(|e| {
            e.to_int::<i64>()
                .map_err(|err| Error::msg(format!("{name}: {err}")))
        })
        .transpose()
}

/// The first item of sequence `seq` in `o`.
fn item(o: &InMemDicomObject, seq: dicom_object::Tag) -> Option<&InMemDicomObject> {
    elem(o, seq)?.items()?.first()
}

/// A value from the functional groups: the frame's own item first, then the shared one,
/// then the top level.
fn grouped(
    top: &InMemDicomObject,
    per_frame: Option<&InMemDicomObject>,
    seq: dicom_object::Tag,
    tag: dicom_object::Tag,
    name: &str,
    n: usize,
) -> Result<Option<Vec<f64>>> {
    let shared = item(top, tags::SHARED_FUNCTIONAL_GROUPS_SEQUENCE);
    for g in [per_frame, shared].into_iter().flatten() {
        if let Some(s) = item(g, seq) {
            if let Some(v) = floats(s, tag, name, n)? {
                return Ok(Some(v));
            }
        }
    }
    floats(top, tag, name, n)
}

/// What one file holds, from its header (pixel data not read).
#[derive(Debug)]
struct FileInfo {
    /// SeriesInstanceUID.
    uid: String,
    layout: Layout,
    frames: Vec<Frame>,
    /// Transfer syntax UID.
    ts: String,
}

/// The index-to-world columns and origin of a series, and what was noted.
type Placed = ([[f64; 3]; 3], [f64; 3], Vec<String>);

/// The series UID, layout and frames of one file (header only, pixel data not read).
fn frames_of(path: &Path) -> Result<FileInfo> {
    let h = header_of(path)?;
    image_of(path, &h)
}

/// A DICOM file's data set up to its pixel data, and its series.
struct Header {
    obj: dicom_object::DefaultDicomObject,
    /// SeriesInstanceUID ("" without one).
    uid: String,
}

impl Header {
    /// Whether the file holds an image (Rows given): not a report, a presentation
    /// state or another object without pixels.
    fn is_image(&self) -> bool {
        elem(&self.obj, tags::ROWS).is_some()
    }
}

/// Reads `path`'s data set up to its pixel data (lengths checked first).
fn header_of(path: &Path) -> Result<Header> {
    check_lengths(path)?;
    let obj = OpenFileOptions::new()
        .read_until(tags::PIXEL_DATA)
        .open_file(path)
        .map_err(|e| Error::at(path, format!("not a readable DICOM file: {e}")))?;
    let uid = elem(&obj, tags::SERIES_INSTANCE_UID)
        .and_then(|e| e.to_str().ok())
        .map(|s| s.trim_end_matches('\0').trim().to_string())
        .unwrap_or_default();
    Ok(Header { obj, uid })
}

/// The slices in the file `path` whose header is `h`.
fn image_of(path: &Path, h: &Header) -> Result<FileInfo> {
    let obj = &h.obj;
    let ts = obj
        .meta()
        .transfer_syntax()
        .trim_end_matches('\0')
        .to_string();
    let o: &InMemDicomObject = obj;
    let at = |e: Error| e.with_path(path);
    let uid = h.uid.clone();
    let get = |tag, name: &str| -> Result<i64> {
        int(o, tag, name)?.ok_or_else(|| Error::msg(format!("no {name}: not an image")))
    };
    let spp = int(o, tags::SAMPLES_PER_PIXEL, "SamplesPerPixel")
        .map_err(at)?
        .unwrap_or(1);
    if spp != 1 {
        return Err(Error::at(
            path,
            format!("SamplesPerPixel {spp}: colour images can't be rendered as a scalar volume"),
        ));
    }
    let rows = get(tags::ROWS, "Rows").map_err(at)?;
    let cols = get(tags::COLUMNS, "Columns").map_err(at)?;
    let bits = get(tags::BITS_ALLOCATED, "BitsAllocated").map_err(at)?;
    let signed = int(o, tags::PIXEL_REPRESENTATION, "PixelRepresentation").map_err(at)? == Some(1);
    if !(1..=65535).contains(&rows) || !(1..=65535).contains(&cols) {
        return Err(Error::at(
            path,
            format!("Rows {rows} x Columns {cols} is not an image size"),
        ));
    }
    if ![8, 16, 32].contains(&bits) {
        return Err(Error::at(
            path,
            format!("BitsAllocated {bits}: only 8, 16 or 32 are read"),
        ));
    }
    let layout = Layout {
        rows: rows as u32,
        cols: cols as u32,
        bits: bits as u16,
        signed,
    };
    let nframes = int(o, tags::NUMBER_OF_FRAMES, "NumberOfFrames")
        .map_err(at)?
        .unwrap_or(1);
    if !(1..=1_000_000).contains(&nframes) {
        return Err(Error::at(
            path,
            format!("NumberOfFrames {nframes} is not a frame count"),
        ));
    }
    let per_frame: Vec<&InMemDicomObject> = elem(o, tags::PER_FRAME_FUNCTIONAL_GROUPS_SEQUENCE)
        .and_then(|e| e.items())
        .map(|items| items.iter().collect())
        .unwrap_or_default();
    if nframes > 1 && per_frame.len() != nframes as usize {
        return Err(Error::at(
            path,
            format!(
                "{nframes} frames without a plane position for each (PerFrameFunctionalGroups \
                 has {} items); rendr reads multi-frame files of the enhanced kind",
                per_frame.len()
            ),
        ));
    }
    let mut frames = Vec::new();
    for f in 0..nframes as usize {
        let pf = per_frame.get(f).copied();
        let need = |v: Option<Vec<f64>>, name: &str| {
            v.ok_or_else(|| Error::at(path, format!("no {name}: the slice has no place in space")))
        };
        let pos = need(
            grouped(
                o,
                pf,
                tags::PLANE_POSITION_SEQUENCE,
                tags::IMAGE_POSITION_PATIENT,
                "ImagePositionPatient",
                3,
            )
            .map_err(at)?,
            "ImagePositionPatient",
        )?;
        let orient = need(
            grouped(
                o,
                pf,
                tags::PLANE_ORIENTATION_SEQUENCE,
                tags::IMAGE_ORIENTATION_PATIENT,
                "ImageOrientationPatient",
                6,
            )
            .map_err(at)?,
            "ImageOrientationPatient",
        )?;
        let spacing = need(
            grouped(
                o,
                pf,
                tags::PIXEL_MEASURES_SEQUENCE,
                tags::PIXEL_SPACING,
                "PixelSpacing",
                2,
            )
            .map_err(at)?,
            "PixelSpacing",
        )?;
        let one = |tag, name| -> Result<Option<f64>> {
            Ok(grouped(
                o,
                pf,
                tags::PIXEL_VALUE_TRANSFORMATION_SEQUENCE,
                tag,
                name,
                1,
            )?
            .map(|v| v[0]))
        };
        let slope = one(tags::RESCALE_SLOPE, "RescaleSlope")
            .map_err(at)?
            .unwrap_or(1.0);
        let inter = one(tags::RESCALE_INTERCEPT, "RescaleIntercept")
            .map_err(at)?
            .unwrap_or(0.0);
        frames.push(Frame {
            file: path.to_path_buf(),
            index: f as u32,
            pos: [pos[0], pos[1], pos[2]],
            orient: core::array::from_fn(|i| orient[i]),
            spacing: [spacing[0], spacing[1]],
            rescale: (slope, inter),
        });
    }
    Ok(FileInfo {
        uid,
        layout,
        frames,
        ts,
    })
}

/// Refuses a file in which an element claims more bytes than the file holds after it,
/// or whose sequences nest deeper than [`NESTING_MAX`].
///
/// `dicom-parser` reserves and zeroes an element's stated length before reading it, so
/// a lying length (up to 4 GiB) would cost that much memory before the read fails, and
/// `dicom-object` builds nested sequences by recursion, so deep nesting would overflow
/// the stack. This walk follows the element headers as the parser reads them (the meta
/// group, then the data set with the parser's stack of open sequences and items) and
/// bounds every length by the file's size first. A deflated data set is inflated
/// (counted, then walked as a stream): its lengths are bounded by its inflated size,
/// itself bounded by the memory the process may use.
fn check_lengths(path: &Path) -> Result<()> {
    use std::io::{Read, Seek, SeekFrom};
    let io = |e: std::io::Error| Error::io(path, "can't read", e);
    let f = std::fs::File::open(path).map_err(io)?;
    let len = f.metadata().map_err(io)?.len();
    let mut r = std::io::BufReader::new(f);
    r.seek(SeekFrom::Start(132)).map_err(io)?;
    let seek = |r: &mut std::io::BufReader<std::fs::File>, n: u32| r.seek_relative(i64::from(n));
    let Some(set) = walk_meta(&mut r, len, path, seek)? else {
        return Ok(()); // `dicom-object` refuses the meta group itself
    };
    let mut file = Stream {
        pos: set.start,
        len,
        path,
        whole: "the file",
    };
    if !set.deflated {
        return walk_data_set(&mut r, &mut file, set.encoding, seek);
    }
    // The data set after the meta group is one raw deflate stream: its size first (the
    // stream is read, not kept), then its elements.
    let inflate = |e: std::io::Error| {
        Error::at(
            path,
            format!("the deflated data set can't be inflated: {e}"),
        )
    };
    r.seek(SeekFrom::Start(set.start)).map_err(io)?;
    let size = std::io::copy(
        &mut flate2::read::DeflateDecoder::new(&mut r),
        &mut std::io::sink(),
    )
    .map_err(inflate)?;
    crate::check_memory(size, "the inflated data set").map_err(|e| e.with_path(path))?;
    r.seek(SeekFrom::Start(set.start)).map_err(io)?;
    let mut d = std::io::BufReader::new(flate2::read::DeflateDecoder::new(r));
    let mut inflated = Stream {
        pos: 0,
        len: size,
        path,
        whole: "the inflated data set",
    };
    walk_data_set(&mut d, &mut inflated, Encoding::EXPLICIT_LE, |r, n| {
        let got = std::io::copy(&mut r.take(u64::from(n)), &mut std::io::sink())?;
        if got < u64::from(n) {
            return Err(std::io::ErrorKind::UnexpectedEof.into());
        }
        Ok(())
    })
}

/// Deepest nesting of sequences a DICOM file may have (real files nest a few levels;
/// `dicom-object` builds each level by recursion, ~1 kB of stack).
const NESTING_MAX: usize = 128;

/// An undefined length.
const UNDEF: u32 = 0xFFFF_FFFF;

/// How a data set's elements are encoded.
#[derive(Clone, Copy)]
struct Encoding {
    explicit: bool,
    big: bool,
}

impl Encoding {
    /// The meta group's encoding (and the deflated data set's).
    const EXPLICIT_LE: Encoding = Encoding {
        explicit: true,
        big: false,
    };

    fn u16(self, x: &[u8]) -> u16 {
        let a = [x[0], x[1]];
        if self.big {
            u16::from_be_bytes(a)
        } else {
            u16::from_le_bytes(a)
        }
    }

    fn u32(self, x: &[u8]) -> u32 {
        let a = [x[0], x[1], x[2], x[3]];
        if self.big {
            u32::from_be_bytes(a)
        } else {
            u32::from_le_bytes(a)
        }
    }
}

/// Where the data set after the meta group starts, and how it is encoded.
struct DataSet {
    start: u64,
    encoding: Encoding,
    deflated: bool,
}

/// What a walk reads: its place, its size, and names for messages.
struct Stream<'a> {
    /// Bytes read so far (in the file, or in the inflated data set).
    pos: u64,
    /// Bytes it holds.
    len: u64,
    path: &'a Path,
    /// What `len` measures, in messages.
    whole: &'a str,
}

impl Stream<'_> {
    fn io(&self, e: std::io::Error) -> Error {
        Error::io(self.path, "can't read", e)
    }

    /// Bytes left after `pos`.
    fn left(&self) -> u64 {
        self.len.saturating_sub(self.pos)
    }

    /// An error unless `l` (an element's, item's or delimiter's length) fits in what is
    /// left.
    fn bound(&self, h: &Head) -> Result<()> {
        if h.len != UNDEF && u64::from(h.len) > self.left() {
            return Err(Error::at(
                self.path,
                format!(
                    "element ({:04X},{:04X}) claims {} bytes; {} has {} left",
                    h.tag.0,
                    h.tag.1,
                    h.len,
                    self.whole,
                    self.left()
                ),
            ));
        }
        Ok(())
    }
}

/// An element, item or delimiter header as `dicom-encoding` decodes it.
struct Head {
    tag: (u16, u16),
    vr: dicom_core::VR,
    len: u32,
}

/// Reads the header at `s.pos` in encoding `enc` (advancing `s.pos`), as
/// `dicom-encoding` decodes an element header: item and delimiter tags (group FFFE)
/// have a 4-byte length and no VR; an explicit VR is one of two forms; an implicit VR
/// comes from the dictionary. None when the stream ends first.
fn read_head<R: std::io::Read>(r: &mut R, s: &mut Stream, enc: Encoding) -> Result<Option<Head>> {
    use dicom_core::dictionary::{DataDictionary, DataDictionaryEntry};
    use dicom_core::VR;
    if s.left() < 8 {
        return Ok(None);
    }
    let mut b = [0u8; 8];
    r.read_exact(&mut b).map_err(|e| s.io(e))?;
    s.pos += 8;
    let tag = (enc.u16(&b), enc.u16(&b[2..]));
    if tag.0 == 0xFFFE {
        let len = enc.u32(&b[4..]);
        return Ok(Some(Head {
            tag,
            vr: VR::UN,
            len,
        }));
    }
    if !enc.explicit {
        // OW for pixel and overlay data, the first of a choice, UN for an unknown tag.
        let vr = if tag == (0x7FE0, 0x0010) || (tag.0 >> 8 == 0x60 && tag.1 == 0x3000) {
            VR::OW
        } else {
            dicom_dictionary_std::StandardDataDictionary
                .by_tag(dicom_object::Tag(tag.0, tag.1))
                .map_or(VR::UN, |d| d.vr().relaxed())
        };
        let len = enc.u32(&b[4..]);
        return Ok(Some(Head { tag, vr, len }));
    }
    // These VRs have a 2-byte length; every other, an unknown one included (read as
    // UN), 2 reserved bytes and a 4-byte length.
    let vr = VR::from_binary([b[4], b[5]]).unwrap_or(VR::UN);
    let short = matches!(
        vr,
        VR::AE
            | VR::AS
            | VR::AT
            | VR::CS
            | VR::DA
            | VR::DS
            | VR::DT
            | VR::FL
            | VR::FD
            | VR::IS
            | VR::LO
            | VR::LT
            | VR::PN
            | VR::SH
            | VR::SL
            | VR::SS
            | VR::ST
            | VR::TM
            | VR::UI
            | VR::UL
            | VR::US
    );
    let len = if short {
        u32::from(enc.u16(&b[6..]))
    } else {
        if s.left() < 4 {
            return Ok(None);
        }
        let mut x = [0u8; 4];
        r.read_exact(&mut x).map_err(|e| s.io(e))?;
        s.pos += 4;
        enc.u32(&x)
    };
    Ok(Some(Head { tag, vr, len }))
}

/// The file meta group from just after `DICM`, as `dicom-object` reads it: the group
/// length (0002,0000) first, then elements (each value read whole) until their bytes
/// reach it. Where the data set starts and how it is encoded; None when `dicom-object`
/// refuses the meta group.
fn walk_meta<R: std::io::Read>(
    r: &mut R,
    len: u64,
    path: &Path,
    mut skip: impl FnMut(&mut R, u32) -> std::io::Result<()>,
) -> Result<Option<DataSet>> {
    let enc = Encoding::EXPLICIT_LE;
    let mut s = Stream {
        pos: 132,
        len,
        path,
        whole: "the file",
    };
    let first = read_head(r, &mut s, enc)?;
    if first.is_none_or(|h| h.tag != (2, 0) || h.len != 4) || s.left() < 4 {
        return Ok(None);
    }
    let mut v = [0u8; 4];
    r.read_exact(&mut v).map_err(|e| s.io(e))?;
    s.pos += 4;
    let group = u32::from_le_bytes(v);
    let mut ts: Option<String> = None;
    let mut read = 0u32;
    while read < group {
        let at = s.pos;
        let Some(h) = read_head(r, &mut s, enc)? else {
            return Ok(None);
        };
        if h.len == UNDEF {
            return Ok(None);
        }
        s.bound(&h)?;
        if h.tag == (0x0002, 0x0010) {
            // The registry matches the UID with trailing whitespace and NULs trimmed,
            // however long the padding: what counts is its first 64 bytes (a UID's
            // most) and whether the rest is all padding.
            let mut uid = vec![0u8; h.len.min(64) as usize];
            r.read_exact(&mut uid).map_err(|e| s.io(e))?;
            let (mut rest, mut padded) = (h.len as usize - uid.len(), true);
            let mut buf = [0u8; 4096];
            while rest > 0 {
                let k = rest.min(buf.len());
                r.read_exact(&mut buf[..k]).map_err(|e| s.io(e))?;
                padded &= buf[..k]
                    .iter()
                    .all(|&b| b == 0 || char::from(b).is_whitespace());
                rest -= k;
            }
            ts = padded.then(|| String::from_utf8_lossy(&uid).into_owned());
        } else {
            skip(r, h.len).map_err(|e| s.io(e))?;
        }
        s.pos += u64::from(h.len);
        let size = u32::try_from(s.pos - at).unwrap_or(u32::MAX);
        read = read.saturating_add(size);
    }
    // The data set's encoding, as `dicom-object` takes it from the registry: a syntax
    // it does not know, or cannot read, is refused.
    use dicom_transfer_syntax_registry::TransferSyntaxIndex;
    let Some(syntax) = ts
        .as_deref()
        .and_then(|u| dicom_transfer_syntax_registry::TransferSyntaxRegistry.get(u))
    else {
        return Ok(None);
    };
    if !syntax.can_decode_dataset() {
        return Ok(None);
    }
    Ok(Some(DataSet {
        start: s.pos,
        encoding: Encoding {
            explicit: syntax.uid() != "1.2.840.10008.1.2",
            big: syntax.uid() == "1.2.840.10008.1.2.2",
        },
        // A data set read through an adapter (deflate): Deflated Explicit VR Little
        // Endian, and the JPIP Referenced Deflate syntaxes.
        deflated: !syntax.is_codec_free() && !syntax.is_encapsulated_pixel_data(),
    }))
}

/// A sequence or item the parser has open (its stack of delimiters).
#[derive(Clone, Copy)]
struct Open {
    item: bool,
    /// Its length (or [`UNDEF`]).
    len: u32,
    /// The parser's count where its content starts.
    base: u64,
    /// Pixel data fragments (or one of them).
    pixel: bool,
}

/// The data set from `s.pos` in encoding `enc`, read as `dicom-parser`'s
/// `DataSetReader` reads it (`skip` passing over a value): every length it reserves is
/// bounded by the bytes left, and sequences nest at most [`NESTING_MAX`] deep. Where the
/// parser would stop with an error (a bad item header, an item running past its
/// sequence, the end of the data), the walk stops too and leaves the error to it.
///
/// The parser keeps two places: the bytes it has read (`s.pos`) and its count (`at`),
/// which for a value of numbers adds the stated length though only whole numbers are
/// read. The count decides where a defined-length sequence or item ends; the bytes
/// where the next header is read.
fn walk_data_set<R: std::io::Read>(
    r: &mut R,
    s: &mut Stream,
    enc: Encoding,
    mut skip: impl FnMut(&mut R, u32) -> std::io::Result<()>,
) -> Result<()> {
    use dicom_core::dictionary::{DataDictionary, DataDictionaryEntry, VirtualVr};
    use dicom_core::VR;
    let mut at = s.pos;
    let mut open: Vec<Open> = Vec::new();
    // The parser's flags: at a sequence's level (an item header next), a check for a
    // defined length's end due, the pixel data's first item (or delimiter) next, the
    // offset table next; and PixelRepresentation, when read, signed.
    let (mut in_seq, mut check, mut pixel_next, mut table_next) = (false, false, false, false);
    let mut signed: Option<bool> = None;
    let mut pass = |r: &mut R, s: &mut Stream, n: u32| {
        skip(r, n).map_err(|e| s.io(e))?;
        s.pos += u64::from(n);
        Ok::<(), Error>(())
    };
    let deep = |s: &Stream, open: &[Open]| {
        if open.len() >= 2 * NESTING_MAX {
            return Err(Error::at(
                s.path,
                format!("sequences nest more than {NESTING_MAX} deep"),
            ));
        }
        Ok(())
    };
    loop {
        if check {
            // A defined length ends where the count reaches it; the count past it is an
            // error.
            if let Some(o) = open.last().filter(|o| o.len != UNDEF) {
                let end = o.base + u64::from(o.len);
                if end < at {
                    return Ok(());
                }
                if end == at {
                    in_seq = o.item;
                    open.pop();
                    continue;
                }
            }
            check = false;
        }
        if in_seq || pixel_next {
            // An item header (or a delimiter) comes next.
            let first = pixel_next;
            if first {
                pixel_next = false;
                open.push(Open {
                    item: false,
                    len: UNDEF,
                    base: at,
                    pixel: true,
                });
            }
            if s.left() < 8 {
                return Ok(());
            }
            let mut b = [0u8; 8];
            r.read_exact(&mut b).map_err(|e| s.io(e))?;
            s.pos += 8;
            at += 8;
            let h = Head {
                tag: (enc.u16(&b), enc.u16(&b[2..])),
                vr: VR::UN,
                len: enc.u32(&b[4..]),
            };
            match h.tag {
                (0xFFFE, 0xE000) => {
                    let Some(pixel) = open.last().map(|o| o.pixel) else {
                        return Ok(());
                    };
                    s.bound(&h)?;
                    deep(s, &open)?;
                    in_seq = false;
                    open.push(Open {
                        item: true,
                        len: h.len,
                        base: at,
                        pixel,
                    });
                    if h.len == 0 {
                        check = true;
                    } else if first {
                        table_next = true;
                    }
                }
                (0xFFFE, 0xE00D) if h.len == 0 && !first => {
                    open.pop();
                    in_seq = true;
                    check = true;
                }
                (0xFFFE, 0xE0DD) => {
                    open.pop();
                    in_seq = false;
                    check = !first;
                }
                _ => return Ok(()),
            }
            continue;
        }
        if let Some(o) = open.last().filter(|o| o.item && o.pixel) {
            // A fragment's bytes (the first, the offset table, read as whole u32s).
            if o.len == UNDEF {
                return Ok(());
            }
            let n = if table_next { o.len & !3 } else { o.len };
            table_next = false;
            // A fragment is read as far as the data goes and counted whole. (Only after
            // an offset table whose length is not a multiple of 4 is a fragment read a
            // second time, and can run past the end; the count then passes the item's.)
            pass(r, s, n.min(u32::try_from(s.left()).unwrap_or(u32::MAX)))?;
            at += u64::from(n);
            check = true;
            continue;
        }
        // An element header: a sequence, a delimiter, pixel fragments, or a value.
        let before = s.pos;
        let Some(mut h) = read_head(r, s, enc)? else {
            return Ok(());
        };
        at += s.pos - before;
        let xs = || {
            dicom_dictionary_std::StandardDataDictionary
                .by_tag(dicom_object::Tag(h.tag.0, h.tag.1))
                .is_some_and(|d| matches!(d.vr(), VirtualVr::Xs))
        };
        if signed == Some(true) && xs() {
            // "US or SS" read as SS for signed pixels.
            h.vr = VR::SS;
        }
        if h.vr == VR::SQ {
            s.bound(&h)?;
            deep(s, &open)?;
            in_seq = true;
            open.push(Open {
                item: false,
                len: h.len,
                base: at,
                pixel: false,
            });
            check = h.len == 0;
            continue;
        }
        if h.tag == (0xFFFE, 0xE00D) {
            // An item delimiter: ignored outside any sequence.
            if open.pop().is_some() {
                in_seq = true;
                check = true;
            }
            continue;
        }
        if h.len == UNDEF {
            if h.tag == (0x7FE0, 0x0010) {
                pixel_next = true;
            } else {
                // Read as a sequence, whatever its VR.
                deep(s, &open)?;
                in_seq = true;
                open.push(Open {
                    item: false,
                    len: UNDEF,
                    base: at,
                    pixel: false,
                });
            }
            continue;
        }
        s.bound(&h)?;
        if h.len > 0 {
            // A value of numbers is read as whole numbers (the rest is left unread) but
            // counted whole.
            let n = h.len - h.len % value_size(h.vr);
            if h.tag == (0x0028, 0x0103) && matches!(h.vr, VR::US | VR::OW) {
                // PixelRepresentation: nonzero makes later "US or SS" values SS.
                signed = None;
                if n >= 2 {
                    let mut v = [0u8; 2];
                    r.read_exact(&mut v).map_err(|e| s.io(e))?;
                    s.pos += 2;
                    signed = Some(enc.u16(&v) != 0);
                    pass(r, s, n - 2)?;
                }
            } else {
                pass(r, s, n)?;
            }
            at += u64::from(h.len);
        }
        check = true;
    }
}

/// Bytes per value of `vr` as `dicom-parser` reads a data set's values: numbers and
/// tags whole (1 for text and bytes).
fn value_size(vr: dicom_core::VR) -> u32 {
    use dicom_core::VR;
    match vr {
        VR::US | VR::SS | VR::OW => 2,
        VR::AT | VR::UL | VR::SL | VR::FL | VR::OL | VR::OF => 4,
        VR::FD | VR::OD | VR::SV | VR::UV | VR::OV => 8,
        _ => 1,
    }
}

/// True when `path` starts like a DICOM Part 10 file (preamble + `DICM`).
fn is_dicom(path: &Path) -> bool {
    use std::io::Read;
    let mut b = [0u8; 132];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut b))
        .is_ok()
        && &b[128..] == b"DICM"
}

/// Reads the series `path` names (a directory, or one file of the series).
pub(super) fn read(path: &Path) -> Result<Loaded> {
    let (dir, only) = if path.is_dir() {
        (path.to_path_buf(), None)
    } else {
        let uid = frames_of(path)?.uid;
        // (A bare file name's parent is "": the current directory.)
        let dir = path.parent().filter(|d| !d.as_os_str().is_empty());
        (dir.unwrap_or(Path::new(".")).to_path_buf(), Some(uid))
    };
    let files = series_files(&dir)?;
    if files.is_empty() {
        return Err(Error::at(&dir, "holds no DICOM files"));
    }
    // The images beside it: those of the file's series, or of the one series of a
    // directory. Other series, and objects without pixels (reports, presentation
    // states), are passed over; a file that can't be parsed at all is an error, and
    // so is a slice of the series read that is not one.
    let mut found: Vec<(String, Result<FileInfo>)> = Vec::new();
    for f in files {
        let h = header_of(&f)?;
        if h.is_image() && only.as_ref().is_none_or(|u| *u == h.uid) {
            found.push((h.uid.clone(), image_of(&f, &h)));
        }
    }
    if found.is_empty() {
        return Err(Error::at(&dir, "holds no DICOM images"));
    }
    let mut uids: Vec<&str> = Vec::new();
    for (uid, _) in &found {
        if !uids.contains(&uid.as_str()) {
            uids.push(uid);
        }
    }
    let want = match only {
        Some(uid) => uid,
        None if uids.len() == 1 => uids[0].to_string(),
        None => {
            return Err(Error::at(
                &dir,
                format!(
                    "holds {} DICOM series ({}); name one file of the series to read",
                    uids.len(),
                    uids.join(", ")
                ),
            ))
        }
    };
    let parts = found
        .into_iter()
        .filter(|(uid, _)| *uid == want)
        .map(|(_, info)| info)
        .collect::<Result<Vec<FileInfo>>>()?;
    let nfiles = parts.len();
    let Some(layout) = parts.first().map(|p| p.layout.clone()) else {
        return Err(Error::at(
            path,
            "no DICOM file of its series in its folder (files need the DICM preamble)",
        ));
    };
    let mut frames: Vec<Frame> = Vec::new();
    let mut syntaxes: Vec<String> = Vec::new();
    for p in parts {
        if p.layout != layout {
            return Err(Error::at(
                &p.frames[0].file,
                format!(
                    "its slices are {:?}, the series' first are {layout:?}",
                    p.layout
                ),
            ));
        }
        if !syntaxes.contains(&p.ts) {
            syntaxes.push(p.ts);
        }
        frames.extend(p.frames);
    }
    let (dirs, origin, notes) = geometry(&mut frames)?;
    let data = pixels(&frames, &layout)?;
    let mut notes = notes;
    notes.insert(
        0,
        format!(
            "DICOM series of {} slices ({} file{}; transfer syntax {})",
            frames.len(),
            nfiles,
            if nfiles == 1 { "" } else { "s" },
            syntaxes
                .iter()
                .map(|u| syntax_name(u))
                .collect::<Vec<_>>()
                .join(", ")
        ),
    );
    let rescales: Vec<(f64, f64)> = frames.iter().map(|f| f.rescale).collect();
    let data = if rescales.iter().all(|r| *r == rescales[0]) {
        let (d, note) = super::rescale(data, rescales[0].0, rescales[0].1)?;
        notes.extend(note.map(|s| format!("RescaleSlope/Intercept: {s}")));
        d
    } else {
        notes.push("slices have different RescaleSlope/Intercept: each applied, into float".into());
        let per = (layout.rows * layout.cols) as usize;
        let v = data.to_f64();
        Data::F32(
            v.iter()
                .enumerate()
                .map(|(i, &x)| {
                    let (s, b) = rescales[i / per];
                    (x * s + b) as f32
                })
                .collect(),
        )
    };
    let sizes = [layout.cols as usize, layout.rows as usize, frames.len()];
    let nrrd = super::volume_nrrd(sizes, data, "left-posterior-superior", dirs, origin)?;
    Ok(Loaded {
        nrrd,
        format: Format::Dicom,
        notes,
    })
}

/// The DICOM files directly in `dir` (DICOMDIR and other files skipped), sorted by name
/// only so errors are reproducible.
fn series_files(dir: &Path) -> Result<Vec<PathBuf>> {
    let rd = std::fs::read_dir(dir).map_err(|e| Error::io(dir, "can't list", e))?;
    let mut out = Vec::new();
    for e in rd {
        let p = e.map_err(|e| Error::io(dir, "can't list", e))?.path();
        let dicomdir = p
            .file_name()
            .is_some_and(|n| n.eq_ignore_ascii_case("DICOMDIR"));
        if p.is_file() && !dicomdir && is_dicom(&p) {
            out.push(p);
            if out.len() > FILES_MAX {
                return Err(Error::at(
                    dir,
                    format!("holds more than {FILES_MAX} DICOM files"),
                ));
            }
        }
    }
    out.sort();
    Ok(out)
}

fn syntax_name(uid: &str) -> String {
    use dicom_transfer_syntax_registry::TransferSyntaxIndex;
    match dicom_transfer_syntax_registry::TransferSyntaxRegistry.get(uid) {
        Some(ts) => format!("{} ({uid})", ts.name()),
        None => uid.to_string(),
    }
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Sorts the frames along the normal and checks their spacing; the index-to-world
/// columns, origin and notes.
fn geometry(frames: &mut [Frame]) -> Result<Placed> {
    let f0 = frames[0].clone();
    let close = |a: &[f64], b: &[f64], tol: f64| a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol);
    for f in frames.iter() {
        if !close(&f.orient, &f0.orient, 1e-4)
            || !close(&f.spacing, &f0.spacing, 1e-6 * f0.spacing[0].abs().max(1.0))
        {
            return Err(Error::at(
                &f.file,
                "its ImageOrientationPatient or PixelSpacing differs from the series' other slices",
            ));
        }
    }
    let r = [f0.orient[0], f0.orient[1], f0.orient[2]];
    let c = [f0.orient[3], f0.orient[4], f0.orient[5]];
    let n = cross(r, c);
    let nl = dot(n, n).sqrt();
    if !(nl > 0.5) || (dot(r, r).sqrt() - 1.0).abs() > 1e-3 || (dot(c, c).sqrt() - 1.0).abs() > 1e-3
    {
        return Err(Error::at(
            &f0.file,
            "ImageOrientationPatient is not two unit vectors at a right angle",
        ));
    }
    let n = n.map(|x| x / nl);
    frames.sort_by(|a, b| dot(a.pos, n).total_cmp(&dot(b.pos, n)));
    let mut notes = Vec::new();
    let k = frames.len();
    let step = if k == 1 {
        notes.push("one slice: slice spacing taken as the in-plane row spacing".into());
        n.map(|x| x * f0.spacing[0])
    } else {
        let d: Vec<f64> = frames
            .windows(2)
            .map(|w| dot(w[1].pos, n) - dot(w[0].pos, n))
            .collect();
        let mean = (dot(frames[k - 1].pos, n) - dot(frames[0].pos, n)) / (k - 1) as f64;
        if let Some(i) = d
            .iter()
            .position(|&x| x.abs() <= 1e-6 * mean.abs().max(1e-3))
        {
            return Err(Error::at(
                &frames[i + 1].file,
                format!(
                    "two slices at one position ({:?}); the folder mixes acquisitions?",
                    frames[i].pos
                ),
            ));
        }
        let tol = 1e-3 * mean.abs();
        if let Some(i) = d.iter().position(|&x| (x - mean).abs() > tol) {
            let lo = d.iter().cloned().fold(f64::INFINITY, f64::min);
            let hi = d.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            return Err(Error::at(
                &frames[i + 1].file,
                format!(
                    "uneven slice spacing: {lo:.6} to {hi:.6} along the normal (mean {mean:.6}); \
                     a slice missing? rendr reads evenly spaced series only"
                ),
            ));
        }
        let p0 = frames[0].pos;
        let pk = frames[k - 1].pos;
        let step: [f64; 3] = core::array::from_fn(|i| (pk[i] - p0[i]) / (k - 1) as f64);
        let off = cross(step, n);
        if dot(off, off).sqrt() > 1e-4 * mean.abs() {
            notes.push("slice positions step off the normal (gantry tilt): a sheared grid".into());
        }
        step
    };
    let dirs = [
        r.map(|x| x * f0.spacing[1]),
        c.map(|x| x * f0.spacing[0]),
        step,
    ];
    Ok((dirs, frames[0].pos, notes))
}

/// The RLE Lossless transfer syntax.
const RLE_LOSSLESS: &str = "1.2.840.10008.1.2.5";

/// RLE Lossless pixel data of `o`, checked before `dicom-pixeldata` decodes it: its
/// decoder trusts the fragments' headers and the segments' decoded lengths (a fragment
/// shorter than its 64-byte header, a segment count past it, or a segment that decodes
/// to fewer than Rows x Columns bytes makes it panic or allocate by the count), so
/// those are errors here.
fn check_rle(o: &InMemDicomObject) -> Result<()> {
    let bad = |m: String| Err(Error::msg(format!("RLE pixel data: {m}")));
    let (Some(rows), Some(cols), Some(bits)) = (
        int(o, tags::ROWS, "Rows")?,
        int(o, tags::COLUMNS, "Columns")?,
        int(o, tags::BITS_ALLOCATED, "BitsAllocated")?,
    ) else {
        // The decoder refuses an image without them.
        return Ok(());
    };
    let spp = int(o, tags::SAMPLES_PER_PIXEL, "SamplesPerPixel")?.unwrap_or(1);
    let (Ok(rows), Ok(cols), Ok(spp)) = (
        u16::try_from(rows),
        u16::try_from(cols),
        usize::try_from(spp),
    ) else {
        return bad(format!(
            "Rows {rows}, Columns {cols} or SamplesPerPixel {spp} out of range"
        ));
    };
    let plane = usize::from(rows) * usize::from(cols);
    let segments = spp.saturating_mul(usize::try_from(bits / 8).unwrap_or(0));
    let Some(dicom_core::DicomValue::PixelSequence(seq)) =
        elem(o, tags::PIXEL_DATA).map(|e| e.value())
    else {
        // Not encapsulated: the decoder says so.
        return Ok(());
    };
    for (i, f) in seq.fragments().iter().enumerate() {
        let word = |j: usize| {
            f.get(4 * j..4 * j + 4)
                .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
        };
        let Some(n) = word(0).filter(|_| f.len() >= 64) else {
            return bad(format!(
                "frame {i}: {} bytes, shorter than the 64-byte RLE header",
                f.len()
            ));
        };
        if n > 15 || n < segments {
            return bad(format!(
                "frame {i}: {n} segments where {segments} are needed (at most 15)"
            ));
        }
        for s in 0..segments {
            let end = if s + 1 < n {
                word(s + 2)
            } else {
                Some(f.len())
            };
            let got = match (word(s + 1), end) {
                (Some(a), Some(b)) => f.get(a..b).and_then(packbits_len),
                _ => None,
            };
            match got {
                None => return bad(format!("frame {i}: segment {s} lies outside its fragment or is cut short")),
                Some(g) if g < plane => {
                    return bad(format!(
                        "frame {i}: segment {s} decodes to {g} bytes, fewer than Rows x Columns ({plane})"
                    ))
                }
                Some(_) => {}
            }
        }
    }
    Ok(())
}

/// The JPEG transfer syntaxes `dicom-transfer-syntax-registry`'s JPEG adapter decodes:
/// baseline, extended, lossless, lossless first-order.
const JPEG: [&str; 4] = [
    "1.2.840.10008.1.2.4.50",
    "1.2.840.10008.1.2.4.51",
    "1.2.840.10008.1.2.4.57",
    "1.2.840.10008.1.2.4.70",
];

/// JPEG pixel data of `o`, checked before `dicom-pixeldata` decodes it: its JPEG
/// adapter sizes its output by Rows x Columns x SamplesPerPixel x frames and copies
/// each decoded frame in without comparing (a frame whose JPEG header is larger made it
/// panic). The frames are read here as the adapter reads them, one JPEG stream after
/// another in the joined fragments, with the same decoder, and each one's size is
/// checked from its header before it is decoded, and after. Where the decoder fails,
/// the adapter fails too; that is left to it.
fn check_jpeg(o: &InMemDicomObject) -> Result<()> {
    let bad = |m: String| Err(Error::msg(format!("JPEG pixel data: {m}")));
    let u16_of = |tag| elem(o, tag).and_then(|e| e.uint16().ok());
    let (Some(rows), Some(cols), Some(spp), Some(bits)) = (
        u16_of(tags::ROWS),
        u16_of(tags::COLUMNS),
        u16_of(tags::SAMPLES_PER_PIXEL),
        u16_of(tags::BITS_ALLOCATED),
    ) else {
        return Ok(()); // the adapter refuses the image
    };
    if bits != 8 && bits != 16 {
        return Ok(());
    }
    let frames = elem(o, tags::NUMBER_OF_FRAMES)
        .and_then(|e| e.to_int::<u32>().ok())
        .unwrap_or(1);
    let Some(dicom_core::DicomValue::PixelSequence(seq)) =
        elem(o, tags::PIXEL_DATA).map(|e| e.value())
    else {
        return Ok(()); // not encapsulated: the decoder says so
    };
    let per = u64::from(spp) * u64::from(bits / 8) * u64::from(rows) * u64::from(cols);
    let room = per.saturating_mul(u64::from(frames));
    let data: Vec<u8> = seq.fragments().iter().flatten().copied().collect();
    let len = data.len() as u64;
    let next_even = |x: u64| (x + 1) & !1;
    let mut cur = std::io::Cursor::new(&data[..]);
    let mut used = 0u64;
    for i in 0..frames {
        let mut d = jpeg_decoder::Decoder::new(&mut cur);
        let Some(info) = d.read_info().ok().and_then(|_| d.info()) else {
            return Ok(());
        };
        let claim =
            u64::from(info.width) * u64::from(info.height) * info.pixel_format.pixel_bytes() as u64;
        let too_big = |n: u64| {
            bad(format!(
                "frame {i} is a {} x {} JPEG of {n} bytes; Rows x Columns x SamplesPerPixel \
                 x BitsAllocated/8 is {per} ({cols} x {rows} x {spp} x {})",
                info.width,
                info.height,
                bits / 8
            ))
        };
        if used + claim > room {
            return too_big(claim);
        }
        let Ok(px) = d.decode() else {
            return Ok(());
        };
        if used + px.len() as u64 > room {
            return too_big(px.len() as u64);
        }
        used += px.len() as u64;
        // The next frame starts at the next SOI marker, as the adapter finds it.
        if next_even(cur.position()) >= next_even(len) || cur.position() + 2 >= len {
            break;
        }
        loop {
            let p = cur.position() as usize;
            match (data.get(p), data.get(p + 1)) {
                (Some(0xFF), Some(0xD8)) => break,
                (Some(_), Some(_)) => cur.set_position(cur.position() + 1),
                _ => return Ok(()),
            }
        }
    }
    Ok(())
}

/// How many bytes PackBits data decodes to, as `dicom-pixeldata`'s RLE reader decodes
/// it (a literal run cut short by the end counts what is there); None when a replicate
/// run lacks its byte.
fn packbits_len(seg: &[u8]) -> Option<usize> {
    let (mut i, mut out) = (0usize, 0usize);
    while i < seg.len() {
        let h = seg[i] as i8;
        i += 1;
        match h {
            -128 => {}
            -127..=-1 => {
                seg.get(i)?;
                i += 1;
                out += (1 - isize::from(h)) as usize;
            }
            _ => {
                let n = h as usize + 1;
                out += n.min(seg.len() - i);
                i += n;
            }
        }
    }
    Some(out)
}

/// The stored pixel values of every frame, in order, in their own type.
fn pixels(frames: &[Frame], l: &Layout) -> Result<Data> {
    let per = (l.rows as usize) * (l.cols as usize);
    let n = per
        .checked_mul(frames.len())
        .ok_or_else(|| Error::msg("the series is too large"))?;
    let bytes = (n as u64).saturating_mul(u64::from(l.bits / 8));
    crate::check_memory(
        bytes,
        &format!("{} slices of {} x {}", frames.len(), l.cols, l.rows),
    )?;
    let mut data = match (l.bits, l.signed) {
        (8, false) => Data::U8(Vec::new()),
        (8, true) => Data::I8(Vec::new()),
        (16, false) => Data::U16(Vec::new()),
        (16, true) => Data::I16(Vec::new()),
        (32, false) => Data::U32(Vec::new()),
        _ => Data::I32(Vec::new()),
    };
    crate::nrrd::each_data!(&mut data, v => crate::try_reserve(v, n, "the slices")?);
    let raw = ConvertOptions::new().with_modality_lut(ModalityLutOption::None);
    let mut open: Option<(PathBuf, dicom_object::DefaultDicomObject)> = None;
    for f in frames {
        if open.as_ref().map(|(p, _)| p) != Some(&f.file) {
            let obj = dicom_object::open_file(&f.file)
                .map_err(|e| Error::at(&f.file, format!("not a readable DICOM file: {e}")))?;
            open = Some((f.file.clone(), obj));
        }
        let (_, obj) = open.as_ref().expect("opened above");
        let ts = obj.meta().transfer_syntax().trim_end_matches('\0');
        if ts == RLE_LOSSLESS {
            check_rle(obj).map_err(|e| e.with_path(&f.file))?;
        }
        if JPEG.contains(&ts) {
            check_jpeg(obj).map_err(|e| e.with_path(&f.file))?;
        }
        let dec = obj.decode_pixel_data().map_err(|e| {
            Error::at(
                &f.file,
                format!(
                    "can't decode pixel data in transfer syntax {}: {e}",
                    syntax_name(ts)
                ),
            )
        })?;
        if dec.rows() != l.rows || dec.columns() != l.cols {
            return Err(Error::at(
                &f.file,
                "decoded pixel data does not match Rows x Columns",
            ));
        }
        let bad = |e: dicom_pixeldata::Error| Error::at(&f.file, format!("pixel data: {e}"));
        macro_rules! take {
            ($v:expr, $t:ty) => {{
                let px: Vec<$t> = dec.to_vec_frame_with_options(f.index, &raw).map_err(bad)?;
                if px.len() != per {
                    return Err(Error::at(
                        &f.file,
                        "pixel data is shorter than Rows x Columns",
                    ));
                }
                $v.extend_from_slice(&px);
            }};
        }
        match &mut data {
            Data::U8(v) => take!(v, u8),
            Data::I8(v) => take!(v, i8),
            Data::U16(v) => take!(v, u16),
            Data::I16(v) => take!(v, i16),
            Data::U32(v) => take!(v, u32),
            Data::I32(v) => take!(v, i32),
            _ => return Err(Error::msg("DICOM: no reader for this sample type")),
        }
    }
    Ok(data)
}

/// The DICOM files reading `path` reads (a directory's slices).
pub(super) fn input_files(path: &Path) -> Vec<PathBuf> {
    let dir = if path.is_dir() {
        Some(path)
    } else if is_dicom(path) {
        path.parent()
    } else {
        None
    };
    dir.and_then(|d| series_files(d).ok()).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::{check_lengths, packbits_len};

    /// A Part 10 file: preamble, `DICM`, a meta group (group length first) naming
    /// transfer syntax `ts`, then `rest`.
    fn part10(ts: &str, rest: &[u8]) -> Vec<u8> {
        let short = |e: u16, v: &[u8]| {
            let mut x = vec![2, 0];
            x.extend(e.to_le_bytes());
            x.extend(b"UI");
            x.extend((v.len() as u16).to_le_bytes());
            x.extend(v);
            x
        };
        let mut uid = ts.as_bytes().to_vec();
        if uid.len() % 2 == 1 {
            uid.push(0);
        }
        let body = short(0x10, &uid);
        let mut f = vec![0u8; 128];
        f.extend(b"DICM");
        f.extend([2, 0, 0, 0]);
        f.extend(b"UL");
        f.extend(4u16.to_le_bytes());
        f.extend((body.len() as u32).to_le_bytes());
        f.extend(body);
        f.extend(rest);
        f
    }

    /// A value of numbers whose length is not a multiple of their size: the parser
    /// reads whole numbers and the next header where they end, so the walk does too.
    /// Here (0019,0010) SL of 6 bytes leaves 2 unread; read from there, the next
    /// element (1010,424F) LO of 4 bytes is (0009,1010) OB claiming 1 GiB.
    #[test]
    fn numbers_are_read_whole_as_the_parser_reads_them() {
        let mut rest = vec![0x19, 0, 0x10, 0, b'S', b'L', 6, 0, 1, 2, 3, 4];
        rest.extend([9, 0]); // the 2 bytes past the last whole number
        rest.extend([0x10, 0x10, b'O', b'B', b'L', b'O', 4, 0, 0, 0x40, 0, 0]);
        let m = check_bytes("whole", &part10("1.2.840.10008.1.2.1", &rest)).unwrap_err();
        assert!(
            m.contains("element (0009,1010) claims 1073741828 bytes; the file has 2 left"),
            "{m}"
        );
        // Whole numbers: nothing left unread, nothing claimed past the end.
        let mut rest = vec![0x19, 0, 0x10, 0, b'S', b'L', 8, 0, 1, 2, 3, 4, 5, 6, 7, 8];
        rest.extend([0x10, 0x10, b'O', b'B', b'L', b'O', 4, 0, 0, 0x40, 0, 0]);
        assert_eq!(
            check_bytes("whole", &part10("1.2.840.10008.1.2.1", &rest)),
            Ok(())
        );
    }

    /// The length walk of a deflated data set: an honest one passes, one whose element
    /// claims more than the inflated data set holds is refused, and a stream that does
    /// not inflate is an error saying so.
    #[test]
    fn deflated_data_sets_are_walked_inflated() {
        use std::io::Write;
        let deflate = |b: &[u8]| {
            let mut e = flate2::write::DeflateEncoder::new(Vec::new(), Default::default());
            e.write_all(b).unwrap();
            e.finish().unwrap()
        };
        // (0009,1010) OB with a 4-byte length of 4, then its 4 bytes.
        let element = |claim: u32| {
            let mut x = vec![9, 0, 0x10, 0x10];
            x.extend(b"OB\0\0");
            x.extend(claim.to_le_bytes());
            x.extend([1, 2, 3, 4]);
            x
        };
        let ts = "1.2.840.10008.1.2.1.99";
        let check = |bytes: Vec<u8>| check_bytes("deflated", &bytes);
        assert_eq!(check(part10(ts, &deflate(&element(4)))), Ok(()));
        let m = check(part10(ts, &deflate(&element(1 << 30)))).unwrap_err();
        assert!(
            m.contains(
                "element (0009,1010) claims 1073741824 bytes; the inflated data set has 4 left"
            ),
            "{m}"
        );
        // JPIP Referenced Deflate: its data set is deflated too.
        let m = check(part10(
            "1.2.840.10008.1.2.4.95",
            &deflate(&element(1 << 30)),
        ))
        .unwrap_err();
        assert!(m.contains("the inflated data set has 4 left"), "{m}");
        // Not compressed: the same element read as deflate data.
        let m = check(part10(ts, &element(4))).unwrap_err();
        assert!(m.contains("the deflated data set can't be inflated"), "{m}");
        // Explicit VR little endian, not deflated: the claim is bounded by the file.
        let m = check(part10("1.2.840.10008.1.2.1", &element(1 << 30))).unwrap_err();
        assert!(
            m.contains("claims 1073741824 bytes; the file has 4 left"),
            "{m}"
        );
    }

    /// `bytes` written as `f.dcm` in a fresh folder of its own, removed when dropped.
    struct Scratch {
        dir: std::path::PathBuf,
        file: std::path::PathBuf,
    }

    impl Scratch {
        fn new(name: &str, bytes: &[u8]) -> Scratch {
            let dir = std::env::temp_dir().join(format!("rnd-dicom-{name}-{}", std::process::id()));
            std::fs::create_dir_all(&dir).unwrap();
            let file = dir.join("f.dcm");
            std::fs::write(&file, bytes).unwrap();
            Scratch { dir, file }
        }
    }

    impl Drop for Scratch {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.dir);
        }
    }

    /// The length walk of `bytes` read as a file.
    fn check_bytes(name: &str, bytes: &[u8]) -> Result<(), String> {
        check_lengths(&Scratch::new(name, bytes).file).map_err(|e| e.to_string())
    }

    /// `bytes` read as a file by dicom-object itself, the parser the walk models.
    fn parsed(name: &str, bytes: &[u8]) -> Result<dicom_object::DefaultDicomObject, String> {
        dicom_object::open_file(&Scratch::new(name, bytes).file).map_err(|e| format!("{e:?}"))
    }

    /// An item or sequence delimiter header where an element is expected (outside any
    /// sequence, or after an item ends by its length) is read by the parser as an
    /// element with a value of its length, and the next header after that value (the
    /// formats fuzz target found a DICOM whose walk took such an item header as an item
    /// and missed a 1.4 GB claim). Here the header's 12 bytes hide, from a walk that
    /// reads them as headers, the next element: (0009,1010) OB claiming 1 GiB.
    #[test]
    fn item_headers_where_elements_are_expected_are_read_as_elements() {
        for e in [0xE0DDu16, 0xE000] {
            let mut rest = vec![0xFE, 0xFF];
            rest.extend(e.to_le_bytes());
            rest.extend([12, 0, 0, 0]);
            rest.extend([9, 0, 0x10, 0, b'L', b'O', 12, 0, 0, 0, 0, 0]);
            rest.extend([9, 0, 0x10, 0x10, b'O', b'B', 0, 0]);
            let mut claim = rest.clone();
            claim.extend([0, 0, 0, 0x40]);
            let m = check_bytes("stray", &part10("1.2.840.10008.1.2.1", &claim)).unwrap_err();
            assert!(
                m.contains("element (0009,1010) claims 1073741824 bytes; the file has 0 left"),
                "{e:04X}: {m}"
            );
            // The parser itself: claiming 2 bytes, present, (0009,1010) is read.
            rest.extend([2, 0, 0, 0, 7, 7]);
            let o = parsed("stray", &part10("1.2.840.10008.1.2.1", &rest)).expect("parsed");
            let v = o.element(dicom_object::Tag(9, 0x1010)).expect("read");
            assert_eq!(v.to_bytes().unwrap().as_ref(), &[7, 7]);
        }
    }

    /// A defined-length item ends where the parser's count reaches its length; the
    /// count adds a value's stated length though only whole numbers are read. An item
    /// of 14 bytes holding an SL that states 6 bytes (one number, 4 bytes, present)
    /// ends there by count: its sequence's delimiter follows, then an element claiming
    /// 1 GiB, refused. An item of 12 bytes around the same SL ends before the count
    /// (the parser stops, "inconsistent sequence end"): what follows is never read by
    /// the parser, so not by the walk.
    #[test]
    fn items_end_where_the_parser_counts_them() {
        let file = |item_len: u32| {
            let mut rest = vec![9, 0, 0x20, 0x10, b'S', b'Q', 0, 0, 0xFF, 0xFF, 0xFF, 0xFF];
            rest.extend([0xFE, 0xFF, 0x00, 0xE0]);
            rest.extend(item_len.to_le_bytes());
            rest.extend([0x19, 0, 0x10, 0, b'S', b'L', 6, 0, 1, 2, 3, 4]);
            rest.extend([0xFE, 0xFF, 0xDD, 0xE0, 0, 0, 0, 0]);
            rest.extend([9, 0, 0x10, 0x10, b'O', b'B', 0, 0, 0, 0, 0, 0x40]);
            part10("1.2.840.10008.1.2.1", &rest)
        };
        let m = check_bytes("item-count", &file(14)).unwrap_err();
        assert!(
            m.contains("element (0009,1010) claims 1073741824 bytes; the file has 0 left"),
            "{m}"
        );
        assert_eq!(check_bytes("item-count", &file(12)), Ok(()));
        let e = parsed("item-count", &file(12)).expect_err("the parser stops at the item's end");
        assert!(e.contains("InconsistentSequenceEnd"), "{e}");
    }

    /// After a nonzero PixelRepresentation (0028,0103), the parser reads a "US or SS"
    /// element (here PixelPaddingValue, given as OB with 3 bytes) as SS, one whole
    /// number, and the next header from its third byte: there (0009,1010) OB claims
    /// 1 GiB. With PixelRepresentation 0 the 3 bytes are read as OB and nothing is
    /// claimed.
    #[test]
    fn signed_pixels_make_us_or_ss_values_ss() {
        let file = |signed: u8, claim: u32| {
            let mut rest = vec![0x28, 0, 0x03, 0x01, b'U', b'S', 2, 0, signed, 0];
            rest.extend([0x28, 0, 0x20, 0x01, b'O', b'B', 0, 0, 3, 0, 0, 0, 1, 2]);
            rest.extend([9, 0, 0x10, 0x10, b'O', b'B', 0, 0]);
            rest.extend(claim.to_le_bytes());
            if claim == 2 {
                rest.extend([7, 7]);
            }
            part10("1.2.840.10008.1.2.1", &rest)
        };
        let m = check_bytes("signed", &file(1, 1 << 30)).unwrap_err();
        assert!(
            m.contains("element (0009,1010) claims 1073741824 bytes; the file has 0 left"),
            "{m}"
        );
        assert_eq!(check_bytes("unsigned", &file(0, 1 << 30)), Ok(()));
        // The parser itself: with a claim of 2 bytes, present, it reads (0009,1010)
        // only when the pixels are signed.
        for signed in [0, 1] {
            let read = parsed("signed", &file(signed, 2))
                .ok()
                .and_then(|o| o.element(dicom_object::Tag(9, 0x1010)).ok().cloned());
            assert_eq!(read.is_some(), signed == 1, "signed {signed}");
        }
    }

    /// A transfer syntax UID padded past 64 bytes is still the syntax (the registry
    /// trims trailing spaces and NULs): the data set after it is walked in it.
    #[test]
    fn padded_transfer_syntaxes_are_read_as_the_registry_reads_them() {
        let claim = [9, 0, 0x10, 0x10, b'O', b'B', 0, 0, 0, 0, 0, 0x40];
        let ts = format!("1.2.840.10008.1.2.1{}", " ".repeat(81));
        let m = check_bytes("padded-ts", &part10(&ts, &claim)).unwrap_err();
        assert!(
            m.contains("element (0009,1010) claims 1073741824 bytes; the file has 0 left"),
            "{m}"
        );
        // The parser takes it as that syntax: (0009,1010), given 2 bytes, is read.
        let mut small = claim.to_vec();
        small.splice(8.., [2, 0, 0, 0, 7, 7]);
        let o = parsed("padded-ts", &part10(&ts, &small)).expect("parsed");
        assert!(o.element(dicom_object::Tag(9, 0x1010)).is_ok());
    }

    /// Sequences may nest 128 deep (and `dicom-object`, which builds them by recursion,
    /// then reads the file in a test thread's stack); deeper is refused.
    #[test]
    fn nesting_is_bounded() {
        let nest = |depth: usize| {
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
            let mut rest = level.repeat(depth);
            rest.extend(close.repeat(depth));
            part10("1.2.840.10008.1.2.1", &rest)
        };
        let deepest = nest(super::NESTING_MAX);
        assert_eq!(check_bytes("nest", &deepest), Ok(()));
        let obj = parsed("nest", &deepest).expect("parsed");
        assert!(obj.element(dicom_object::Tag(9, 0x1010)).is_ok());
        let m = check_bytes("nest", &nest(super::NESTING_MAX + 1)).unwrap_err();
        assert!(m.contains("sequences nest more than 128 deep"), "{m}");
    }

    /// PackBits lengths as the RLE decoder counts them: literal runs (h >= 0: h + 1
    /// bytes, cut short by the end), replicate runs (h < 0: 1 − h copies of one byte),
    /// the no-op −128; a replicate run without its byte is None.
    #[test]
    fn packbits_lengths() {
        assert_eq!(packbits_len(&[]), Some(0));
        assert_eq!(packbits_len(&[2, 7, 8, 9]), Some(3));
        assert_eq!(packbits_len(&[2, 7]), Some(1));
        assert_eq!(packbits_len(&[0xFD, 5]), Some(4));
        assert_eq!(packbits_len(&[0x81, 5, 0, 1]), Some(129));
        assert_eq!(packbits_len(&[0x80, 0x80, 1, 4, 4]), Some(2));
        assert_eq!(packbits_len(&[1, 3, 4, 0xFF]), None);
    }
}
