//! Volume file → renderable volume: voxel storage (f32 or i16) plus index-to-world
//! geometry, with the conversions made to render it (a leading axis of size 1 dropped,
//! samples of other types than `short` converted to `float`, ...) recorded so `info` can
//! report them. Any
//! format of [`crate::formats`] is read (NRRD, NIfTI, MetaImage, DICOM).

use std::path::Path;
use std::sync::{Arc, OnceLock};

use rnd_core::affine::Affine4;
use rnd_core::brick::Brick;
use rnd_core::kernel::KernelName;
use rnd_core::render::AnyVolume;
use rnd_core::volume::{OwnedVolume, Volume};
use rnd_core::voxel::Voxel;

use crate::formats::Format;
use crate::mapped::Mapping;
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

/// The checked samples and geometry of a [`VolumeBuf`]: owned, or used in place from a
/// map of the file (the view's slice lies in the map, which the `Arc` keeps; the
/// `'static` lifetime never leaves this module: [`VolumeBuf::view`] lends it for as long
/// as the `VolumeBuf` is borrowed).
#[derive(Debug, Clone)]
enum Voxels {
    F32(OwnedVolume<f32>),
    I16(OwnedVolume<i16>),
    /// (The map is only kept, for the slice in the view.)
    MappedF32 {
        vol: Volume<'static, f32>,
        _map: Arc<Mapping>,
    },
    MappedI16 {
        vol: Volume<'static, i16>,
        _map: Arc<Mapping>,
    },
}

impl PartialEq for Voxels {
    /// The same samples, sizes and geometry, however they are held.
    fn eq(&self, o: &Voxels) -> bool {
        fn same<V: rnd_core::voxel::Voxel + PartialEq>(a: Volume<'_, V>, b: Volume<'_, V>) -> bool {
            a.sizes() == b.sizes() && a.itow() == b.itow() && a.data() == b.data()
        }
        match (self.view(), o.view()) {
            (AnyVolume::F32(a), AnyVolume::F32(b)) => same(a, b),
            (AnyVolume::I16(a), AnyVolume::I16(b)) => same(a, b),
            _ => false,
        }
    }
}

impl Voxels {
    fn view(&self) -> AnyVolume<'_> {
        match self {
            Voxels::F32(v) => AnyVolume::F32(v.view()),
            Voxels::I16(v) => AnyVolume::I16(v.view()),
            Voxels::MappedF32 { vol, .. } => AnyVolume::F32(*vol),
            Voxels::MappedI16 { vol, .. } => AnyVolume::I16(*vol),
        }
    }
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
    /// The skip grid renders keep for the next frame
    /// ([`crate::parallel::render_volume`]).
    grids: crate::parallel::KeptGrid,
    /// The copy with padded rows renders use, when it pays ([`VolumeBuf::render_view`]).
    padded: KeptPadded,
}

/// Bytes of padding [`VolumeBuf::render_view`] puts after each row (one cache line).
pub const ROW_PAD_BYTES: usize = 64;

/// The least size in bytes of a volume [`VolumeBuf::render_view`] pads (smaller ones
/// measured no quicker padded).
pub const PAD_MIN_BYTES: usize = 16 << 20;

/// Whether a volume of `sizes` samples of `bytes` bytes each, rendered with a kernel of
/// support `support`, is one that [`VolumeBuf::render_view`] renders from a copy with
/// padded rows where [`Padding`] allows it ([`VolumeBuf::pads`]): a volume of at least
/// [`PAD_MIN_BYTES`] whose rows are a multiple of 512 bytes long (a 256-sample float or
/// 512-sample short row: every few rows fall into the same cache sets, so a ray's
/// supports evict each other), rendered with a kernel of support 3 or more (box and
/// tent read too few rows to gain). Measured on a 256³ float volume (bspln3 MIPs of the
/// value and of the gradient magnitude: a quarter and a sixth less render time;
/// bench/RESULTS.md run 46).
/// [`crate::parallel::render_volume`] renders from the copy only without a skip grid.
///
/// ```
/// use rnd_std::volume_io::padding_pays;
///
/// assert!(padding_pays([256; 3], 4, 4));
/// assert!(!padding_pays([256; 3], 4, 2)); // tent
/// assert!(!padding_pays([257, 256, 256], 4, 4)); // rows do not alias
/// assert!(!padding_pays([128, 128, 256], 2, 4)); // 8 MiB
/// ```
pub fn padding_pays(sizes: [usize; 3], bytes: usize, support: usize) -> bool {
    let total = sizes.iter().fold(bytes, |n, &s| n.saturating_mul(s));
    support >= 3 && (sizes[0].saturating_mul(bytes)).is_multiple_of(512) && total >= PAD_MIN_BYTES
}

