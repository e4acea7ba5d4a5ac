//! # rnd-std: files, threads and images for rendr
//!
//! The std layer around [`rnd_core`]: NRRD and plain-text array IO ([`nrrd`]), loading
//! volumes with their geometry ([`volume_io`]), the small text/NRRD inputs of the
//! renderer ([`files`]: transfer functions, LUTs, Levoy files, lights), output images
//! ([`image_out`]: NRRD or PNG) and multi-threaded rendering ([`parallel`]). Every error
//! ([`Error`]) names the file it concerns.
#![deny(missing_docs)]
#![deny(clippy::missing_errors_doc, clippy::missing_panics_doc)]
#![deny(clippy::undocumented_unsafe_blocks)]

mod codec;
pub mod error;
pub mod files;
pub mod formats;
pub mod image_out;
mod mapped;
pub mod nrrd;
pub mod output;
pub mod parallel;
pub mod volume_io;

pub use error::{Error, ErrorKind, Result};

/// What a program that loads, renders and writes volumes uses, in one
/// `use rnd_std::prelude::*;`: the core prelude (with this crate's [`Error`],
/// [`ErrorKind`] and [`Result`]; the core's as `CoreError`, `CoreErrorKind`) and the
/// std layer's loaders, writers and threaded rendering.
pub mod prelude {
    pub use rnd_core::prelude::{
        render, Affine4, AnyVolume, Blend, Camera, CameraSpec, KernelName, Levoy, Light,
        LightSpace, Lut, LutBuilder, OwnedVolume, Param, Phong, Probe, Probed, RenderParams,
        RenderSpec, Txf, TxfSpace, Volume, Voxel,
    };
    pub use rnd_core::{Error as CoreError, ErrorKind as CoreErrorKind};

    pub use crate::files::{load_levoy, load_lights, load_lut, load_txf};
    pub use crate::image_out::{write_image, Image};
    pub use crate::nrrd::{write_volume, Nrrd};
    pub use crate::parallel::{render_volume, render_with, Control, Progress};
    pub use crate::volume_io::{load_volume, VolumeBuf, VolumeData};
    pub use crate::{Error, ErrorKind, Result};
}

