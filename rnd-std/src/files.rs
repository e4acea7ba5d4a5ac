//! Loading the small text/NRRD files rendr reads (transfer functions, LUTs, Levoy
//! iso-contours, lights), each validated with errors naming the file. [`write_atomic`] is
//! re-exported from [`crate::output`].

use std::path::Path;

use rnd_core::classify::{LutAxis, Primitive, Quantity, Shape};
use rnd_core::light::{Light, LightSpace};
use rnd_core::txf::{hsv_to_rgb, Levoy, Lut, Txf, TxfSpace};

use crate::nrrd::{self, Centering, Nrrd};
use crate::{Error, Result};

/// Requires a 2-D array (a 1-D array counts as one column); returns it with its column
/// and row counts.
fn as_2d(path: &Path, n: Nrrd) -> Result<(Nrrd, usize, usize)> {
    let (c, r) = match n.sizes() {
        [c, r] => (*c, *r),
        [c] => (1, *c),
        s => {
            return Err(Error::at(
                path,
                format!("need a 2-D array, got {}-D", s.len()),
            ))
        }
    };
    Ok((n, c, r))
}

fn space_of(path: &Path, n: &Nrrd) -> Result<Option<TxfSpace>> {
    let s = n.header.key("space").or_else(|| n.header.key("range"));
    match s {
        None => Ok(None),
        Some(s) => s
            .parse::<TxfSpace>()
            .map(Some)
            .map_err(|e| Error::from(e).with_path(path)),
    }
}

fn rows(n: &Nrrd, c: usize) -> Vec<Vec<f64>> {
    n.data.to_f64().chunks(c).map(<[f64]>::to_vec).collect()
}

/// Loads a control-point transfer function (a text array with a comment line): `#space:=` (or `#range:=`) rgb,
/// hsv or alpha; 4 or 2 columns; rows sorted by position.
///
/// # Errors
/// As [`crate::nrrd::read`] and [`txf_from_nrrd`].
pub fn load_txf(path: &Path) -> Result<Txf> {
    txf_from_nrrd(path, nrrd::read(path)?)
}

/// [`load_txf`] on an array already read (`path` names it in errors).
///
/// # Errors
/// [`crate::ErrorKind::Format`] when the array is not 2-D with 2 or 4 columns or the
/// space is unknown; the core's [`rnd_core::ErrorKind::Txf`] for bad control points.
pub fn txf_from_nrrd(path: &Path, n: Nrrd) -> Result<Txf> {
    let (n, c, _) = as_2d(path, n)?;
    let space = space_of(path, &n)?.ok_or_else(|| {
        Error::at(
            path,
            "no \"#space:=\" (or \"#range:=\") line saying rgb, hsv or alpha",
        )
    })?;
    let need = space.channels() + 1;
    if c != need {
        return Err(Error::at(
            path,
            format!("axis[0].size should be {need} for space {space}, not {c} (columns per row)"),
        ));
    }
    let rs = rows(&n, c);
    let refs: Vec<&[f64]> = rs.iter().map(Vec::as_slice).collect();
    Txf::new(space, &refs).map_err(|e| Error::from(e).with_path(path))
}

/// Loads a LUT (a NRRD or text array): 4 × N, or 4 × N × M for a 2-D LUT, each data
/// axis with finite min < max (cell-centred when a centring is given).
///
/// # Errors
/// As [`crate::nrrd::read`] and [`lut_from_nrrd`].
pub fn load_lut(path: &Path) -> Result<Lut> {
    lut_from_nrrd(path, nrrd::read(path)?)
}

