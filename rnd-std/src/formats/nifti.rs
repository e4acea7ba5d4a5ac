//! NIfTI-1 and NIfTI-2 volumes: single files (`.nii`, magic `n+1`/`n+2`) and header +
//! image pairs (`.hdr` + `.img`, magic `ni1`/`ni2`), either gzip-compressed.
//!
//! The NIfTI-1 header is parsed by the `nifti` crate; NIfTI-2 (which that crate does not
//! read) by hand, from the layout of the NIfTI-2 definition. Both become one [`Hdr`],
//! from which the geometry follows the NIfTI rules:
//!
//! - `sform_code > 0`: the affine rows `srow_x/y/z` (preferred, as nibabel and FSL do);
//! - else `qform_code > 0`: the quaternion `(b, c, d)` with `a = √(1 − b² − c² − d²)`,
//!   the spacings `pixdim[1..3]`, the third axis times `qfac = pixdim[0]` (±1; any other
//!   value read as 1) and the offset `qoffset_x/y/z`;
//! - else ("method 1", Analyze files): the spacings on the diagonal, origin 0.
//!
//! Coordinates are NIfTI's RAS+ world (`right-anterior-superior`), in the file's
//! spatial unit (noted when it is not millimetres). `scl_slope`/`scl_inter` are applied
//! when the slope is a number other than 0 (see [`super::rescale`]).

use std::io::{BufRead, Read};
use std::path::{Path, PathBuf};

use super::{Format, Loaded};
use crate::nrrd::{Endian, ScalarType};
use crate::{Error, Result};

/// What rendr uses of a NIfTI-1 or NIfTI-2 header.
#[derive(Debug, Clone, PartialEq)]
struct Hdr {
    /// 1 or 2.
    version: u8,
    /// Header and data in separate files (`ni1`/`ni2`).
    pair: bool,
    endian: Endian,
    dim: [i64; 8],
    datatype: i16,
    bitpix: i16,
    pixdim: [f64; 8],
    vox_offset: f64,
    scl_slope: f64,
    scl_inter: f64,
    qform_code: i32,
    sform_code: i32,
    quatern: [f64; 3],
    qoffset: [f64; 3],
    srow: [[f64; 4]; 3],
    xyzt_units: i32,
}

/// Header sizes of NIfTI-1 and NIfTI-2.
const LEN1: usize = 348;
const LEN2: usize = 540;

fn parse1(b: &[u8]) -> Result<Hdr> {
    let h = nifti::NiftiHeader::from_reader(b)
        .map_err(|e| Error::msg(format!("NIfTI-1 header: {e}")))?;
    let f = |x: f32| x as f64;
    Ok(Hdr {
        version: 1,
        pair: &h.magic == b"ni1\0",
        endian: match h.endianness {
            nifti::Endianness::Little => Endian::Little,
            nifti::Endianness::Big => Endian::Big,
        },
        // NIfTI-1 stores dimensions as signed 16-bit numbers.
        dim: h.dim.map(|d| d as i16 as i64),
        datatype: h.datatype,
        bitpix: h.bitpix,
        pixdim: h.pixdim.map(f),
        vox_offset: f(h.vox_offset),
        scl_slope: f(h.scl_slope),
        scl_inter: f(h.scl_inter),
        qform_code: h.qform_code as i32,
        sform_code: h.sform_code as i32,
        quatern: [f(h.quatern_b), f(h.quatern_c), f(h.quatern_d)],
        qoffset: [f(h.quatern_x), f(h.quatern_y), f(h.quatern_z)],
        srow: [h.srow_x.map(f), h.srow_y.map(f), h.srow_z.map(f)],
        xyzt_units: h.xyzt_units as i32,
    })
}

