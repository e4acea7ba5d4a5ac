//! Writing NRRD files: `NRRD0004`, raw / gzip / bzip2 / ascii, little-endian, to a
//! temporary file renamed into place.

use std::io::Write;
use std::path::Path;

use super::header::{Encoding, Endian};
use super::{each_data, Data, Nrrd};
use crate::{Error, Result};

/// How to write.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WriteOptions {
    /// Data encoding.
    pub encoding: Encoding,
    /// Byte order (for raw/gzip/bzip2/hex).
    pub endian: Endian,
}

impl Default for WriteOptions {
    fn default() -> Self {
        WriteOptions {
            encoding: Encoding::Raw,
            endian: Endian::Little,
        }
    }
}

fn fmt_f64(x: f64) -> String {
    if x.is_nan() {
        "nan".into()
    } else if x.is_infinite() {
        if x > 0.0 {
            "inf".into()
        } else {
            "-inf".into()
        }
    } else {
        format!("{x}")
    }
}

fn vec3(v: &[f64]) -> String {
    format!(
        "({})",
        v.iter().map(|&x| fmt_f64(x)).collect::<Vec<_>>().join(",")
    )
}

/// The `content:` line is cut to this many characters (an ellipsis marks the cut), so
/// that a long command line (a large @file) still gives a header rendr and Teem read.
pub const CONTENT_MAX: usize = 4096;

/// Header text on one line: control characters (a newline would end the field and
/// forge the next) shown as escapes.
fn one_line(t: &str) -> String {
    crate::error::escape_controls(t).into_owned()
}

fn content_line(c: &str) -> String {
    let c = one_line(c);
    match c.char_indices().nth(CONTENT_MAX) {
        None => c,
        Some((cut, _)) => format!("{} ...", &c[..cut]),
    }
}

/// Serializes `n` with options `opt` into `w`. Text fields are written on one line
/// each (control characters escaped), the content cut to [`CONTENT_MAX`] characters.
///
/// # Errors
/// [`crate::ErrorKind::Format`], writing nothing, when the header does not describe the
/// data ([`check_header`]); [`crate::ErrorKind::Io`] when writing fails; without the
/// `gzip`/`bzip2` feature, those encodings are refused.
pub fn write_to(n: &Nrrd, opt: WriteOptions, w: &mut dyn Write) -> Result<()> {
    check_header(n)?;
    let h = &n.header;
    let io = |e: std::io::Error| Error::msg(format!("write failed: {e}"));
    let mut s = String::from("NRRD0004\n");
    s.push_str("# Complete NRRD file format specification at:\n# http://teem.sourceforge.net/nrrd/format.html\n");
    if let Some(c) = &h.content {
        s.push_str(&format!("content: {}\n", content_line(c)));
    }
    s.push_str(&format!("type: {}\n", h.scalar.as_str()));
    s.push_str(&format!("dimension: {}\n", h.sizes.len()));
    if let Some(sp) = &h.space {
        s.push_str(&format!("space: {}\n", one_line(sp)));
    } else if let Some(d) = h.space_dimension {
        s.push_str(&format!("space dimension: {d}\n"));
    }
    s.push_str(&format!(
        "sizes: {}\n",
        h.sizes
            .iter()
            .map(|x| x.to_string())
            .collect::<Vec<_>>()
            .join(" ")
    ));
    if let Some(d) = &h.space_directions {
        let items: Vec<String> = d
            .iter()
            .map(|v| v.as_ref().map_or("none".to_string(), |v| vec3(v)))
            .collect();
        s.push_str(&format!("space directions: {}\n", items.join(" ")));
    }
    let list = |v: &[f64]| v.iter().map(|&x| fmt_f64(x)).collect::<Vec<_>>().join(" ");
    if let Some(v) = &h.spacings {
        s.push_str(&format!("spacings: {}\n", list(v)));
    }
    if let Some(v) = &h.axis_mins {
        s.push_str(&format!("axis mins: {}\n", list(v)));
    }
    if let Some(v) = &h.axis_maxs {
        s.push_str(&format!("axis maxs: {}\n", list(v)));
    }
    if let Some(c) = &h.centerings {
        s.push_str(&format!(
            "centerings: {}\n",
            c.iter().map(|c| c.as_str()).collect::<Vec<_>>().join(" ")
        ));
    }
    if let Some(k) = &h.kinds {
        s.push_str(&format!("kinds: {}\n", one_line(&k.join(" "))));
    }
    if let Some(l) = &h.labels {
        s.push_str(&format!(
            "labels: {}\n",
            l.iter()
                .map(|x| format!("\"{}\"", one_line(x)))
                .collect::<Vec<_>>()
                .join(" ")
        ));
    }
    if h.scalar.size() > 1 && opt.encoding != Encoding::Ascii {
        s.push_str(match opt.endian {
            Endian::Little => "endian: little\n",
            Endian::Big => "endian: big\n",
        });
    }
    s.push_str(&format!("encoding: {}\n", opt.encoding.as_str()));
    if let Some(o) = &h.space_origin {
        s.push_str(&format!("space origin: {}\n", vec3(o)));
    }
    for (k, v) in &h.key_values {
        s.push_str(&format!("{}:={}\n", one_line(k), one_line(v)));
    }
    s.push('\n');
    w.write_all(s.as_bytes()).map_err(io)?;
    match opt.encoding {
        Encoding::Ascii => {
            let mut out = String::new();
            let per_line = h.sizes.first().copied().unwrap_or(1).max(1);
            for (i, t) in n.data.texts(fmt_f64).enumerate() {
                out.push_str(&t);
                out.push(if (i + 1) % per_line == 0 { '\n' } else { ' ' });
            }
            w.write_all(out.as_bytes()).map_err(io)?;
        }
        enc => match enc {
            Encoding::Raw => write_samples(n, opt.endian, w).map_err(io)?,
            Encoding::Hex => {
                let mut bytes = Vec::with_capacity(n.data.len() * h.scalar.size());
                write_samples(n, opt.endian, &mut bytes).map_err(io)?;
                let mut out = String::with_capacity(bytes.len() * 2 + bytes.len() / 32);
                for (i, b) in bytes.iter().enumerate() {
                    out.push_str(&format!("{b:02x}"));
                    if (i + 1) % 32 == 0 {
                        out.push('\n');
                    }
                }
                out.push('\n');
                w.write_all(out.as_bytes()).map_err(io)?;
            }
            Encoding::Gzip => {
                crate::codec::gzip_to(w, |e| write_samples(n, opt.endian, e))?.map_err(io)?;
            }
            Encoding::Bzip2 => {
                crate::codec::bzip2_to(w, |e| write_samples(n, opt.endian, e))?.map_err(io)?;
            }
            Encoding::Ascii => unreachable!("handled above"),
        },
    }
    Ok(())
}