/// [`load_lut`] on an array already read. Axis 0 holds r, g, b, a; each data axis
/// needs `axis mins/maxs` (its domain) and names its quantity with a label that
/// [`Quantity::from_label`] reads (`v`, `gm`, `k1`, `k2`, `meancurv`, `gausscurv`, or as
/// Teem writes them, e.g. `gage(scalar:gm)`). A 4 × N LUT without a label is over `v`.
///
/// # Errors
/// [`crate::ErrorKind::Format`] when the array is not 4 × N or 4 × N × M, a domain is
/// missing or a label is missing (2-D) or names no quantity; the core's
/// [`rnd_core::ErrorKind::Txf`] for a bad domain, two axes of one quantity or bad
/// entries.
pub fn lut_from_nrrd(path: &Path, n: Nrrd) -> Result<Lut> {
    let s = n.sizes().to_vec();
    if !(s.len() == 2 || s.len() == 3) {
        return Err(Error::at(
            path,
            format!(
                "LUT must be 2-D (4 x N) or 3-D (4 x N x M), got {}-D",
                s.len()
            ),
        ));
    }
    if s[0] != 4 {
        return Err(Error::at(
            path,
            format!("LUT axis 0 has size {}, need 4 (r g b a)", s[0]),
        ));
    }
    let h = &n.header;
    let mut axes = Vec::new();
    for (a, &len) in s.iter().enumerate().skip(1) {
        let (lo, hi) = match (&h.axis_mins, &h.axis_maxs) {
            (Some(x), Some(y)) => (x[a], y[a]),
            _ => {
                return Err(Error::at(
                    path,
                    format!("LUT axis {a} has no axis min/max (its domain)"),
                ))
            }
        };
        // The domain (finite min < max) is checked by `Lut::with_axes`.
        if nrrd::centering(h, a) == Centering::Node {
            return Err(Error::at(
                path,
                format!("LUT axis {a} must be cell-centred, not node"),
            ));
        }
        let label = h
            .labels
            .as_ref()
            .and_then(|l| l.get(a))
            .map(|l| l.trim())
            .filter(|l| !l.is_empty());
        let quantity = match label {
            Some(l) => Quantity::from_label(l).ok_or_else(|| {
                Error::at(
                    path,
                    format!(
                        "LUT axis {a} label \"{l}\" names no quantity (v gm k1 k2 meancurv \
                         gausscurv, or gage(scalar:NAME))"
                    ),
                )
            })?,
            None if s.len() == 2 => Quantity::Value,
            None => {
                return Err(Error::at(
                    path,
                    format!(
                        "2-D LUT axis {a} has no label naming its quantity (v gm k1 k2 \
                         meancurv gausscurv)"
                    ),
                ))
            }
        };
        axes.push(LutAxis::new(quantity, lo, hi, len));
    }
    // Non-finite entries are refused by `Lut::with_axes`.
    let v = n.data.to_f32();
    let rgba = v
        .chunks_exact(4)
        .map(|c| [c[0], c[1], c[2], c[3]])
        .collect();
    Lut::with_axes(&axes, rgba).map_err(|e| Error::from(e).with_path(path))
}

/// `lut` as a NRRD: float, 4 × N (× M), each data axis with its domain, cell centring
/// and Teem's label for its quantity (`gage(scalar:v)`, ...), axis 0 labelled `RGBA`,
/// as `teem-miter -txf` and [`lut_from_nrrd`] read it.
///
/// # Errors
/// [`crate::ErrorKind::Format`] only if the sizes do not match the entries (they do for
/// every [`Lut`]).
pub fn lut_to_nrrd(lut: &Lut, content: Option<String>) -> Result<Nrrd> {
    let axes = lut.axes();
    let mut sizes = vec![4];
    sizes.extend(axes.iter().map(|a| a.len));
    let data: Vec<f32> = lut.entries().iter().flatten().copied().collect();
    let mut n = Nrrd::new(sizes, nrrd::Data::F32(data))?;
    let h = &mut n.header;
    h.content = content;
    let all = |first: f64, f: &dyn Fn(&LutAxis) -> f64| {
        std::iter::once(first)
            .chain(axes.iter().map(f))
            .collect::<Vec<f64>>()
    };
    h.axis_mins = Some(all(f64::NAN, &|a| a.min));
    h.axis_maxs = Some(all(f64::NAN, &|a| a.max));
    h.centerings = Some(
        std::iter::once(Centering::Unknown)
            .chain(axes.iter().map(|_| Centering::Cell))
            .collect(),
    );
    h.kinds = Some(
        std::iter::once("RGBA-color".to_string())
            .chain(axes.iter().map(|_| "???".to_string()))
            .collect(),
    );
    h.labels = Some(
        std::iter::once("RGBA".to_string())
            .chain(axes.iter().map(|a| a.quantity.teem_label().to_string()))
            .collect(),
    );
    Ok(n)
}

