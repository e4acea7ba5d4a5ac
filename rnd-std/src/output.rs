//! Output files that are safe to write: nothing half-written, nothing clobbered, no
//! planted link followed.
//!
//! [`Output::create`] is called before the work starts, so a wrong output is reported
//! before any time is spent: it checks the name, refuses an output that is one of the
//! inputs (compared by file identity, links resolved) and creates the temporary file the
//! result will be written into. [`Output::commit`] fills it and renames it over the
//! output; until then the output is untouched, and dropping an uncommitted `Output`
//! removes the temporary file.
//!
//! - A regular file (or a name that does not exist yet) is written through a temporary
//!   file `.rendr-tmp-XXXXXXXXXXXXXXXX` in the same directory, created exclusively
//!   (`O_EXCL`: a file, link or FIFO already there under that name is never opened; a new
//!   random name is tried instead), then renamed over the output. A symbolic link named
//!   as the output is replaced, never followed. A file replaced keeps its permissions.
//! - An existing character device or FIFO (`/dev/null`, a named pipe) is written into
//!   directly, never replaced; a FIFO is opened only when the data is ready. Block
//!   devices, sockets and directories are refused.
//! - `-` is standard output; a closed standard output is an error, as is any failed
//!   write to it.
//!
//! Temporary files still being written are listed, so that a signal handler can remove
//! them ([`remove_temp_files`]).

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

use crate::{Error, ErrorKind, Result};

static TEMP_FILES: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn temp_list() -> MutexGuard<'static, Vec<PathBuf>> {
    TEMP_FILES.lock().unwrap_or_else(|e| e.into_inner())
}

/// Removes every temporary output file still being written. For a signal handler: after
/// it, the outputs being written are as they were before the program started.
pub fn remove_temp_files() {
    for p in temp_list().iter() {
        let _ = std::fs::remove_file(p);
    }
}

/// The identity of the file `p` names, links followed (device and inode on Unix).
#[cfg(unix)]
fn file_id(p: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(p).ok().map(|m| (m.dev(), m.ino()))
}

#[cfg(not(unix))]
fn file_id(p: &Path) -> Option<PathBuf> {
    std::fs::canonicalize(p).ok()
}

/// Whether `a` and `b` name the same existing file (links resolved; `-` is never a
/// file).
pub fn same_file(a: &Path, b: &Path) -> bool {
    if a.as_os_str() == "-" || b.as_os_str() == "-" {
        return false;
    }
    match (file_id(a), file_id(b)) {
        (Some(x), Some(y)) => x == y,
        _ => false,
    }
}

/// A fresh 64-bit value for temporary names (unpredictable enough that a name cannot be
/// planted in advance; collisions are retried anyway).
fn random_u64() -> u64 {
    use std::hash::{BuildHasher, Hasher};
    use std::sync::atomic::{AtomicU64, Ordering};
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u64(COUNTER.fetch_add(1, Ordering::Relaxed));
    h.write_u32(std::process::id());
    if let Ok(t) = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH) {
        h.write_u128(t.as_nanos());
    }
    h.finish()
}

#[derive(Debug)]
enum Target {
    /// Standard output (a duplicate of descriptor 1).
    Stdout(File),
    /// A character device, opened now.
    Device(File),
    /// A FIFO, opened when the data is ready (opening blocks until a reader comes).
    Fifo,
    /// A temporary file in the output's directory, renamed over the output at the end.
    Temp {
        tmp: PathBuf,
        file: File,
        /// Permissions of the file being replaced, to keep.
        perms: Option<std::fs::Permissions>,
    },
    /// Committed (or given up): nothing left to clean.
    Done,
}

/// An output file being prepared: see the [module documentation](self).
#[derive(Debug)]
pub struct Output {
    path: PathBuf,
    target: Target,
}

fn dir_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