/// Whether renders of a [`VolumeBuf`] use a copy with padded rows
/// ([`VolumeBuf::set_padding`]); either way they give the same image bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Padding {
    /// Where [`padding_pays`] for the volume and the kernel, on a processor where the
    /// copy was measured to pay over several frames ([`padding_helps_here`]).
    #[default]
    Auto,
    /// As [`Padding::Auto`], for a volume rendered once: only on a processor where the
    /// copy was measured to pay for itself within the frame that makes it
    /// ([`padding_pays_in_one_frame_here`]).
    AutoOneFrame,
    /// Where [`padding_pays`] for the volume and the kernel, on any processor.
    Always,
    /// Never: renders read the volume as it is.
    Never,
}

/// Whether this processor is one on which [`Padding::Auto`] pads: an x86-64 processor
/// from AMD. Measured (bench/RESULTS.md): on an AMD Zen 5 the copy takes a quarter
/// (value) and a sixth (gradient magnitude) off a 256³ float volume's bspln3 MIPs and
/// pays for itself in one frame (run 46); on an Intel Xeon with AVX-512 it takes at most
/// 5% off later frames (none on an oblique view), while making it costs a first frame
/// more than that (7–26% of a whole `go`, its fresh memory; runs 53, 56).
pub fn padding_helps_here() -> bool {
    amd_family().is_some()
}

/// Whether this processor is one on which [`Padding::AutoOneFrame`] pads: an AMD
/// processor of family 0x1A (Zen 5) or later, where the copy paid for itself within one
/// frame (bench/RESULTS.md run 46). On an AMD Zen 4 (family 0x19) it did not: a single
/// `go` of the 256³ float volume's bspln3 MIPs took 3–6% longer with the copy, while
/// later frames of `turn` were 1.05× (gradient) to 1.2× (value) quicker (run 61).
pub fn padding_pays_in_one_frame_here() -> bool {
    amd_family().is_some_and(|f| f >= 0x1A)
}

/// The processor's family (CPUID leaf 1: base family, plus the extended family where
/// the base is 0xF) when it is an AMD processor; None otherwise.
fn amd_family() -> Option<u32> {
    #[cfg(target_arch = "x86_64")]
    {
        // (`unsafe` for the toolchains before `__cpuid` became safe.)
        #[allow(unused_unsafe)]
        // SAFETY: CPUID exists on every x86_64 processor; leaf 0 always.
        let v = unsafe { std::arch::x86_64::__cpuid(0) };
        // "AuthenticAMD" in ebx, edx, ecx.
        if (v.ebx, v.edx, v.ecx) != (0x6874_7541, 0x6974_6e65, 0x444d_4163) || v.eax < 1 {
            return None;
        }
        #[allow(unused_unsafe)]
        // SAFETY: as above; leaf 1 exists (the highest leaf, eax of leaf 0, is at least 1).
        let a = unsafe { std::arch::x86_64::__cpuid(1) }.eax;
        let base = (a >> 8) & 0xF;
        Some(if base == 0xF {
            base + ((a >> 20) & 0xFF)
        } else {
            base
        })
    }
    #[cfg(not(target_arch = "x86_64"))]
    None
}

/// A padded copy of a volume's samples: its rows `row` samples apart.
#[derive(Debug)]
enum Padded {
    F32(Vec<f32>, usize),
    I16(Vec<i16>, usize),
}

/// The padded copy a [`VolumeBuf`] keeps for its renders: made at the first render it
/// pays for (or never, when padding is off or memory is short). A copy of the volume
/// starts without one; two volumes compare equal whatever they keep.
#[derive(Debug, Default)]
struct KeptPadded {
    mode: Padding,
    copy: OnceLock<Option<Padded>>,
}

impl Clone for KeptPadded {
    fn clone(&self) -> Self {
        KeptPadded {
            mode: self.mode,
            copy: OnceLock::new(),
        }
    }
}

