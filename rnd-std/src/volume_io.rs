//! Volume file → renderable volume: voxel storage (f32 or i16) plus index-to-world
//! geometry, with the conversions made to render it (a leading axis of size 1 dropped,
//! samples of other types than `short` converted to `float`, ...) recorded so `info` can
//! report them. Any
//! format of [`crate::formats`] is read (NRRD, NIfTI, MetaImage, DICOM).

use std::path::Path;

use rnd_core::affine::Affine4;
use rnd_core::render::AnyVolume;
use rnd_core::volume::Volume;

use crate::formats::Format;
use crate::nrrd::{self, Centering, Data, Nrrd};
use crate::{Error, Result};

/// Voxel storage.
#[derive(Debug, Clone, PartialEq)]
pub enum VolumeData {
    /// 32-bit float (float input, or any non-short type converted).
    F32(Vec<f32>),
    /// Signed 16-bit (short input, kept at 2 bytes per voxel).
    I16(Vec<i16>),
}

/// A loaded volume: samples, sizes, geometry and what was done to make it renderable.
#[derive(Debug, Clone, PartialEq)]
pub struct VolumeBuf {
    /// Samples, fast axis first.
    pub data: VolumeData,
    /// Sizes, fast axis first.
    pub sizes: [usize; 3],
    /// Index-to-world.
    pub itow: Affine4,
    /// NRRD type name of the file's samples.
    pub file_type: String,
    /// World space name (`left-posterior-superior` when the file says so).
    pub space: Option<String>,
    /// Conversions applied, one sentence each; empty for a standard volume.
    pub notes: Vec<String>,
    /// The format of the file it was read from.
    pub format: Format,
}

impl VolumeBuf {
    /// Borrowed view for rendering.
    pub fn view(&self) -> AnyVolume<'_> {
        // Geometry was validated when the buffer was built.
        match &self.data {
            VolumeData::F32(v) => AnyVolume::F32(
                Volume::new(v, self.sizes, self.itow).expect("volume validated at load"),
            ),
            VolumeData::I16(v) => AnyVolume::I16(
                Volume::new(v, self.sizes, self.itow).expect("volume validated at load"),
            ),
        }
    }

    /// Voxel type name: `real` (f32) or `short`.
    pub fn type_name(&self) -> &'static str {
        match self.data {
            VolumeData::F32(_) => "real",
            VolumeData::I16(_) => "short",
        }
    }

    /// Minimum and maximum sample.
    pub fn min_max(&self) -> (f64, f64) {
        match self.view() {
            AnyVolume::F32(v) => {
                let (a, b) = v.min_max();
                (a as f64, b as f64)
            }
            AnyVolume::I16(v) => {
                let (a, b) = v.min_max();
                (a as f64, b as f64)
            }
        }
    }
}

/// Loads a volume from a file (`-` = stdin) of any format rendr reads.
pub fn load_volume(path: &Path) -> Result<VolumeBuf> {
    load_volume_threads(path, 1)
}

/// [`load_volume`], reading large raw data with `threads` threads at once (the same
/// volume for any count).
pub fn load_volume_threads(path: &Path, threads: usize) -> Result<VolumeBuf> {
    let l = crate::formats::read(path, threads)?;
    let mut v = volume_from_nrrd(l.nrrd).map_err(|e| e.with_path(path))?;
    v.format = l.format;
    v.notes.splice(0..0, l.notes);
    Ok(v)
}