/// Most bytes of a 2-D LUT primitives file.
const PRIMITIVES_LIMIT: u64 = 1 << 20;

/// Loads the primitives of a 2-D LUT ([`Lut::from_primitives`]): one per line, a shape
/// name, its numbers, then `r g b a` (colour and peak opacity); `#` starts a comment.
///
/// ```text
/// # shape    parameters (x = first axis, y = second)   r   g   b   a
/// box        x0 x1 y0 y1                               1   1   1   0.3
/// gauss      cx cy sx sy                               1   0   0   0.8
/// triangle   v0 w g1 g0                                0   1   0   0.5
/// arch       va vb top width                           1   1   0   0.6
/// levoy      v0 r                                      1   1   1   1
/// ```
///
/// # Errors
/// The file unreadable or too long; a line with an unknown shape, the wrong count of
/// numbers, or a number that does not parse (each naming the line). The primitives'
/// values are checked by [`Lut::from_primitives`].
pub fn load_primitives(path: &Path) -> Result<Vec<Primitive>> {
    let text = read_text(path, PRIMITIVES_LIMIT)?;
    parse_primitives(&text).map_err(|m| Error::at(path, m))
}

/// [`load_primitives`] of text already read; the error is the message (naming the line).
///
/// # Errors
/// As [`load_primitives`].
pub fn parse_primitives(text: &str) -> std::result::Result<Vec<Primitive>, String> {
    let mut out = Vec::new();
    for (no, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        let mut words = line.split_whitespace();
        let Some(name) = words.next() else { continue };
        let at = |m: String| format!("line {}: {m}", no + 1);
        let nums = words
            .map(|w| {
                w.parse::<f64>()
                    .map_err(|_| at(format!("\"{w}\" is not a number")))
            })
            .collect::<std::result::Result<Vec<f64>, String>>()?;
        let params = match name.to_ascii_lowercase().as_str() {
            "box" => 4,
            "gauss" => 4,
            "triangle" => 4,
            "arch" => 4,
            "levoy" => 2,
            _ => {
                return Err(at(format!(
                    "unknown primitive \"{name}\" (known: box gauss triangle arch levoy)"
                )))
            }
        };
        if nums.len() != params + 4 {
            return Err(at(format!(
                "{name} takes {params} numbers and then r g b a ({} in all), not {}",
                params + 4,
                nums.len()
            )));
        }
        let p = &nums[..params];
        let shape = match name.to_ascii_lowercase().as_str() {
            "box" => Shape::Box {
                lo: [p[0], p[2]],
                hi: [p[1], p[3]],
            },
            "gauss" => Shape::Gaussian {
                centre: [p[0], p[1]],
                sigma: [p[2], p[3]],
            },
            "triangle" => Shape::Triangle {
                v0: p[0],
                w: p[1],
                g1: p[2],
                g0: p[3],
            },
            "arch" => Shape::Arch {
                va: p[0],
                vb: p[1],
                top: p[2],
                width: p[3],
            },
            _ => Shape::Levoy { v0: p[0], r: p[1] },
        };
        let c = &nums[params..];
        out.push(Primitive {
            shape,
            rgb: [c[0], c[1], c[2]],
            alpha: c[3],
        });
    }
    Ok(out)
}

/// Loads Levoy iso-contours (isovalue, thickness, opacity): 3 columns `v r a` per line.
///
/// # Errors
/// As [`crate::nrrd::read`] and [`levoy_from_nrrd`].
pub fn load_levoy(path: &Path) -> Result<Levoy> {
    levoy_from_nrrd(path, nrrd::read(path)?)
}

/// [`load_levoy`] on an array already read.
///
/// # Errors
/// [`crate::ErrorKind::Format`] when the array does not have 3 columns; the core's
/// [`rnd_core::ErrorKind::Txf`] for bad contours.
pub fn levoy_from_nrrd(path: &Path, n: Nrrd) -> Result<Levoy> {
    let (n, c, _) = as_2d(path, n)?;
    if c != 3 {
        return Err(Error::at(
            path,
            format!("need 3 columns (isovalue thickness opacity), got {c}"),
        ));
    }
    let items = rows(&n, 3)
        .into_iter()
        .map(|r| [r[0] as f32, r[1] as f32, r[2] as f32])
        .collect();
    Levoy::new(items).map_err(|e| Error::from(e).with_path(path))
}