/// Checks that `n`'s header (its fields are public) describes its data as a reader
/// needs: the data's sample type, 1 to 16 sizes (the dimensions a reader takes) whose product is the sample count, one
/// entry per axis in each per-axis field, and space vectors as long as the space's
/// dimension.
///
/// # Errors
/// [`crate::ErrorKind::Format`] naming the field that disagrees.
pub fn check_header(n: &Nrrd) -> Result<()> {
    let h = &n.header;
    let bad = |m: String| Err(Error::msg(format!("NRRD header to write: {m}")));
    if h.scalar != n.data.scalar_type() {
        return bad(format!(
            "type {} but the samples are {}",
            h.scalar.as_str(),
            n.data.scalar_type().as_str()
        ));
    }
    let count = h.sizes.iter().try_fold(1usize, |a, &s| a.checked_mul(s));
    if !(1..=super::read::MAX_DIM).contains(&h.sizes.len()) || count != Some(n.data.len()) {
        return bad(format!("sizes {:?} for {} samples", h.sizes, n.data.len()));
    }
    let dim = h.sizes.len();
    let per_axis = [
        (
            "space directions",
            h.space_directions.as_ref().map(Vec::len),
        ),
        ("spacings", h.spacings.as_ref().map(Vec::len)),
        ("axis mins", h.axis_mins.as_ref().map(Vec::len)),
        ("axis maxs", h.axis_maxs.as_ref().map(Vec::len)),
        ("centerings", h.centerings.as_ref().map(Vec::len)),
        ("kinds", h.kinds.as_ref().map(Vec::len)),
        ("labels", h.labels.as_ref().map(Vec::len)),
    ];
    for (field, len) in per_axis {
        if let Some(l) = len.filter(|&l| l != dim) {
            return bad(format!("{field}: {l} entries for {dim} axes"));
        }
    }
    if let Some(sd) = h.space_dim() {
        let dirs = h.space_directions.iter().flatten().flatten();
        let vectors = dirs.map(|v| ("space directions", v));
        for (field, v) in vectors.chain(h.space_origin.iter().map(|o| ("space origin", o))) {
            if v.len() != sd {
                return bad(format!(
                    "{field}: {} values in a space of dimension {sd}",
                    v.len()
                ));
            }
        }
    }
    Ok(())
}

