//! # rnd-std: files, threads and images for rendr
//!
//! The std layer around [`rnd_core`]: NRRD and plain-text array IO ([`nrrd`]), loading
//! volumes with their geometry ([`volume_io`]), the small text/NRRD inputs of the
//! renderer ([`files`]: transfer functions, LUTs, Levoy files, lights), output images
//! ([`image_out`]: NRRD or PNG) and multi-threaded rendering ([`parallel`]). Every error
//! ([`Error`]) names the file it concerns.
#![warn(missing_docs)]

pub mod error;
pub mod files;
pub mod image_out;
pub mod nrrd;
pub mod parallel;
pub mod volume_io;

pub use error::{Error, Result};

/// Total physical memory in bytes (Linux `/proc/meminfo`), if known.
pub fn mem_total() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = s.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
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