impl PartialEq for KeptPadded {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

/// `vol`'s samples with [`ROW_PAD_BYTES`] after each row (each row's last sample
/// repeated), and the row stride, copied on up to `threads` threads (a share of the
/// slices each); None when memory is short: the copy is an optimization, so it is not
/// made when it would take more than a quarter of what this process may hold
/// ([`crate::mem_limit`]) or the system refuses it.
fn pad_rows<V: Voxel>(vol: &Volume<'_, V>, threads: usize) -> Option<(Vec<V>, usize)> {
    let [s0, s1, s2] = vol.sizes();
    let row = s0 + ROW_PAD_BYTES / std::mem::size_of::<V>();
    let n = row.checked_mul(s1)?.checked_mul(s2)?;
    let bytes = (n as u64).saturating_mul(std::mem::size_of::<V>() as u64);
    if crate::mem_limit().is_some_and(|lim| bytes > lim / 4) {
        return None;
    }
    let mut out = Vec::new();
    out.try_reserve_exact(n).ok()?;
    let (src, sstride) = (vol.data(), vol.slice_stride());
    let per = s2.div_ceil(threads.clamp(1, s2));
    let dst = &mut out.spare_capacity_mut()[..n];
    std::thread::scope(|scope| {
        for (t, part) in dst.chunks_mut(per * row * s1).enumerate() {
            scope.spawn(move || {
                for (j, d) in part.chunks_mut(row).enumerate() {
                    // Row `g` of the volume: row g % s1 of slice g / s1.
                    let g = t * per * s1 + j;
                    let at = g / s1 * sstride + g % s1 * vol.row_stride();
                    let r = &src[at..at + s0];
                    let (head, pad) = d.split_at_mut(s0);
                    for (d, &x) in head.iter_mut().zip(r) {
                        d.write(x);
                    }
                    for d in pad {
                        d.write(r[s0 - 1]);
                    }
                }
            });
        }
    });
    // SAFETY: the threads above wrote every one of the first `n` elements (the chunks
    // of `row` elements partition them, and each element of a chunk is written from the
    // row or its repeated last sample), and `n` is within the capacity reserved.
    unsafe { out.set_len(n) };
    Some((out, row))
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
            grids: Default::default(),
            padded: Default::default(),
        })
    }

    /// Borrowed view for rendering and probing.
    pub fn view(&self) -> AnyVolume<'_> {
        self.vox.view()
    }

    /// A view to render with `kernel`: the same samples, from a copy with padded rows
    /// ([`Volume::padded`]) when [`VolumeBuf::pads`] (made on `threads` threads at the
    /// first such call and kept for the next; not when memory is short). Either view
    /// renders the same bits.
    pub fn render_view(&self, kernel: KernelName, threads: usize) -> AnyVolume<'_> {
        let view = self.view();
        if !self.pads(kernel) {
            return view;
        }
        let copy = self.padded.copy.get_or_init(|| match view {
            AnyVolume::F32(v) => pad_rows(&v, threads).map(|(d, r)| Padded::F32(d, r)),
            AnyVolume::I16(v) => pad_rows(&v, threads).map(|(d, r)| Padded::I16(d, r)),
        });
        let (sizes, itow) = (view.sizes(), *view.itow());
        let padded = match copy {
            Some(Padded::F32(d, r)) => Volume::padded(d, sizes, *r, itow).map(AnyVolume::F32),
            Some(Padded::I16(d, r)) => Volume::padded(d, sizes, *r, itow).map(AnyVolume::I16),
            None => return view,
        };
        padded.unwrap_or(view)
    }

    /// Whether [`VolumeBuf::render_view`] renders with `kernel` from a padded copy
    /// ([`padding_pays`], and [`VolumeBuf::set_padding`]'s [`Padding`] says so here).
    pub fn pads(&self, kernel: KernelName) -> bool {
        let bytes = match self.view() {
            AnyVolume::F32(_) => 4,
            AnyVolume::I16(_) => 2,
        };
        let here = match self.padded.mode {
            Padding::Never => return false,
            Padding::Always => true,
            Padding::Auto => padding_helps_here(),
            Padding::AutoOneFrame => padding_pays_in_one_frame_here(),
        };
        here && padding_pays(self.sizes(), bytes, kernel.support())
    }

    /// Whether a padded copy has been made.
    #[cfg(test)]
    pub(crate) fn has_padded_copy(&self) -> bool {
        matches!(self.padded.copy.get(), Some(Some(_)))
    }

    /// When renders use a copy with padded rows ([`VolumeBuf::render_view`];
    /// [`Padding::Auto`] by default). Drops a copy already made.
    pub fn set_padding(&mut self, mode: Padding) {
        self.padded = KeptPadded {
            mode,
            copy: OnceLock::new(),
        };
    }

    /// The samples, fast axis first.
    pub fn data(&self) -> Samples<'_> {
        match self.view() {
            AnyVolume::F32(v) => Samples::F32(v.data()),
            AnyVolume::I16(v) => Samples::I16(v.data()),
        }
    }

    /// Whether the samples are used in place from a map of the file
    /// ([`load_volume_mapped`]) rather than held in memory.
    pub fn is_mapped(&self) -> bool {
        matches!(
            self.vox,
            Voxels::MappedF32 { .. } | Voxels::MappedI16 { .. }
        )
    }

    /// Sizes, fast axis first.
    pub fn sizes(&self) -> [usize; 3] {
        self.view().sizes()
    }

    /// Index-to-world.
    pub fn itow(&self) -> Affine4 {
        *self.view().itow()
    }

    /// The skip grid kept between renders.
    pub(crate) fn grids(&self) -> &crate::parallel::KeptGrid {
        &self.grids
    }

    /// Voxel type name: `real` (f32) or `short`.
    pub fn type_name(&self) -> &'static str {
        match self.view() {
            AnyVolume::F32(_) => "real",
            AnyVolume::I16(_) => "short",
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

/// [`load_volume_threads`], except that a NRRD file whose samples are raw `float` or
/// `short` in this machine's byte order (at an offset aligned for the type) is used in
/// place through a read-only memory map: no copy and no memory to fill, so a large
/// volume is ready at once. Other files are read as [`load_volume_threads`] reads them;
/// the volume is the same either way ([`VolumeBuf::is_mapped`] tells which).
///
/// A map shows the file as it is while the volume is in use: change the file meanwhile
/// and the samples change; cut it short and the process stops (`SIGBUS`). Use
/// [`load_volume_threads`] for files that may change while they are rendered.
///
/// # Errors
/// As [`load_volume`].
pub fn load_volume_mapped(path: &Path, threads: usize) -> Result<VolumeBuf> {
    if path.as_os_str() != "-" && std::fs::metadata(path).is_ok_and(|m| m.is_file()) {
        if let Some((header, map)) = nrrd::read::map_raw(path)? {
            return mapped_volume(&header, map).map_err(|e| e.with_path(path));
        }
    }
    load_volume_threads(path, threads)
}

/// The volume of a NRRD header whose samples are `map`.
fn mapped_volume(h: &nrrd::Header, map: Arc<Mapping>) -> Result<VolumeBuf> {
    let Geometry { sizes, itow, notes } = geometry(h)?;
    let unaligned = || Error::msg("the mapped samples are not aligned for their type");
    // (Each slice is kept only in `Voxels`, beside the `map` it lies in, and lent out
    // only for as long as the `Voxels` is borrowed.)
    let vox = if h.scalar == nrrd::ScalarType::I16 {
        // SAFETY: see above.
        let d = unsafe { crate::mapped::samples::<i16>(&map) }.ok_or_else(unaligned)?;
        Voxels::MappedI16 {
            vol: Volume::new(d, sizes, itow)?,
            _map: map,
        }
    } else {
        // SAFETY: see above.
        let d = unsafe { crate::mapped::samples::<f32>(&map) }.ok_or_else(unaligned)?;
        Voxels::MappedF32 {
            vol: Volume::new(d, sizes, itow)?,
            _map: map,
        }
    };
    Ok(VolumeBuf {
        vox,
        file_type: h.scalar.as_str().to_string(),
        space: h.space.clone(),
        notes,
        format: Format::Nrrd,
        grids: Default::default(),
        padded: Default::default(),
    })
}

/// The part of a volume one process of a bricked render holds: the samples of `region`
/// (in a grid of `grid` samples), and the geometry of the whole grid.
#[derive(Debug)]
pub struct RegionBuf {
    /// The region's samples as a volume of the region's sizes (its ItoW is the grid's,
    /// so use it through [`RegionBuf::view`]).
    pub buf: VolumeBuf,
    /// The whole grid's sizes.
    pub grid: [usize; 3],
    /// The box held.
    pub region: Brick,
    /// Whether only the region was read from the file (a NRRD of raw, gzip or bzip2 data
    /// in one file); otherwise the whole volume was read and the region copied out.
    pub partial_read: bool,
}

impl RegionBuf {
    /// The region as a [`Volume::region`] of the grid, for rendering its bricks.
    ///
    /// # Errors
    /// [`crate::ErrorKind::Core`] (volume) when the fields were changed so that the
    /// region no longer lies in the grid or the samples do not fill it.
    pub fn view(&self) -> Result<AnyVolume<'_>> {
        let (g, r, itow) = (self.grid, self.region, self.buf.itow());
        Ok(match self.buf.data() {
            Samples::F32(d) => AnyVolume::F32(Volume::region(d, g, r, itow)?),
            Samples::I16(d) => AnyVolume::I16(Volume::region(d, g, r, itow)?),
        })
    }
}