impl Output {
    /// Prepares `path` for writing (`-` = standard output), refusing it when it is one
    /// of `inputs` (the same file by identity, whatever the spelling or links).
    ///
    /// # Errors
    /// An empty name or one ending in `/`, a directory, block device or socket, an
    /// output that is one of the inputs, a missing or unwritable directory, a closed
    /// standard output.
    pub fn create<P: AsRef<Path>>(path: &Path, inputs: &[P]) -> Result<Output> {
        if path.as_os_str() == "-" {
            return Ok(Output {
                path: path.to_path_buf(),
                target: Target::Stdout(stdout_file()?),
            });
        }
        if path.as_os_str().is_empty() {
            return Err(out_msg("output file name is empty"));
        }
        if path.file_name().is_none() || path.to_string_lossy().ends_with('/') {
            return Err(out_at(path, "output name is a directory, not a file"));
        }
        for i in inputs {
            if same_file(path, i.as_ref()) {
                let i = i.as_ref();
                let what = if i == path {
                    "output is also an input".to_string()
                } else {
                    format!("output is the same file as input {}", i.display())
                };
                return Err(out_at(
                    path,
                    format!("{what}; writing would overwrite the input"),
                ));
            }
        }
        let mut perms = None;
        match std::fs::metadata(path) {
            Ok(m) if m.is_dir() => {
                return Err(out_at(path, "output is a directory"));
            }
            Ok(m) if m.is_file() => {
                // A link to a regular file is replaced by the new file, not followed.
                if std::fs::symlink_metadata(path).is_ok_and(|l| l.is_file()) {
                    perms = Some(m.permissions());
                }
            }
            Ok(m) => return Output::special(path, &m),
            Err(_) => {}
        }
        let dir = dir_of(path);
        match std::fs::metadata(&dir) {
            Ok(m) if m.is_dir() => {}
            Ok(_) => {
                return Err(out_at(
                    path,
                    format!("can't create output: {} is not a directory", dir.display()),
                ))
            }
            Err(e) => {
                return Err(out_at(
                    path,
                    format!(
                        "can't create output: directory {} {}",
                        dir.display(),
                        if e.kind() == std::io::ErrorKind::NotFound {
                            "does not exist".to_string()
                        } else {
                            format!("can't be read ({e})")
                        }
                    ),
                ))
            }
        }
        let (tmp, file) = create_temp(path, &dir)?;
        Ok(Output {
            path: path.to_path_buf(),
            target: Target::Temp { tmp, file, perms },
        })
    }

    #[cfg(unix)]
    fn special(path: &Path, m: &std::fs::Metadata) -> Result<Output> {
        use std::os::unix::fs::FileTypeExt;
        let t = m.file_type();
        let target = if t.is_char_device() {
            let f = std::fs::OpenOptions::new()
                .write(true)
                .open(path)
                .map_err(|e| Error::io(path, "can't open output device", e))?;
            Target::Device(f)
        } else if t.is_fifo() {
            Target::Fifo
        } else if t.is_block_device() {
            return Err(out_at(
                path,
                "output is a block device; refusing to write an image over a disk",
            ));
        } else if t.is_socket() {
            return Err(out_at(path, "output is a socket"));
        } else {
            return Err(out_at(path, "output is not a regular file"));
        };
        Ok(Output {
            path: path.to_path_buf(),
            target,
        })
    }

    #[cfg(not(unix))]
    fn special(path: &Path, _m: &std::fs::Metadata) -> Result<Output> {
        Err(out_at(path, "output is not a regular file"))
    }

    /// The output's name as given.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Writes the output through `fill` and puts it in place. On any failure the
    /// output is as it was and the temporary file is gone.
    ///
    /// # Errors
    /// What `fill` returns (with the output's name added), write, flush and rename
    /// failures.
    pub fn commit(mut self, fill: impl FnOnce(&mut dyn Write) -> Result<()>) -> Result<()> {
        let path = self.path.clone();
        match std::mem::replace(&mut self.target, Target::Done) {
            Target::Stdout(f) => write_through(f, fill).map_err(|e| stdout_error(&e)),
            Target::Device(f) => write_through(f, fill).map_err(|e| e.with_path(&path)),
            Target::Fifo => {
                let f = std::fs::OpenOptions::new()
                    .write(true)
                    .open(&path)
                    .map_err(|e| Error::io(&path, "can't open output", e))?;
                write_through(f, fill).map_err(|e| e.with_path(&path))
            }
            Target::Temp { tmp, file, perms } => {
                let r = (|| {
                    let f = write_file(file, fill).map_err(|e| e.with_path(&path))?;
                    if let Some(p) = perms {
                        let _ = f.set_permissions(p);
                    }
                    let _ = f.sync_all();
                    drop(f);
                    // Under the list's lock, so a signal handler sees either the
                    // temporary file or the finished output, never both or neither.
                    let mut list = temp_list();
                    let r = std::fs::rename(&tmp, &path)
                        .map_err(|e| Error::io(&path, "can't move output into place", e));
                    list.retain(|x| x != &tmp);
                    r
                })();
                if r.is_err() {
                    remove_temp(&tmp);
                }
                r
            }
            Target::Done => Ok(()),
        }
    }
}