/// Writes the samples of `n` in byte order `e`, converted a piece at a time through one
/// small buffer (no copy of the whole array).
fn write_samples(n: &Nrrd, e: Endian, w: &mut dyn Write) -> std::io::Result<()> {
    fn put<T: Copy, const S: usize>(
        v: &[T],
        f: impl Fn(T) -> [u8; S],
        w: &mut dyn Write,
    ) -> std::io::Result<()> {
        let mut buf = vec![0u8; (64 << 10) / S * S];
        for part in v.chunks(buf.len() / S) {
            let bytes = &mut buf[..part.len() * S];
            for (o, &x) in bytes.chunks_exact_mut(S).zip(part) {
                o.copy_from_slice(&f(x));
            }
            w.write_all(bytes)?;
        }
        Ok(())
    }
    each_data!(&n.data, v => match e {
        Endian::Little => put(v, |x| x.to_le_bytes(), w),
        Endian::Big => put(v, |x| x.to_be_bytes(), w),
    })
}

/// Writes `n` to `path` (`-` = stdout) through a temporary file in the same directory,
/// renamed into place only when everything was written.
///
/// # Errors
/// As [`crate::output::write_atomic`] and [`write_to`].
pub fn write(n: &Nrrd, path: &Path, opt: WriteOptions) -> Result<()> {
    crate::files::write_atomic(path, |w| write_to(n, opt, w))
}

/// The NRRD of a volume, with its geometry: `space` (the volume's own, else
/// `3D-right-handed`), `space directions` (the columns of the index-to-world matrix),
/// `space origin` and cell centring, so Teem's tools and `rendr` read back the same
/// samples and index-to-world.
///
/// # Errors
/// When the samples cannot be copied (memory).
pub fn volume_nrrd(vol: &crate::volume_io::VolumeBuf) -> Result<Nrrd> {
    use crate::volume_io::Samples;
    let data = match vol.data() {
        Samples::F32(v) => Data::F32(copy(v)?),
        Samples::I16(v) => Data::I16(copy(v)?),
    };
    fn copy<T: Copy>(v: &[T]) -> Result<Vec<T>> {
        let mut out = Vec::new();
        crate::try_reserve(&mut out, v.len(), "a copy of the samples")?;
        out.extend_from_slice(v);
        Ok(out)
    }
    let mut n = Nrrd::new(vol.sizes().to_vec(), data)?;
    let itow = vol.itow();
    let h = &mut n.header;
    h.space = Some(
        vol.space
            .clone()
            .unwrap_or_else(|| "3D-right-handed".to_string()),
    );
    h.space_directions = Some((0..3).map(|c| Some(itow.column3(c).to_vec())).collect());
    h.space_origin = Some(itow.column3(3).to_vec());
    h.centerings = Some(vec![crate::nrrd::Centering::Cell; 3]);
    Ok(n)
}

/// Writes a volume as NRRD with its geometry ([`volume_nrrd`]) to `path`, safely (a
/// temporary file renamed into place when complete; an input is never overwritten).
///
/// ```
/// use rnd_std::prelude::*;
/// use rnd_std::nrrd::WriteOptions;
///
/// let dir = std::env::temp_dir().join(format!("rnd-std-doc-{}", std::process::id()));
/// std::fs::create_dir_all(&dir).unwrap();
/// let path = dir.join("ramp.nrrd");
/// let geom = Affine4::from_spacing([0.5, 0.5, 2.0], [-1.0, 0.0, 3.0]);
/// let vol = VolumeBuf::new(VolumeData::F32((0..60).map(|i| i as f32).collect()), [3, 4, 5], geom)
///     .unwrap();
/// write_volume(&vol, &path, WriteOptions::default()).unwrap();
/// let back = load_volume(&path).unwrap();
/// assert_eq!(back.itow(), geom);
/// assert_eq!(back.data(), vol.data());
/// # std::fs::remove_dir_all(&dir).unwrap();
/// ```
///
/// # Errors
/// As [`volume_nrrd`] and [`write()`].
pub fn write_volume(
    vol: &crate::volume_io::VolumeBuf,
    path: &Path,
    opt: WriteOptions,
) -> Result<()> {
    write(&volume_nrrd(vol)?, path, opt)
}