/// Reads the box `pick(grid)` of the volume in `path` (given the grid's sizes): from a
/// NRRD of raw, gzip or bzip2 data only that box is read and held
/// ([`crate::nrrd::read_region`]); any other file is read whole, the box copied out and
/// the rest let go (so the peak memory is the whole volume's for those).
///
/// # Errors
/// As [`load_volume`], and those of `pick`.
pub fn load_volume_region(
    path: &Path,
    threads: usize,
    pick: impl FnOnce([usize; 3]) -> rnd_core::Result<Brick>,
) -> Result<RegionBuf> {
    let mut pick = Some(pick);
    let mut pick_once = |g: [usize; 3]| -> Result<Brick> {
        let f = pick
            .take()
            .ok_or_else(|| Error::msg("region chosen twice"))?;
        f(g).map_err(|e| Error::from(e).with_path(path))
    };
    // (None for anything but a NRRD read in parts.)
    if let Some((n, grid, region)) = crate::nrrd::read_region(path, &mut pick_once)? {
        let mut buf = volume_from_nrrd(n).map_err(|e| e.with_path(path))?;
        buf.format = Format::Nrrd;
        return Ok(RegionBuf {
            buf,
            grid,
            region,
            partial_read: true,
        });
    }
    let whole = load_volume_threads(path, threads)?;
    let grid = whole.sizes();
    let region = pick_once(grid)?;
    let cut = |b: &Brick| -> Result<VolumeData> {
        fn copy<T: Copy>(d: &[T], g: [usize; 3], b: &Brick) -> Result<Vec<T>> {
            let mut out = Vec::new();
            crate::try_reserve(&mut out, b.voxels(), "the region's samples")?;
            for k in b.lo[2]..b.hi[2] {
                for j in b.lo[1]..b.hi[1] {
                    let row = g[0] * (j + g[1] * k);
                    out.extend_from_slice(&d[row + b.lo[0]..row + b.hi[0]]);
                }
            }
            Ok(out)
        }
        if (0..3).any(|a| b.lo[a] >= b.hi[a] || b.hi[a] > grid[a]) {
            return Err(Error::msg(format!(
                "region {:?}..{:?} is empty or leaves the grid {grid:?}",
                b.lo, b.hi
            )));
        }
        Ok(match whole.data() {
            Samples::F32(d) => VolumeData::F32(copy(d, grid, b)?),
            Samples::I16(d) => VolumeData::I16(copy(d, grid, b)?),
        })
    };
    let data = cut(&region).map_err(|e| e.with_path(path))?;
    let mut buf = VolumeBuf::new(data, region.sizes(), whole.itow())?;
    buf.file_type = whole.file_type.clone();
    buf.space = whole.space.clone();
    buf.notes = whole.notes.clone();
    buf.format = whole.format;
    Ok(RegionBuf {
        buf,
        grid,
        region,
        partial_read: false,
    })
}