/// Loads lights (one per row, colour then direction then view-space flag): `#space:=rgb|hsv` (rgb when absent), 7 columns
/// `c0 c1 c2 d0 d1 d2 vsp`.
///
/// # Errors
/// As [`crate::nrrd::read`] and [`lights_from_nrrd`].
pub fn load_lights(path: &Path) -> Result<Vec<Light>> {
    lights_from_nrrd(path, nrrd::read(path)?)
}

/// [`load_lights`] on an array already read.
///
/// # Errors
/// [`crate::ErrorKind::Format`] when the array does not have 7 columns, the space is
/// unknown or there are too many lights; the core's [`rnd_core::ErrorKind::Light`]
/// for a bad light.
pub fn lights_from_nrrd(path: &Path, n: Nrrd) -> Result<Vec<Light>> {
    let (n, c, _) = as_2d(path, n)?;
    let space = space_of(path, &n)?.unwrap_or(TxfSpace::Rgb);
    if space == TxfSpace::Alpha {
        return Err(Error::at(
            path,
            "light colours must be in space rgb or hsv, not alpha",
        ));
    }
    if c != 7 {
        return Err(Error::at(
            path,
            format!("need 7 columns per light (r g b  dx dy dz  view), got {c}"),
        ));
    }
    let count = n.sizes().get(1).copied().unwrap_or(1);
    if count > rnd_core::light::MAX_LIGHTS {
        return Err(Error::at(
            path,
            format!(
                "{count} lights; at most {} are allowed",
                rnd_core::light::MAX_LIGHTS
            ),
        ));
    }
    rows(&n, 7)
        .into_iter()
        .enumerate()
        .map(|(i, r)| {
            let col = [r[0], r[1], r[2]];
            let rgb = if space == TxfSpace::Hsv {
                hsv_to_rgb(col)
            } else {
                col
            };
            Light::new(
                [rgb[0] as f32, rgb[1] as f32, rgb[2] as f32],
                [r[3], r[4], r[5]],
                if r[6] != 0.0 {
                    LightSpace::View
                } else {
                    LightSpace::World
                },
            )
            .map_err(|e| {
                let mut e = Error::from(e).with_path(path);
                e.msg = format!("light {i}: {}", e.msg);
                e
            })
        })
        .collect()
}

pub use crate::output::{remove_temp_files, write_atomic};

/// Reads a text file's bytes (`-` = stdin), at most `limit` of them, block by block:
/// a longer input, or one with a NUL byte (a binary file, `/dev/zero`), is refused as
/// soon as that shows, without reading on.
///
/// # Errors
/// Unreadable, a directory, too long, NUL bytes (each naming the file).
pub fn read_text_bytes(path: &Path, limit: u64) -> Result<Vec<u8>> {
    use std::io::Read;
    let mut src: Box<dyn Read> = if path.as_os_str() == "-" {
        Box::new(std::io::stdin().lock())
    } else {
        if std::fs::metadata(path).is_ok_and(|m| m.is_dir()) {
            return Err(Error::at(path, "is a directory, not a file"));
        }
        Box::new(std::fs::File::open(path).map_err(|e| Error::io(path, "can't read", e))?)
    };
    let mut text = Vec::new();
    let mut buf = vec![0u8; 1 << 16];
    loop {
        let n = match src.read(&mut buf) {
            Ok(0) => return Ok(text),
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(Error::io(path, "can't read", e)),
        };
        if buf[..n].contains(&0) {
            return Err(Error::at(path, "not a text file (it holds NUL bytes)"));
        }
        if (text.len() + n) as u64 > limit {
            return Err(Error::at(
                path,
                format!("longer than {}", crate::human_bytes(limit)),
            ));
        }
        text.extend_from_slice(&buf[..n]);
    }
}

/// [`read_text_bytes`] for UTF-8 text.
///
/// # Errors
/// As [`read_text_bytes`], and text that is not UTF-8.
pub fn read_text(path: &Path, limit: u64) -> Result<String> {
    String::from_utf8(read_text_bytes(path, limit)?).map_err(|_| Error::at(path, "not UTF-8 text"))
}