impl Drop for Output {
    fn drop(&mut self) {
        if let Target::Temp { tmp, .. } = &self.target {
            remove_temp(tmp);
        }
    }
}

fn remove_temp(tmp: &Path) {
    let mut list = temp_list();
    let _ = std::fs::remove_file(tmp);
    list.retain(|x| x != tmp);
}

/// Creates a new temporary file next to `path` (in `dir`) exclusively, registering it
/// for removal by a signal handler.
fn create_temp(path: &Path, dir: &Path) -> Result<(PathBuf, File)> {
    for _ in 0..64 {
        let tmp = dir.join(format!(".rendr-tmp-{:016x}", random_u64()));
        let mut list = temp_list();
        match std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)
        {
            Ok(f) => {
                list.push(tmp.clone());
                return Ok((tmp, f));
            }
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => {
                return Err(Error::io(
                    path,
                    &format!("can't create output (in {})", dir.display()),
                    e,
                ))
            }
        }
    }
    Err(out_at(
        path,
        "can't create output: 64 temporary names in a row were taken",
    ))
}

fn write_file(f: File, fill: impl FnOnce(&mut dyn Write) -> Result<()>) -> Result<File> {
    let mut w = std::io::BufWriter::with_capacity(1 << 16, f);
    fill(&mut w)?;
    w.into_inner()
        .map_err(|e| out_msg(format!("can't write: {}", e.error())))
}

fn write_through(f: File, fill: impl FnOnce(&mut dyn Write) -> Result<()>) -> Result<()> {
    write_file(f, fill).map(drop)
}

fn stdout_error(e: &Error) -> Error {
    out_msg(format!("(stdout): {}", e.msg))
}

/// A handle on standard output that reports every failed write (Rust's own `Stdout`
/// treats a closed descriptor 1 as a sink that swallows everything).
///
/// # Errors
/// When standard output is closed.
pub fn stdout() -> Result<File> {
    stdout_file()
}

#[cfg(unix)]
fn stdout_file() -> Result<File> {
    use std::os::fd::FromRawFd;
    let closed = || out_msg("(stdout): standard output is closed; nowhere to write the output");
    // SAFETY: fcntl(F_DUPFD_CLOEXEC) on descriptor 1 only duplicates it (or fails with
    // EBADF when it is closed); it touches no memory.
    let fd = unsafe { libc::fcntl(1, libc::F_DUPFD_CLOEXEC, 3) };
    if fd < 0 {
        return Err(closed());
    }
    // SAFETY: `fd` was just created by fcntl and is owned by nothing else.
    let f = unsafe { File::from_raw_fd(fd) };
    // Rust's runtime opens /dev/null read-write on a descriptor 0-2 that a program was
    // started without; a shell's `>/dev/null` opens it write-only. So descriptor 1 on
    // /dev/null read-write means standard output was closed.
    // SAFETY: F_GETFL only reads the descriptor's flags.
    let flags = unsafe { libc::fcntl(fd, libc::F_GETFL) };
    if flags >= 0 && flags & libc::O_ACCMODE == libc::O_RDWR && is_dev_null(&f) {
        return Err(closed());
    }
    Ok(f)
}

#[cfg(unix)]
fn is_dev_null(f: &File) -> bool {
    use std::os::unix::fs::{FileTypeExt, MetadataExt};
    match (f.metadata(), std::fs::metadata("/dev/null")) {
        (Ok(a), Ok(b)) => a.file_type().is_char_device() && a.rdev() == b.rdev(),
        _ => false,
    }
}

#[cfg(not(unix))]
fn stdout_file() -> Result<File> {
    Err(out_msg(
        "(stdout): writing to standard output needs a Unix system here; give a file name",
    ))
}

/// Writes to `path` through `fill` in one step ([`Output::create`] with no inputs, then
/// [`Output::commit`]).
///
/// # Errors
/// As [`Output::create`] and [`Output::commit`].
pub fn write_atomic(path: &Path, fill: impl FnOnce(&mut dyn Write) -> Result<()>) -> Result<()> {
    Output::create::<&Path>(path, &[])?.commit(fill)
}