/// NIfTI-2: the NIfTI-1 fields widened to 64 bits and reordered (offsets from the
/// NIfTI-2 definition).
fn parse2(b: &[u8]) -> Result<Hdr> {
    let endian = if b[..4] == 540i32.to_le_bytes() {
        Endian::Little
    } else {
        Endian::Big
    };
    let bytes = |o: usize, n: usize| -> [u8; 8] {
        let mut a = [0u8; 8];
        a[..n].copy_from_slice(&b[o..o + n]);
        if endian == Endian::Big {
            a[..n].reverse();
        }
        a
    };
    let i16_at = |o: usize| i16::from_le_bytes(bytes(o, 2)[..2].try_into().expect("2 bytes"));
    let i32_at = |o: usize| i32::from_le_bytes(bytes(o, 4)[..4].try_into().expect("4 bytes"));
    let i64_at = |o: usize| i64::from_le_bytes(bytes(o, 8));
    let f64_at = |o: usize| f64::from_le_bytes(bytes(o, 8));
    let row = |o: usize| -> [f64; 4] { core::array::from_fn(|i| f64_at(o + 8 * i)) };
    Ok(Hdr {
        version: 2,
        pair: &b[4..8] == b"ni2\0",
        endian,
        dim: core::array::from_fn(|i| i64_at(16 + 8 * i)),
        datatype: i16_at(12),
        bitpix: i16_at(14),
        pixdim: core::array::from_fn(|i| f64_at(104 + 8 * i)),
        vox_offset: i64_at(168) as f64,
        scl_slope: f64_at(176),
        scl_inter: f64_at(184),
        qform_code: i32_at(344),
        sform_code: i32_at(348),
        quatern: [f64_at(352), f64_at(360), f64_at(368)],
        qoffset: [f64_at(376), f64_at(384), f64_at(392)],
        srow: [row(400), row(432), row(464)],
        xyzt_units: i32_at(500),
    })
}

/// The sample type of NIfTI datatype code `code`.
fn scalar(code: i16) -> Result<ScalarType> {
    Ok(match code {
        2 => ScalarType::U8,
        4 => ScalarType::I16,
        8 => ScalarType::I32,
        16 => ScalarType::F32,
        64 => ScalarType::F64,
        256 => ScalarType::I8,
        512 => ScalarType::U16,
        768 => ScalarType::U32,
        1024 => ScalarType::I64,
        1280 => ScalarType::U64,
        32 | 1792 | 2048 => {
            return Err(Error::msg(format!(
                "datatype {code} is complex; rendr renders real scalar volumes"
            )))
        }
        128 | 2304 => {
            return Err(Error::msg(format!(
                "datatype {code} is RGB(A) colour; rendr renders scalar volumes"
            )))
        }
        _ => {
            return Err(Error::msg(format!(
                "datatype {code} is not a NIfTI sample type"
            )))
        }
    })
}

/// The spatial unit, when it is not millimetres (or unknown).
fn unit_note(units: i32) -> Option<String> {
    match units & 7 {
        0 | 2 => None,
        1 => Some("spatial unit is metres; coordinates are used as the file gives them".into()),
        3 => {
            Some("spatial unit is micrometres; coordinates are used as the file gives them".into())
        }
        u => Some(format!(
            "unknown spatial unit code {u}; coordinates used as given"
        )),
    }
}

/// Name of a qform/sform code.
fn xform_name(code: i32) -> &'static str {
    match code {
        1 => "scanner",
        2 => "aligned",
        3 => "Talairach",
        4 => "MNI-152",
        5 => "template",
        _ => "unknown",
    }
}

/// The index-to-world columns and origin a header gives, and a sentence saying which
/// of its transforms that was.
fn geometry(h: &Hdr) -> Result<([[f64; 3]; 3], [f64; 3], String)> {
    let sp = [h.pixdim[1], h.pixdim[2], h.pixdim[3]];
    if h.sform_code > 0 {
        let s = &h.srow;
        let dirs = core::array::from_fn(|c| [s[0][c], s[1][c], s[2][c]]);
        let o = [s[0][3], s[1][3], s[2][3]];
        let also = if h.qform_code > 0 {
            format!(" (the qform, code {}, is not used)", h.qform_code)
        } else {
            String::new()
        };
        return Ok((
            dirs,
            o,
            format!(
                "geometry from the sform (code {}: {}){also}",
                h.sform_code,
                xform_name(h.sform_code)
            ),
        ));
    }
    if sp.iter().any(|x| !x.is_finite() || *x == 0.0) {
        return Err(Error::msg(format!(
            "pixdim {sp:?}: spacings must be non-zero numbers"
        )));
    }
    if h.qform_code > 0 {
        let [b, c, d] = h.quatern;
        let a = (1.0 - (b * b + c * c + d * d)).max(0.0).sqrt();
        let r = [
            [
                a * a + b * b - c * c - d * d,
                2.0 * (b * c - a * d),
                2.0 * (b * d + a * c),
            ],
            [
                2.0 * (b * c + a * d),
                a * a + c * c - b * b - d * d,
                2.0 * (c * d - a * b),
            ],
            [
                2.0 * (b * d - a * c),
                2.0 * (c * d + a * b),
                a * a + d * d - c * c - b * b,
            ],
        ];
        let qfac = if h.pixdim[0] == -1.0 { -1.0 } else { 1.0 };
        let scale = [sp[0].abs(), sp[1].abs(), sp[2].abs() * qfac];
        let dirs = core::array::from_fn(|col| core::array::from_fn(|row| r[row][col] * scale[col]));
        return Ok((
            dirs,
            h.qoffset,
            format!(
                "geometry from the qform (code {}: {}, qfac {qfac})",
                h.qform_code,
                xform_name(h.qform_code)
            ),
        ));
    }
    Ok((
        [[sp[0], 0.0, 0.0], [0.0, sp[1], 0.0], [0.0, 0.0, sp[2]]],
        [0.0; 3],
        "no qform or sform: axis-aligned grid from pixdim, origin (0,0,0)".into(),
    ))
}