/// Builds a volume from an in-memory NRRD.
#[allow(clippy::unnecessary_cast)] // each_data! covers f32 and f64 too
pub fn volume_from_nrrd(n: Nrrd) -> Result<VolumeBuf> {
    let h = &n.header;
    let mut notes = Vec::new();
    let mut sizes = h.sizes.clone();
    let mut axis_off = 0usize;
    if sizes.len() == 4 && sizes[0] == 1 {
        notes.push("dropped a leading axis of size 1".to_string());
        sizes.remove(0);
        axis_off = 1;
    }
    if sizes.len() != 3 {
        let what = if sizes.len() == 4 {
            " (vector or multi-channel data can't be rendered)"
        } else {
            ""
        };
        return Err(Error::msg(format!(
            "volume must be 3-D, this is {}-D (sizes {:?}){what}",
            h.sizes.len(),
            h.sizes
        )));
    }
    let sizes = [sizes[0], sizes[1], sizes[2]];
    let file_type = h.scalar.as_str().to_string();
    // Geometry.
    let sd = h.space_dim();
    let cent: Vec<Centering> = (0..3).map(|a| nrrd::centering(h, a + axis_off)).collect();
    let itow = if let Some(dirs) = &h.space_directions {
        let sd = sd.unwrap_or(3);
        if sd != 3 {
            return Err(Error::msg(format!(
                "space has dimension {sd}; need a 3-D world space"
            )));
        }
        let d: Vec<[f64; 3]> = (0..3)
            .map(|a| match dirs[a + axis_off].as_deref() {
                Some(&[x, y, z]) => Ok([x, y, z]),
                Some(v) => Err(Error::msg(format!(
                    "space directions: axis {a} vector has {} components, need 3",
                    v.len()
                ))),
                None => Err(Error::msg(format!(
                    "space directions: axis {a} is \"none\""
                ))),
            })
            .collect::<Result<_>>()?;
        let o = match h.space_origin.as_deref() {
            Some(&[x, y, z]) => [x, y, z],
            Some(o) => {
                return Err(Error::msg(format!(
                    "space origin has {} components, need 3",
                    o.len()
                )))
            }
            None => {
                notes.push("no space origin: using (0,0,0)".to_string());
                [0.0; 3]
            }
        };
        match h.space.as_deref() {
            Some("left-posterior-superior") => {}
            Some(s) => notes.push(format!(
                "world space is \"{s}\" (not LPS); its coordinates are used as is"
            )),
            None => notes.push("no named space (\"space dimension\" only)".to_string()),
        }
        Affine4::from_columns(d[0], d[1], d[2], o)
    } else {
        let sp: [f64; 3] = core::array::from_fn(|a| {
            h.spacings
                .as_ref()
                .map(|s| s[a + axis_off])
                .filter(|x| x.is_finite())
                .unwrap_or(f64::NAN)
        });
        let mut spc = [1.0; 3];
        if sp.iter().all(|x| x.is_finite()) {
            spc = sp;
            notes.push("no space directions: axis-aligned grid from \"spacings\"".to_string());
        } else {
            notes.push("no spacing recorded: world space = index space (spacing 1)".to_string());
        }
        if spc.contains(&0.0) {
            return Err(Error::msg("spacings: a spacing is 0"));
        }
        let mut o = [0.0; 3];
        if let Some(mins) = &h.axis_mins {
            for a in 0..3 {
                let m = mins[a + axis_off];
                if m.is_finite() {
                    o[a] = if cent[a] == Centering::Cell {
                        m + spc[a] / 2.0
                    } else {
                        m
                    };
                }
            }
            notes.push("origin from \"axis mins\"".to_string());
        }
        Affine4::from_columns([spc[0], 0., 0.], [0., spc[1], 0.], [0., 0., spc[2]], o)
    };
    if !itow.is_finite() {
        return Err(Error::msg(
            "space directions/origin have non-finite numbers",
        ));
    }
    if itow.affine_inverse().is_err() {
        return Err(Error::msg(
            "space directions are singular (axes are parallel or zero): can't invert index-to-world",
        ));
    }
    if cent.contains(&Centering::Node) {
        notes.push(
            "node-centred axes: samples are taken at the nodes (same index-to-world)".to_string(),
        );
    }
    let data = match n.data {
        Data::I16(v) => VolumeData::I16(v),
        Data::F32(v) => VolumeData::F32(v),
        other => {
            notes.push(format!(
                "{} samples converted to float",
                other.scalar_type()
            ));
            // The float copy exists beside the file's samples for a moment.
            let need = (other.len() as u64).saturating_mul(4);
            crate::check_memory(need, "converting the samples to float")?;
            let mut v: Vec<f32> = Vec::new();
            crate::try_reserve(&mut v, other.len(), "the float samples")?;
            crate::nrrd::each_data!(&other, src => v.extend(src.iter().map(|&x| x as f32)));
            VolumeData::F32(v)
        }
    };
    let space = h.space.clone();
    let vb = VolumeBuf {
        data,
        sizes,
        itow,
        file_type,
        space,
        notes,
        format: Format::Nrrd,
    };
    // Validate once so view() can't fail.
    match &vb.data {
        VolumeData::F32(v) => {
            Volume::new(v, sizes, itow)?;
        }
        VolumeData::I16(v) => {
            Volume::new(v, sizes, itow)?;
        }
    }
    Ok(vb)
}