/// An [`ErrorKind::Output`] error about `path`.
fn out_at(path: &Path, msg: impl Into<String>) -> Error {
    Error::at(path, msg).with_kind(ErrorKind::Output)
}

/// An [`ErrorKind::Output`] error.
fn out_msg(msg: impl Into<String>) -> Error {
    Error::msg(msg).with_kind(ErrorKind::Output)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmpdir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!(
            "rnd-std-output-{name}-{}-{:x}",
            std::process::id(),
            random_u64()
        ));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn put(p: &Path, bytes: &[u8]) {
        write_atomic(p, |w| {
            w.write_all(bytes).map_err(|e| Error::msg(e.to_string()))
        })
        .unwrap();
    }

    fn leftovers(d: &Path) -> Vec<String> {
        std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.contains("rendr-tmp"))
            .collect()
    }

    #[test]
    fn dropped_output_leaves_nothing_and_keeps_the_old_file() {
        let d = tmpdir("drop");
        let p = d.join("o.txt");
        std::fs::write(&p, b"old").unwrap();
        let o = Output::create::<&Path>(&p, &[]).unwrap();
        assert_eq!(leftovers(&d).len(), 1);
        drop(o);
        assert!(leftovers(&d).is_empty());
        assert_eq!(std::fs::read(&p).unwrap(), b"old");
        // A failing fill: the same.
        let o = Output::create::<&Path>(&p, &[]).unwrap();
        let e = o
            .commit(|w| {
                w.write_all(b"partial").unwrap();
                Err(Error::msg("boom"))
            })
            .unwrap_err();
        assert!(e.to_string().contains("boom"));
        assert!(leftovers(&d).is_empty());
        assert_eq!(std::fs::read(&p).unwrap(), b"old");
        let _ = std::fs::remove_dir_all(d);
    }

    #[cfg(unix)]
    #[test]
    fn planted_links_are_never_followed() {
        let d = tmpdir("link");
        let victim = d.join("victim");
        std::fs::write(&victim, b"victim").unwrap();
        // The output itself a link to another file: the link is replaced.
        let out = d.join("out.txt");
        std::os::unix::fs::symlink(&victim, &out).unwrap();
        put(&out, b"new");
        assert_eq!(std::fs::read(&victim).unwrap(), b"victim");
        assert_eq!(std::fs::read(&out).unwrap(), b"new");
        assert!(!std::fs::symlink_metadata(&out)
            .unwrap()
            .file_type()
            .is_symlink());
        let _ = std::fs::remove_dir_all(d);
    }

    #[cfg(unix)]
    #[test]
    fn replaced_file_keeps_its_permissions() {
        use std::os::unix::fs::PermissionsExt;
        let d = tmpdir("perm");
        let p = d.join("o");
        std::fs::write(&p, b"old").unwrap();
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o600)).unwrap();
        put(&p, b"new");
        let m = std::fs::metadata(&p).unwrap().permissions().mode() & 0o777;
        assert_eq!(m, 0o600);
        let _ = std::fs::remove_dir_all(d);
    }

    #[test]
    fn inputs_are_compared_by_identity() {
        let d = tmpdir("ident");
        let p = d.join("in.nrrd");
        std::fs::write(&p, b"input").unwrap();
        let other = d.join(".").join("in.nrrd");
        let e = Output::create(&other, &[&p]).unwrap_err();
        assert!(e.to_string().contains("would overwrite the input"), "{e}");
        #[cfg(unix)]
        {
            let hard = d.join("hard");
            std::fs::hard_link(&p, &hard).unwrap();
            assert!(Output::create(&hard, &[&p]).is_err());
        }
        assert_eq!(std::fs::read(&p).unwrap(), b"input");
        assert!(leftovers(&d).is_empty());
        let _ = std::fs::remove_dir_all(d);
    }

    #[test]
    fn missing_directory_is_named_before_any_work() {
        let d = tmpdir("nodir");
        let p = d.join("no/such/dir/o.nrrd");
        let e = Output::create::<&Path>(&p, &[]).unwrap_err().to_string();
        assert!(e.contains("does not exist"), "{e}");
        let _ = std::fs::remove_dir_all(d);
    }

    #[test]
    fn long_names_fit() {
        let d = tmpdir("long");
        let name = "n".repeat(250);
        let p = d.join(&name);
        put(&p, b"x");
        assert_eq!(std::fs::read(&p).unwrap(), b"x");
        let _ = std::fs::remove_dir_all(d);
    }
}