/// Reads a NIfTI file of version `f` whose bytes (decompressed, when `gz`) come from
/// `r`; `path` finds the `.img` of a header/image pair.
pub(super) fn read(f: Format, r: &mut dyn BufRead, path: &Path, gz: bool) -> Result<Loaded> {
    let len = if f == Format::Nifti1 { LEN1 } else { LEN2 };
    let mut b = vec![0u8; len];
    r.read_exact(&mut b)
        .map_err(|_| Error::msg(format!("{}: the header is truncated", f.name())))?;
    let h = if f == Format::Nifti1 {
        parse1(&b)?
    } else {
        parse2(&b)?
    };
    let what = f.name();
    let sizes = super::sizes3(&h.dim[1..=(h.dim[0].clamp(0, 7) as usize)], what)
        .map_err(|e| Error::msg(format!("{e} (dim[0] = {})", h.dim[0])))?;
    let t = scalar(h.datatype).map_err(|e| Error::msg(format!("{what}: {e}")))?;
    if h.bitpix as usize != 8 * t.size() {
        return Err(Error::msg(format!(
            "{what}: bitpix {} does not match datatype {} ({} bits)",
            h.bitpix,
            h.datatype,
            8 * t.size()
        )));
    }
    if !(h.vox_offset >= 0.0 && h.vox_offset.fract() == 0.0) {
        return Err(Error::msg(format!(
            "{what}: vox_offset {} is not a byte offset",
            h.vox_offset
        )));
    }
    let (dirs, origin, how) = geometry(&h).map_err(|e| Error::msg(format!("{what}: {e}")))?;
    let mut notes = vec![format!(
        "{what}{}{}: {how}",
        if h.pair { " header/image pair" } else { "" },
        if gz { ", gzip" } else { "" }
    )];
    notes.extend(unit_note(h.xyzt_units));
    let n = sizes[0] * sizes[1] * sizes[2];
    let data = if h.pair {
        let img = pair_data_file(path).ok_or_else(|| {
            Error::msg(format!(
                "{what} header/image pair: no .img (or .img.gz) beside this header"
            ))
        })?;
        let file = std::fs::File::open(&img).map_err(|e| Error::io(&img, "can't read", e))?;
        let (head, src) = super::peek(Box::new(file)).map_err(|e| e.with_path(&img))?;
        let mut src: Box<dyn Read> = if head.starts_with(b"\x1f\x8b") {
            crate::codec::gunzip(src).map_err(|e| e.with_path(&img))?
        } else {
            Box::new(src)
        };
        super::skip(&mut src, h.vox_offset as u64, "vox_offset").map_err(|e| e.with_path(&img))?;
        crate::nrrd::read::read_samples(&mut src, t, h.endian, n).map_err(|e| e.with_path(&img))?
    } else {
        let min = len as f64 + 4.0;
        if h.vox_offset < min {
            return Err(Error::msg(format!(
                "{what}: vox_offset {} is inside the header (the data of a single file \
                 starts at {min} or later)",
                h.vox_offset
            )));
        }
        super::skip(r, h.vox_offset as u64 - len as u64, "vox_offset")?;
        crate::nrrd::read::read_samples(r, t, h.endian, n)?
    };
    let (slope, inter) = (
        h.scl_slope,
        if h.scl_inter.is_finite() {
            h.scl_inter
        } else {
            0.0
        },
    );
    let data = if slope.is_finite() && slope != 0.0 {
        let (d, note) = super::rescale(data, slope, inter)?;
        notes.extend(note.map(|s| format!("scl_slope/scl_inter: {s}")));
        d
    } else {
        data
    };
    let nrrd = super::volume_nrrd(sizes, data, "right-anterior-superior", dirs, origin)?;
    Ok(Loaded {
        nrrd,
        format: f,
        notes,
    })
}

