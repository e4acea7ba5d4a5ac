//! Volume file → renderable volume: voxel storage (f32 or i16) plus index-to-world
//! geometry, with the conversions made to render it (a leading axis of size 1 dropped,
//! samples of other types than `short` converted to `float`, ...) recorded so `info` can
//! report them. Any
//! format of [`crate::formats`] is read (NRRD, NIfTI, MetaImage, DICOM).

use std::path::Path;

use rnd_core::affine::Affine4;
use rnd_core::render::AnyVolume;
use rnd_core::volume::OwnedVolume;

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

/// The samples of a [`VolumeBuf`], borrowed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Samples<'a> {
    /// 32-bit float.
    F32(&'a [f32]),
    /// Signed 16-bit.
    I16(&'a [i16]),
}

/// The checked samples and geometry of a [`VolumeBuf`].
#[derive(Debug, Clone, PartialEq)]
enum Voxels {
    F32(OwnedVolume<f32>),
    I16(OwnedVolume<i16>),
}

/// A loaded volume: samples, sizes, geometry and what was done to make it renderable.
/// The samples and geometry are checked when it is made and cannot change after, so
/// [`VolumeBuf::view`] cannot fail.
///
/// ```
/// use rnd_std::prelude::*;
/// use rnd_std::volume_io::{VolumeBuf, VolumeData};
///
/// let v = VolumeBuf::new(VolumeData::I16(vec![0; 24]), [2, 3, 4], Affine4::IDENTITY).unwrap();
/// assert_eq!(v.view().sizes(), [2, 3, 4]);
/// assert!(VolumeBuf::new(VolumeData::I16(vec![0; 23]), [2, 3, 4], Affine4::IDENTITY).is_err());
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct VolumeBuf {
    vox: Voxels,
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
    /// A volume made in memory: samples (fast axis first), sizes and index-to-world
    /// (a NRRD volume without notes; `file_type` `float` or `short`).
    ///
    /// # Errors
    /// [`crate::ErrorKind::Core`] with [`rnd_core::ErrorKind::Volume`] when the sizes do
    /// not match the samples or `itow` is not an invertible affine matrix.
    pub fn new(data: VolumeData, sizes: [usize; 3], itow: Affine4) -> Result<VolumeBuf> {
        let (vox, file_type) = match data {
            VolumeData::F32(v) => (Voxels::F32(OwnedVolume::from_vec(v, sizes, itow)?), "float"),
            VolumeData::I16(v) => (Voxels::I16(OwnedVolume::from_vec(v, sizes, itow)?), "short"),
        };
        Ok(VolumeBuf {
            vox,
            file_type: file_type.to_string(),
            space: None,
            notes: Vec::new(),
            format: Format::Nrrd,
        })
    }

    /// Borrowed view for rendering and probing.
    pub fn view(&self) -> AnyVolume<'_> {
        match &self.vox {
            Voxels::F32(v) => AnyVolume::F32(v.view()),
            Voxels::I16(v) => AnyVolume::I16(v.view()),
        }
    }

    /// The samples, fast axis first.
    pub fn data(&self) -> Samples<'_> {
        match &self.vox {
            Voxels::F32(v) => Samples::F32(v.data()),
            Voxels::I16(v) => Samples::I16(v.data()),
        }
    }

    /// Sizes, fast axis first.
    pub fn sizes(&self) -> [usize; 3] {
        self.view().sizes()
    }

    /// Index-to-world.
    pub fn itow(&self) -> Affine4 {
        *self.view().itow()
    }

    /// Voxel type name: `real` (f32) or `short`.
    pub fn type_name(&self) -> &'static str {
        match self.vox {
            Voxels::F32(_) => "real",
            Voxels::I16(_) => "short",
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
///
/// # Errors
/// As [`crate::formats::read`] and [`volume_from_nrrd`]: IO errors, a file in no
/// format rendr reads or a bad one, memory beyond the process's limit; each naming the
/// file.
pub fn load_volume(path: &Path) -> Result<VolumeBuf> {
    load_volume_threads(path, 1)
}

/// [`load_volume`], reading large raw data with `threads` threads at once (the same
/// volume for any count).
///
/// # Errors
/// As [`load_volume`].
pub fn load_volume_threads(path: &Path, threads: usize) -> Result<VolumeBuf> {
    let l = crate::formats::read(path, threads)?;
    let mut v = volume_from_nrrd(l.nrrd).map_err(|e| e.with_path(path))?;
    v.format = l.format;
    v.notes.splice(0..0, l.notes);
    Ok(v)
}

/// Builds a volume from an in-memory NRRD.
///
/// # Errors
/// [`crate::ErrorKind::Format`] when the array is not 3-D (after dropping a leading
/// axis of size 1) or its geometry is unusable; [`crate::ErrorKind::Memory`] when
/// converting the samples needs more memory than there is.
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
    let mut vb = VolumeBuf::new(data, sizes, itow)?;
    vb.file_type = file_type;
    vb.space = space;
    vb.notes = notes;
    Ok(vb)
}