/// Total physical memory in bytes (Linux `/proc/meminfo`), if known.
pub fn mem_total() -> Option<u64> {
    let s = read_small("/proc/meminfo")?;
    let line = s.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// A small system file (`/proc`, `/sys`) read whole. Such files report no size, so a
/// plain `read_to_string` starts with a few bytes and grows, and `/proc/meminfo` is
/// made anew for every read: room for the whole file up front takes one read.
fn read_small(path: impl AsRef<std::path::Path>) -> Option<String> {
    use std::io::Read;
    let mut s = String::with_capacity(8192);
    std::fs::File::open(path)
        .ok()?
        .read_to_string(&mut s)
        .ok()?;
    Some(s)
}

/// The most memory this process may hold, as far as the system says: the least of
/// physical memory (`MemTotal`), the memory limit of its control group and of every
/// group above it (cgroup v2 `memory.max`, v1 `memory.limit_in_bytes`) and its
/// address-space and data-segment limits (`ulimit -v`, `ulimit -d`). None when nothing
/// is known. Checks of what a header or an option asks for compare with this before
/// allocating; the allocations themselves are fallible as well, since other processes
/// may hold part of it.
///
/// Physical memory and the groups' limits are read from their files once a process
/// (the first call; about 0.05 ms of reading `/proc` and `/sys` on a virtual machine,
/// which every render would otherwise spend again before its threads start); the
/// process's own limits, which it may change itself, on every call.
pub fn mem_limit() -> Option<u64> {
    static SYSTEM: std::sync::OnceLock<Option<u64>> = std::sync::OnceLock::new();
    let system = *SYSTEM.get_or_init(|| [mem_total(), cgroup_limit()].into_iter().flatten().min());
    [system, rlimit_limit()].into_iter().flatten().min()
}

fn cgroup_limit() -> Option<u64> {
    let text = read_small("/proc/self/cgroup")?;
    let mut best: Option<u64> = None;
    let mut take = |v: Option<u64>| {
        if let Some(v) = v {
            best = Some(best.map_or(v, |b| b.min(v)));
        }
    };
    let read_num = |p: std::path::PathBuf| -> Option<u64> { read_small(p)?.trim().parse().ok() };
    for line in text.lines() {
        let mut parts = line.splitn(3, ':');
        let (_, ctrl, path) = (parts.next()?, parts.next()?, parts.next()?);
        let (root, file) = if ctrl.is_empty() {
            ("/sys/fs/cgroup", "memory.max")
        } else if ctrl.split(',').any(|c| c == "memory") {
            ("/sys/fs/cgroup/memory", "memory.limit_in_bytes")
        } else {
            continue;
        };
        // The group's own limit and every ancestor's ("max" reads as no number).
        let mut p = std::path::PathBuf::from(path.trim_start_matches('/'));
        loop {
            take(read_num(std::path::Path::new(root).join(&p).join(file)));
            if !p.pop() {
                break;
            }
        }
    }
    best
}

#[cfg(unix)]
#[allow(clippy::unnecessary_cast)] // rlim_t is u64 on Linux, not on every Unix
fn rlimit_limit() -> Option<u64> {
    let get = |r| {
        let mut l = libc::rlimit {
            rlim_cur: 0,
            rlim_max: 0,
        };
        // SAFETY: getrlimit writes the limit into `l`, a valid rlimit we own.
        let ok = unsafe { libc::getrlimit(r, &mut l) } == 0;
        (ok && l.rlim_cur != libc::RLIM_INFINITY).then_some(l.rlim_cur as u64)
    };
    [get(libc::RLIMIT_AS), get(libc::RLIMIT_DATA)]
        .into_iter()
        .flatten()
        .min()
}

#[cfg(not(unix))]
fn rlimit_limit() -> Option<u64> {
    None
}

/// Refuses a request for `bytes` of memory (for `what`) beyond [`mem_limit`].
///
/// # Errors
/// When `bytes` exceeds the limit, naming both.
pub fn check_memory(bytes: u64, what: &str) -> Result<()> {
    if let Some(lim) = mem_limit() {
        if bytes > lim {
            return Err(Error::msg(format!(
                "{what} would need {} of memory; this process may use at most {}",
                human_bytes(bytes),
                human_bytes(lim)
            ))
            .with_kind(ErrorKind::Memory));
        }
    }
    Ok(())
}

/// Reserves room for exactly `additional` more elements of `v`; memory the system
/// refuses is an error ("the system refused … of memory for `what`"), not an abort.
///
/// # Errors
/// When the reservation fails.
pub fn try_reserve<T>(v: &mut Vec<T>, additional: usize, what: &str) -> Result<()> {
    v.try_reserve_exact(additional)
        .map_err(|_| refused::<T>(additional, what))
}

/// The error for `n` elements of `T` the system would not allocate for `what`.
fn refused<T>(n: usize, what: &str) -> Error {
    let bytes = (n as u64).saturating_mul(std::mem::size_of::<T>() as u64);
    Error::msg(format!(
        "the system refused {} of memory for {what}",
        human_bytes(bytes)
    ))
    .with_kind(ErrorKind::Memory)
}

/// Human-readable byte count ("1.5 GiB").
pub fn human_bytes(b: u64) -> String {
    let units = ["B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    let mut v = b as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < units.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{b} B")
    } else {
        format!("{v:.1} {}", units[u])
    }
}

/// The vector level the environment asks for: `RND_AVX2=0` turns AVX2 and AVX-512 off,
/// `RND_AVX512=0` AVX-512 (the same images, slower; for comparisons); otherwise the
/// best there is. Lowered to what the processor has when a render starts.
pub fn simd_level_from_env() -> rnd_core::simd::SimdLevel {
    use rnd_core::simd::SimdLevel;
    let off = |v: &str| std::env::var_os(v).is_some_and(|x| x == "0");
    if off("RND_AVX2") {
        SimdLevel::Baseline
    } else if off("RND_AVX512") {
        SimdLevel::Avx2
    } else {
        SimdLevel::Avx512
    }
}

/// The README's examples, run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