/// Builds a volume from an in-memory NRRD.
///
/// # Errors
/// [`crate::ErrorKind::Format`] when the header does not describe the data
/// ([`crate::nrrd::check_header`]), the array is not 3-D (after dropping a leading
/// axis of size 1) or its geometry is unusable; [`crate::ErrorKind::Memory`] when
/// converting the samples needs more memory than there is.
#[allow(clippy::unnecessary_cast)] // each_data! covers f32 and f64 too
pub fn volume_from_nrrd(n: Nrrd) -> Result<VolumeBuf> {
    // (A header made by hand may disagree with its data; one read from a file cannot.)
    crate::nrrd::check_header(&n)?;
    let Geometry {
        sizes,
        itow,
        mut notes,
    } = geometry(&n.header)?;
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
    let mut vb = VolumeBuf::new(data, sizes, itow)?;
    vb.file_type = n.header.scalar.as_str().to_string();
    vb.space = n.header.space.clone();
    vb.notes = notes;
    Ok(vb)
}

/// What a NRRD header says of a volume: its sizes, index-to-world and the decisions
/// made to read it as one.
struct Geometry {
    sizes: [usize; 3],
    itow: Affine4,
    notes: Vec<String>,
}

/// The [`Geometry`] of the volume a NRRD header describes (the checks of
/// [`volume_from_nrrd`] that need no samples).
fn geometry(h: &nrrd::Header) -> Result<Geometry> {
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
    Ok(Geometry { sizes, itow, notes })
}
