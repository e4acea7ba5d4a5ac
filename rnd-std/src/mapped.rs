//! Read-only memory maps of raw sample data (Unix): a volume whose samples lie in its
//! file as this machine stores them is used in place, without a copy (no memory to
//! allocate and fill: the pages are the file's, shared with the system's cache).
//!
//! A map shows the file as it is while it is in use: a file changed by another program
//! during a render changes the samples, and one cut short makes the process stop with
//! `SIGBUS`. So only [`crate::volume_io::load_volume_mapped`] maps, when asked.

use std::fs::File;

/// A read-only private map of `len` bytes of a file from byte `off` on.
pub(crate) struct Mapping {
    /// Start of the mapped pages, and their length (from the page holding `off`).
    base: *mut libc::c_void,
    span: usize,
    /// Offset of the first wanted byte within the pages, and the wanted length.
    skip: usize,
    len: usize,
}

// SAFETY: the pages are mapped read-only and private, and `Mapping` hands out only
// shared byte slices of them, so using it from several threads is like sharing a `&[u8]`.
unsafe impl Send for Mapping {}
// SAFETY: as for `Send`.
unsafe impl Sync for Mapping {}

impl std::fmt::Debug for Mapping {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Mapping({} bytes)", self.len)
    }
}

impl Mapping {
    /// Maps bytes `off .. off + len` of `file` (which must hold them), its pages made
    /// present now. `None` where maps are not available or the system refuses one (the
    /// caller then reads the file).
    pub(crate) fn new(file: &File, off: u64, len: usize) -> Option<Mapping> {
        #[cfg(unix)]
        {
            use std::os::fd::AsRawFd;
            let page = 4096u64.max(page_size());
            let start = off / page * page;
            let skip = usize::try_from(off - start).ok()?;
            let span = skip.checked_add(len)?;
            let file_len = file.metadata().ok()?.len();
            if len == 0 || off.checked_add(len as u64)? > file_len {
                return None;
            }
            let start = libc::off_t::try_from(start).ok()?;
            #[cfg(target_os = "linux")]
            let flags = libc::MAP_PRIVATE | libc::MAP_POPULATE;
            #[cfg(not(target_os = "linux"))]
            let flags = libc::MAP_PRIVATE;
            // SAFETY: a new read-only private map of an open file's existing bytes, at an
            // address the system chooses (nothing else in the process is affected); the
            // result is checked before use.
            let base = unsafe {
                libc::mmap(
                    std::ptr::null_mut(),
                    span,
                    libc::PROT_READ,
                    flags,
                    file.as_raw_fd(),
                    start,
                )
            };
            if base == libc::MAP_FAILED {
                return None;
            }
            Some(Mapping {
                base,
                span,
                skip,
                len,
            })
        }
        #[cfg(not(unix))]
        {
            let _ = (file, off, len);
            None
        }
    }

    /// The mapped bytes.
    pub(crate) fn bytes(&self) -> &[u8] {
        // SAFETY: `base + skip .. + len` lies in the live read-only map (made in `new`,
        // removed only in `drop`), which no one writes through.
        unsafe { std::slice::from_raw_parts((self.base as *const u8).add(self.skip), self.len) }
    }
}

impl Drop for Mapping {
    fn drop(&mut self) {
        #[cfg(unix)]
        // SAFETY: the map made in `new`, removed once; nothing borrows it any more
        // (borrows of `bytes` end with the `Mapping`).
        unsafe {
            libc::munmap(self.base, self.span);
        }
    }
}

/// The system's page size.
#[cfg(unix)]
fn page_size() -> u64 {
    // SAFETY: sysconf only reads a system setting.
    let p = unsafe { libc::sysconf(libc::_SC_PAGESIZE) };
    u64::try_from(p).unwrap_or(4096)
}

/// Sample types used in place from a map: every bit pattern is a value.
pub(crate) trait Plain: Copy + 'static {}
impl Plain for f32 {}
impl Plain for i16 {}

/// The bytes of `m` as samples of `T`: `None` unless they are aligned for `T` and a whole
/// number of samples.
///
/// # Safety
/// The slice must not be used after the last clone of `m` is dropped: the caller keeps
/// a clone beside every copy of it, in private fields, and lends it out only with a
/// lifetime bound to those fields.
pub(crate) unsafe fn samples<T: Plain>(m: &std::sync::Arc<Mapping>) -> Option<&'static [T]> {
    let b = m.bytes();
    let size = std::mem::size_of::<T>();
    if !(b.as_ptr() as usize).is_multiple_of(std::mem::align_of::<T>())
        || !b.len().is_multiple_of(size)
    {
        return None;
    }
    // SAFETY: the bytes are aligned for T and a whole number of T, every bit pattern is
    // a T (`Plain`), and the map stays while the caller uses the slice (its contract).
    Some(unsafe { std::slice::from_raw_parts(b.as_ptr() as *const T, b.len() / size) })
}