/// The image file of a NIfTI header/image pair: `x.hdr` → `x.img` (or `x.img.gz`),
/// `x.hdr.gz` → `x.img.gz` (or `x.img`); `None` when `path` is no `.hdr` or neither
/// image exists.
pub(super) fn pair_data_file(path: &Path) -> Option<PathBuf> {
    let name = path.file_name()?.to_str()?;
    let stem = name
        .strip_suffix(".hdr.gz")
        .or_else(|| name.strip_suffix(".hdr"))
        .or_else(|| name.strip_suffix(".HDR"))?;
    let upper = name.ends_with(".HDR");
    let ext = if upper {
        ["IMG", "IMG.gz"]
    } else {
        ["img", "img.gz"]
    };
    let first = if name.ends_with(".gz") {
        [ext[1], ext[0]]
    } else {
        ext
    };
    first
        .iter()
        .map(|e| path.with_file_name(format!("{stem}.{e}")))
        .find(|p| p.is_file())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hdr() -> Hdr {
        Hdr {
            version: 1,
            pair: false,
            endian: Endian::Little,
            dim: [3, 2, 3, 4, 1, 1, 1, 1],
            datatype: 4,
            bitpix: 16,
            pixdim: [1.0, 2.0, 3.0, 4.0, 0.0, 0.0, 0.0, 0.0],
            vox_offset: 352.0,
            scl_slope: 0.0,
            scl_inter: 0.0,
            qform_code: 0,
            sform_code: 0,
            quatern: [0.0; 3],
            qoffset: [0.0; 3],
            srow: [[0.0; 4]; 3],
            xyzt_units: 2,
        }
    }

    #[test]
    fn qform_rotation_and_qfac() {
        // 90° about z: (b, c, d) = (0, 0, sin 45°); a = cos 45°.
        let mut h = hdr();
        h.qform_code = 1;
        h.quatern = [0.0, 0.0, std::f64::consts::FRAC_1_SQRT_2];
        h.qoffset = [10.0, 20.0, 30.0];
        h.pixdim[0] = -1.0;
        let (d, o, how) = geometry(&h).unwrap();
        let want = [[0.0, 2.0, 0.0], [-3.0, 0.0, 0.0], [0.0, 0.0, -4.0]];
        for c in 0..3 {
            for r in 0..3 {
                assert!((d[c][r] - want[c][r]).abs() < 1e-12, "{d:?}");
            }
        }
        assert_eq!(o, [10.0, 20.0, 30.0]);
        assert!(how.contains("qform"));
    }

    #[test]
    fn sform_wins_over_qform() {
        let mut h = hdr();
        h.qform_code = 1;
        h.sform_code = 2;
        h.srow = [
            [1.0, 2.0, 3.0, 4.0],
            [5.0, 6.0, 7.0, 8.0],
            [9.0, 10.0, 11.0, 12.0],
        ];
        let (d, o, how) = geometry(&h).unwrap();
        assert_eq!(d, [[1.0, 5.0, 9.0], [2.0, 6.0, 10.0], [3.0, 7.0, 11.0]]);
        assert_eq!(o, [4.0, 8.0, 12.0]);
        assert!(how.contains("sform") && how.contains("qform, code 1, is not used"));
    }

    #[test]
    fn nifti2_layout() {
        let mut b = vec![0u8; LEN2];
        b[..4].copy_from_slice(&540i32.to_be_bytes());
        b[4..8].copy_from_slice(b"n+2\0");
        b[12..14].copy_from_slice(&16i16.to_be_bytes());
        b[14..16].copy_from_slice(&32i16.to_be_bytes());
        for (i, d) in [3i64, 5, 6, 7].iter().enumerate() {
            b[16 + 8 * i..24 + 8 * i].copy_from_slice(&d.to_be_bytes());
        }
        b[168..176].copy_from_slice(&544i64.to_be_bytes());
        b[348..352].copy_from_slice(&1i32.to_be_bytes());
        b[400 + 24..432].copy_from_slice(&(-7.5f64).to_be_bytes());
        let h = parse2(&b).unwrap();
        assert_eq!(h.endian, Endian::Big);
        assert_eq!(&h.dim[..4], &[3, 5, 6, 7]);
        assert_eq!((h.datatype, h.bitpix, h.vox_offset), (16, 32, 544.0));
        assert_eq!((h.sform_code, h.srow[0][3]), (1, -7.5));
        assert!(!h.pair);
    }

    #[test]
    fn pair_names() {
        let d = std::env::temp_dir().join(format!("rnd-nifti-pair-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        std::fs::write(d.join("a.img.gz"), b"").unwrap();
        assert_eq!(pair_data_file(&d.join("a.hdr")), Some(d.join("a.img.gz")));
        std::fs::write(d.join("a.img"), b"").unwrap();
        assert_eq!(pair_data_file(&d.join("a.hdr")), Some(d.join("a.img")));
        assert_eq!(pair_data_file(&d.join("a.nii")), None);
        std::fs::remove_dir_all(&d).unwrap();
    }
}
