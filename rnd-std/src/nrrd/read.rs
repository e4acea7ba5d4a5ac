//! Reading NRRD files (and plain-text arrays via [`super::text`]).

use std::io::{BufRead, Read};
use std::path::{Path, PathBuf};

use super::header::{Centering, Encoding, Endian, Header, ScalarType};
use super::{Data, Nrrd};
use crate::{Error, Result};

/// Reads a NRRD or plain-text array from `path` (`-` = stdin).
///
/// ```
/// use rnd_std::nrrd::{self, Data, Nrrd, WriteOptions, Encoding};
///
/// let dir = std::env::temp_dir().join(format!("rnd-std-nrrd-doc-{}", std::process::id()));
/// std::fs::create_dir_all(&dir).unwrap();
/// let path = dir.join("a.nrrd");
/// let a = Nrrd::new(vec![3, 2], Data::I16(vec![1, -2, 3, -4, 5, -6])).unwrap();
/// let opt = WriteOptions { encoding: Encoding::Gzip, ..Default::default() };
/// nrrd::write(&a, &path, opt).unwrap();
/// let b = nrrd::read(&path).unwrap();
/// assert_eq!((b.sizes(), &b.data), (&[3, 2][..], &a.data));
/// // Plain text is read too: one row per line.
/// std::fs::write(dir.join("t.txt"), "0 1\n2 3\n4 5\n").unwrap();
/// assert_eq!(nrrd::read(&dir.join("t.txt")).unwrap().sizes(), &[2, 3]);
/// # std::fs::remove_dir_all(&dir).unwrap();
/// ```
///
/// # Errors
/// A missing or unreadable file ([`crate::ErrorKind::Io`]); a bad header, data that do
/// not match it, or more memory than the process may use ([`crate::ErrorKind::Format`],
/// [`crate::ErrorKind::Memory`]); each naming the file.
pub fn read(path: &Path) -> Result<Nrrd> {
    read_with_threads(path, 1)
}

/// Plain-text arrays (transfer functions, lights...) are read up to this size.
pub const TEXT_MAX: u64 = 64 << 20;

/// A NRRD header is read up to this size.
pub const HEADER_MAX: usize = 1 << 20;

/// [`read`], reading large raw data with `threads` threads at once (each fills its own
/// part of the samples; the same result for any count).
///
/// Every input is read with a limit derived from what its header says it needs (see
/// [`data_limit_bytes`]), never to its end: a pipe, a device such as `/dev/zero` or a data
/// file far larger than its volume costs no more than the volume.
///
/// # Errors
/// As [`read`].
pub fn read_with_threads(path: &Path, threads: usize) -> Result<Nrrd> {
    if path.as_os_str() == "-" {
        return read_from(std::io::stdin().lock(), Path::new("."), false)
            .map_err(|e| e.with_path(path));
    }
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, "can't read", e))?;
    if meta.is_dir() {
        return Err(Error::at(path, "is a directory, not a file"));
    }
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    if meta.is_file() {
        match read_streaming(path, threads) {
            Ok(Some(n)) => return Ok(n),
            Ok(None) => {}
            Err(e) => return Err(e.with_path(path)),
        }
    }
    let f = std::fs::File::open(path).map_err(|e| Error::io(path, "can't read", e))?;
    read_from(f, &dir, meta.is_file()).map_err(|e| e.with_path(path))
}

/// Reads a NRRD or text array from any byte stream, bounded: the header up to
/// [`HEADER_MAX`], the data up to [`data_limit_bytes`], a text array up to [`TEXT_MAX`].
pub(crate) fn read_from(r: impl Read, dir: &Path, regular: bool) -> Result<Nrrd> {
    let mut r = std::io::BufReader::with_capacity(1 << 16, r);
    let head = r.fill_buf().map_err(read_error)?;
    if !head.starts_with(b"NRRD") {
        if head.contains(&0) {
            return Err(Error::msg(
                "not a NRRD file (no NRRD magic) and not a text array (NUL bytes)",
            ));
        }
        let b = read_up_to(&mut r, TEXT_MAX + 1)?;
        if b.len() as u64 > TEXT_MAX {
            return Err(Error::msg(format!(
                "not a NRRD file, and longer than the {} a text array may have",
                crate::human_bytes(TEXT_MAX)
            )));
        }
        return read_bytes(&b, dir);
    }
    let text = read_header_text(&mut r)?;
    let (parsed, data_file) = parse_header(&text)?;
    let data = match data_file {
        None => {
            let (n, nbytes) = data_size(&parsed)?;
            if parsed.skips.byte < 0 {
                return Err(Error::msg(
                    "byte skip -1 (data at the end) needs raw data in a regular file; \
                     this input has no end to count back from",
                ));
            }
            skip_stream(&mut r, &parsed.skips, regular)?;
            let b = read_up_to(&mut r, data_limit_bytes(parsed.encoding, n, nbytes))?;
            decode(&parsed, &b, &Skips::default())?
        }
        Some(files) => read_detached(&parsed, &files, dir)?,
    };
    let Parsed { header, .. } = parsed;
    Ok(Nrrd { header, data })
}

/// The files reading `path` would read: `path` itself and, for a detached header, its
/// data files (resolved as the reader resolves them). For checking that an output does
/// not overwrite an input; a file that can't be read or parsed gives just itself (the
/// reader reports the problem).
pub fn input_files(path: &Path) -> Vec<PathBuf> {
    let mut out = vec![path.to_path_buf()];
    if path.as_os_str() == "-" || !std::fs::metadata(path).is_ok_and(|m| m.is_file()) {
        return out;
    }
    let Ok(f) = std::fs::File::open(path) else {
        return out;
    };
    let mut r = std::io::BufReader::new(f);
    if !r.fill_buf().is_ok_and(|h| h.starts_with(b"NRRD")) {
        return out;
    }
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    if let Ok((_, Some(files))) = read_header_text(&mut r).and_then(|t| parse_header(&t)) {
        out.extend(files.iter().map(|f| data_path(&dir, f)));
    }
    out
}

/// A detached data file named in a header: absolute, or relative to the header's
/// directory.
fn data_path(dir: &Path, f: &str) -> PathBuf {
    if Path::new(f).is_absolute() {
        PathBuf::from(f)
    } else {
        dir.join(f)
    }
}

/// A word from a file for a message: at most 40 characters (then an ellipsis).
pub(crate) fn short(w: &str) -> std::borrow::Cow<'_, str> {
    match w.char_indices().nth(40) {
        None => std::borrow::Cow::Borrowed(w),
        Some((cut, _)) => std::borrow::Cow::Owned(format!("{}...", &w[..cut])),
    }
}

fn read_error(e: std::io::Error) -> Error {
    Error::msg(format!("can't read: {e}"))
}

/// Reads at most `limit` bytes of `r` (fewer at its end).
fn read_up_to(r: impl Read, limit: u64) -> Result<Vec<u8>> {
    let mut b = Vec::new();
    r.take(limit).read_to_end(&mut b).map_err(read_error)?;
    Ok(b)
}

/// How many bytes of input may hold the data of `n` samples (`nbytes` bytes) in
/// `encoding`, after the header's skips; reading stops there. The margins:
/// - raw: exactly the data;
/// - gzip and bzip2: the data plus 1/64 of it plus 1 MiB (both formats grow
///   incompressible data by less than that);
/// - hex: 3 characters per byte plus 1 MiB (two digits and room for line breaks);
/// - ascii: 64 characters per value plus 1 MiB.
///
/// Skips are passed over without being kept: skipped lines up to [`SKIP_MAX`] bytes in
/// all, byte skips up to the end of a regular file or [`SKIP_MAX`] in a stream.
pub fn data_limit_bytes(encoding: Encoding, n: usize, nbytes: usize) -> u64 {
    let (n, nb) = (n as u64, nbytes as u64);
    match encoding {
        Encoding::Raw => nb,
        Encoding::Gzip | Encoding::Bzip2 => nb.saturating_add(nb / 64).saturating_add(1 << 20),
        Encoding::Hex => nb.saturating_mul(3).saturating_add(1 << 20),
        Encoding::Ascii => n.saturating_mul(64).saturating_add(1 << 20),
    }
}

/// Most bytes passed over by reading: skipped lines in all, and a byte skip in a stream
/// that is not a regular file.
pub const SKIP_MAX: u64 = 64 << 20;

/// Reads a header: lines up to the first empty one, at most [`HEADER_MAX`] bytes (a
/// line without end counts too), no NUL bytes. Text that is not UTF-8 is read as
/// Latin-1, as Teem does (one character per byte).
fn read_header_text(r: &mut impl std::io::BufRead) -> Result<String> {
    let mut text = Vec::new();
    loop {
        let mut line = Vec::new();
        let room = (HEADER_MAX + 1).saturating_sub(text.len()) as u64;
        let n = r
            .by_ref()
            .take(room)
            .read_until(b'\n', &mut line)
            .map_err(read_error)?;
        if n == 0 {
            break;
        }
        if text.len() + line.len() > HEADER_MAX {
            return Err(header_too_long());
        }
        let body = line.strip_suffix(b"\n").unwrap_or(&line);
        let body = body.strip_suffix(b"\r").unwrap_or(body);
        if body.is_empty() && !text.is_empty() {
            break;
        }
        text.extend_from_slice(&line);
    }
    header_string(&text)
}

fn header_too_long() -> Error {
    Error::msg(format!(
        "NRRD header is longer than {}",
        crate::human_bytes(HEADER_MAX as u64)
    ))
}

/// Header bytes as text: UTF-8 when valid, else Latin-1; NUL bytes refused.
fn header_string(b: &[u8]) -> Result<String> {
    if b.contains(&0) {
        return Err(Error::msg(
            "NRRD header contains a NUL byte (not a text header)",
        ));
    }
    Ok(match std::str::from_utf8(b) {
        Ok(s) => s.to_string(),
        Err(_) => b.iter().map(|&c| c as char).collect(),
    })
}

/// Reads a NRRD with raw, gzip or bzip2 data straight from the file into typed samples,
/// so a volume needs its own size in memory and not twice that: attached data, or a
/// detached header naming one regular data file. Returns None for everything else (text
/// arrays, several or non-regular data files, ascii/hex data), which [`read_from`]
/// reads. Errors about the data of a detached header name the data file.
fn read_streaming(path: &Path, threads: usize) -> Result<Option<Nrrd>> {
    read_streaming_with(path, |r, parsed, p| {
        stream_data(r, parsed, p, threads).map(Some)
    })
}

/// The header and a map of the samples of the NRRD in `path` when they can be used in
/// place: raw `float` or `short` data in this machine's byte order, in one regular
/// file (attached, or a detached header's one data file), at an offset aligned for the
/// type. `None` for anything else, or when the system maps nothing (read the file then).
/// The same checks as [`read`] (header, skips, the data's length) and the same errors.
pub(crate) fn map_raw(
    path: &Path,
) -> Result<Option<(Header, std::sync::Arc<crate::mapped::Mapping>)>> {
    let native = if cfg!(target_endian = "little") {
        Endian::Little
    } else {
        Endian::Big
    };
    let found = read_streaming_with(path, |mut r, parsed, p| {
        if parsed.encoding != Encoding::Raw
            || !matches!(parsed.scalar, ScalarType::F32 | ScalarType::I16)
            || parsed.endian != native
        {
            return Ok(None);
        }
        let file_len = r.get_ref().metadata().map(|m| m.len()).unwrap_or(u64::MAX);
        let (_, nbytes) = data_size(&parsed)?;
        to_data(&mut r, &parsed, file_len, nbytes, p)?;
        let off = {
            use std::io::Seek;
            r.stream_position()
                .map_err(|e| Error::io(p, "can't read", e))?
        };
        if !off.is_multiple_of(parsed.scalar.size() as u64) {
            return Ok(None);
        }
        let Some(m) = crate::mapped::Mapping::new(r.get_ref(), off, nbytes) else {
            return Ok(None);
        };
        let Parsed { header, .. } = parsed;
        Ok(Some((header, std::sync::Arc::new(m))))
    });
    found.map_err(|e| e.with_path(path))
}

/// [`read_streaming`]'s file handling around `data`, which reads the data from the
/// reader (positioned at the data's start, before the skips) and the parsed header.
fn read_streaming_with<T>(
    path: &Path,
    data: impl FnOnce(std::io::BufReader<std::fs::File>, Parsed, &Path) -> Result<Option<T>>,
) -> Result<Option<T>> {
    let f = std::fs::File::open(path).map_err(|e| Error::io(path, "can't read", e))?;
    let mut r = std::io::BufReader::with_capacity(1 << 16, f);
    let head = r.fill_buf().map_err(|e| Error::io(path, "can't read", e))?;
    if !head.starts_with(b"NRRD") {
        return Ok(None);
    }
    let text = read_header_text(&mut r)?;
    let (parsed, data_file) = parse_header(&text)?;
    let enc = parsed.encoding;
    if !matches!(enc, Encoding::Raw | Encoding::Gzip | Encoding::Bzip2) {
        return Ok(None);
    }
    let Some(files) = data_file else {
        return data(r, parsed, path);
    };
    let [one] = files.as_slice() else {
        return Ok(None);
    };
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let p = data_path(&dir, one);
    if !std::fs::metadata(&p).is_ok_and(|m| m.is_file()) {
        // Missing, a directory or a stream: read_from says what is wrong or reads it.
        return Ok(None);
    }
    let f = std::fs::File::open(&p).map_err(|e| Error::io(&p, "can't read detached data", e))?;
    let r = std::io::BufReader::with_capacity(1 << 16, f);
    data(r, parsed, &p).map_err(|e| e.with_path(&p))
}

/// A 3-D volume's samples in the box `pick(grid)` (for its `grid` of sizes: the three
/// axes of a 3-D array, or of a 4-D one whose first axis has size 1), read without
/// holding the rest: raw data by seeking from row to row, gzip and bzip2 data by
/// decompressing and dropping what lies outside the box, and nothing past the box's
/// last row. Returns the array of the box (its header's sizes those of the box; every
/// other field, geometry included, as the file says, so index positions stay the
/// grid's), the grid and the box; `None` when the file is not one read this way (other
/// encodings, several or non-regular data files, not 3-D: read it whole). Memory is
/// checked for the box only.
///
/// # Errors
/// As [`read`], and those of `pick`.
pub fn read_region(
    path: &Path,
    pick: impl FnOnce([usize; 3]) -> Result<rnd_core::brick::Brick>,
) -> Result<Option<(Nrrd, [usize; 3], rnd_core::brick::Brick)>> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, "can't read", e))?;
    if !meta.is_file() {
        return Ok(None);
    }
    read_streaming_with(path, |r, parsed, p| stream_region(r, parsed, p, pick))
        .map_err(|e| e.with_path(path))
}

/// The data source of [`stream_region`]: a raw file (skipped by seeking) or a
/// decompressing stream (skipped by reading).
enum Source {
    Raw(std::io::BufReader<std::fs::File>),
    Coded(Box<dyn Read>),
}

impl Source {
    fn skip(&mut self, n: u64) -> std::io::Result<()> {
        match self {
            Source::Raw(r) => {
                let n = i64::try_from(n).map_err(std::io::Error::other)?;
                r.seek_relative(n)
            }
            Source::Coded(r) => {
                let got = std::io::copy(&mut r.take(n), &mut std::io::sink())?;
                if got < n {
                    return Err(std::io::ErrorKind::UnexpectedEof.into());
                }
                Ok(())
            }
        }
    }
    fn read_exact(&mut self, b: &mut [u8]) -> std::io::Result<()> {
        match self {
            Source::Raw(r) => r.read_exact(b),
            Source::Coded(r) => r.read_exact(b),
        }
    }
}

/// Moves `r` past the header's skips to the data's start; raw data must fit in the rest
/// of the file (`file_len` bytes in all) for the `nbytes` the header asks for.
fn to_data(
    r: &mut std::io::BufReader<std::fs::File>,
    parsed: &Parsed,
    file_len: u64,
    nbytes: usize,
    path: &Path,
) -> Result<()> {
    let enc = parsed.encoding;
    if parsed.skips.byte == -1 {
        seek_tail(r, enc, file_len, nbytes)?;
    } else {
        skip_file(r, &parsed.skips, file_len)?;
    }
    let start = {
        use std::io::Seek;
        r.stream_position()
            .map_err(|e| Error::io(path, "can't read", e))?
    };
    if enc == Encoding::Raw && file_len.saturating_sub(start) < nbytes as u64 {
        return Err(Error::msg(format!(
            "data is truncated: sizes {:?} of {} need {nbytes} bytes, only {} present",
            parsed.sizes,
            parsed.scalar,
            file_len.saturating_sub(start)
        )));
    }
    Ok(())
}

fn stream_region(
    mut r: std::io::BufReader<std::fs::File>,
    mut parsed: Parsed,
    path: &Path,
    pick: impl FnOnce([usize; 3]) -> Result<rnd_core::brick::Brick>,
) -> Result<Option<(Nrrd, [usize; 3], rnd_core::brick::Brick)>> {
    let enc = parsed.encoding;
    let grid = match parsed.sizes[..] {
        [a, b, c] | [1, a, b, c] => [a, b, c],
        _ => return Ok(None),
    };
    let lead = parsed.sizes.len() - 3;
    let overflow = || Error::msg(format!("sizes {:?} overflow", parsed.sizes));
    let n = parsed.count().ok_or_else(overflow)?;
    let tsz = parsed.scalar.size();
    let nbytes = n.checked_mul(tsz).ok_or_else(overflow)?;
    let file_len = r.get_ref().metadata().map(|m| m.len()).unwrap_or(u64::MAX);
    to_data(&mut r, &parsed, file_len, nbytes, path)?;
    let b = pick(grid)?;
    if (0..3).any(|a| b.lo[a] >= b.hi[a] || b.hi[a] > grid[a]) {
        return Err(Error::msg(format!(
            "region {:?}..{:?} is empty or leaves the grid {grid:?}",
            b.lo, b.hi
        )));
    }
    let bs = b.sizes();
    let count = b.voxels();
    check_memory(
        count.saturating_mul(tsz),
        &format!("a region of {bs:?} of {}", parsed.scalar),
    )?;
    let mut src = match enc {
        Encoding::Gzip => Source::Coded(crate::codec::gunzip(r).map_err(|e| e.with_path(path))?),
        Encoding::Bzip2 => Source::Coded(crate::codec::bunzip2(r).map_err(|e| e.with_path(path))?),
        _ => Source::Raw(r),
    };
    let mut data = from_f64(parsed.scalar, &[]);
    reserve_all(&mut data, count)?;
    let failed = |e: std::io::Error| match e.kind() {
        std::io::ErrorKind::UnexpectedEof => Error::msg(format!(
            "data is truncated: sizes {:?} of {} need {nbytes} bytes",
            parsed.sizes, parsed.scalar
        )),
        _ if enc == Encoding::Raw => Error::io(path, "can't read", e),
        _ => Error::msg(format!("{} data can't be decompressed: {e}", enc.as_str())),
    };
    let mut row = vec![0u8; bs[0] * tsz];
    let mut at = 0usize;
    for k in b.lo[2]..b.hi[2] {
        for j in b.lo[1]..b.hi[1] {
            // Byte offsets fit: the whole array's size was checked above.
            let off = ((k * grid[1] + j) * grid[0] + b.lo[0]) * tsz;
            src.skip((off - at) as u64).map_err(failed)?;
            src.read_exact(&mut row).map_err(failed)?;
            append(&mut data, &row, parsed.endian, count)?;
            at = off + row.len();
        }
    }
    parsed.header.sizes = parsed.sizes[..lead].iter().copied().chain(bs).collect();
    let Parsed { header, .. } = parsed;
    Ok(Some((Nrrd { header, data }, grid, b)))
}

/// Reads the data [`read_streaming`] reads from `r` (positioned at the data's start,
/// before the header's skips), `path` naming it in errors.
fn stream_data(
    mut r: std::io::BufReader<std::fs::File>,
    parsed: Parsed,
    path: &Path,
    threads: usize,
) -> Result<Nrrd> {
    let enc = parsed.encoding;
    let file_len = r.get_ref().metadata().map(|m| m.len()).unwrap_or(u64::MAX);
    let (n, nbytes) = data_size(&parsed)?;
    let tsz = parsed.scalar.size();
    to_data(&mut r, &parsed, file_len, nbytes, path)?;
    #[cfg(unix)]
    if enc == Encoding::Raw && threads > 1 && nbytes >= PARALLEL_MIN {
        use std::io::Seek;
        let off = r
            .stream_position()
            .map_err(|e| Error::io(path, "can't read", e))?;
        let data = read_raw_parallel(r.get_ref(), off, parsed.scalar, parsed.endian, n, threads)
            .map_err(|e| Error::io(path, "can't read", e))?;
        let Parsed { header, .. } = parsed;
        return Ok(Nrrd { header, data });
    }
    let mut src: Box<dyn Read> = match enc {
        Encoding::Gzip => crate::codec::gunzip(r).map_err(|e| e.with_path(path))?,
        Encoding::Bzip2 => crate::codec::bunzip2(r).map_err(|e| e.with_path(path))?,
        _ => Box::new(r),
    };
    let mut data = from_f64(parsed.scalar, &[]);
    if enc == Encoding::Raw {
        // The file holds all the data (checked above): one allocation of the final size.
        reserve_all(&mut data, n)?;
    }
    let mut chunk = vec![0u8; (1 << 20) / tsz * tsz];
    let mut got = 0usize;
    let mut carry = 0usize;
    while got < nbytes {
        let want = (nbytes - got).min(chunk.len() - carry);
        let k = src
            .read(&mut chunk[carry..carry + want])
            .map_err(|e| Error::msg(format!("{} data can't be decompressed: {e}", enc.as_str())))?;
        if k == 0 {
            return Err(Error::msg(format!(
                "data is truncated: got {got} bytes, sizes {:?} of {} need {nbytes}",
                parsed.sizes, parsed.scalar
            )));
        }
        got += k;
        let avail = carry + k;
        let whole = avail / tsz * tsz;
        append(&mut data, &chunk[..whole], parsed.endian, n)?;
        chunk.copy_within(whole..avail, 0);
        carry = avail - whole;
    }
    if enc != Encoding::Raw {
        check_stream_end(&mut src, enc)?;
    }
    let Parsed { header, .. } = parsed;
    Ok(Nrrd { header, data })
}

/// Passes over the header's line and byte skips without keeping them: lines within
/// [`SKIP_MAX`] bytes in all; a byte skip to the end of a regular file (`regular`) or
/// within [`SKIP_MAX`] in a stream (a pipe has no end to trust).
fn skip_stream(r: &mut impl BufRead, sk: &Skips, regular: bool) -> Result<()> {
    let mut lines = r.by_ref().take(SKIP_MAX);
    for _ in 0..sk.line {
        let n = lines.skip_until(b'\n').map_err(read_error)?;
        if n == 0 || lines.limit() == 0 {
            return Err(Error::msg(format!(
                "line skip goes past the end of the data (or past {} of skipped lines)",
                crate::human_bytes(SKIP_MAX)
            )));
        }
    }
    let skip = sk.byte.max(0) as u64;
    if !regular && skip > SKIP_MAX {
        return Err(Error::msg(format!(
            "byte skip {skip} is beyond the {} rendr passes over in a stream (pipe or \
             device)",
            crate::human_bytes(SKIP_MAX)
        )));
    }
    if std::io::copy(&mut r.by_ref().take(skip), &mut std::io::sink()).map_err(read_error)? < skip {
        return Err(Error::msg("byte skip goes past the end of the data"));
    }
    Ok(())
}

/// [`skip_stream`] in a regular file: the byte skip by seeking (so a skip over most of
/// a large file costs nothing), refused when it passes the file's end.
fn skip_file(r: &mut std::io::BufReader<std::fs::File>, sk: &Skips, len: u64) -> Result<()> {
    use std::io::Seek;
    skip_stream(
        r,
        &Skips {
            line: sk.line,
            byte: 0,
        },
        true,
    )?;
    let skip = sk.byte.max(0);
    r.seek_relative(skip).map_err(read_error)?;
    let at = r.stream_position().map_err(read_error)?;
    if at > len {
        return Err(Error::msg("byte skip goes past the end of the data"));
    }
    Ok(())
}

/// Byte skip -1: the data are the last `need` bytes of a regular file of `len` bytes
/// (raw encoding only), after what has been read of it so far.
fn seek_tail(
    r: &mut std::io::BufReader<std::fs::File>,
    enc: Encoding,
    len: u64,
    need: usize,
) -> Result<()> {
    use std::io::{Seek, SeekFrom};
    if enc != Encoding::Raw {
        return Err(Error::msg("byte skip -1 needs raw encoding"));
    }
    let at = r.stream_position().map_err(read_error)?;
    if len.saturating_sub(at) < need as u64 {
        return Err(Error::msg(format!(
            "data is truncated: need {need} bytes, file has {}",
            len.saturating_sub(at)
        )));
    }
    r.seek(SeekFrom::Start(len - need as u64))
        .map_err(read_error)?;
    Ok(())
}

/// After the data a compressed stream must give, reads on to its end when that is
/// near, so the stream's own check (gzip's CRC-32, bzip2's block CRCs) is verified: a
/// corrupt stream is refused, as Teem refuses it. Data beyond what the sizes need, and
/// bytes after the last stream, are ignored.
fn check_stream_end(src: &mut dyn Read, enc: Encoding) -> Result<()> {
    let mut probe = [0u8; 1];
    match src.read(&mut probe) {
        Err(e) if e.to_string().contains("checksum") || e.to_string() == "Data" => {
            Err(Error::msg(format!("{} data is corrupt: {e}", enc.as_str())))
        }
        _ => Ok(()),
    }
}

/// Raw data of at least this many bytes is read by several threads when asked.
const PARALLEL_MIN: usize = 4 << 20;

/// A sample type read from raw bytes.
trait RawSample: Copy + Send {
    const SIZE: usize;
    /// The sample in byte order `e` held in `b` (exactly SIZE bytes).
    fn get(b: &[u8], e: Endian) -> Self;
}

macro_rules! raw_sample {
    ($($t:ty),*) => {$(
        impl RawSample for $t {
            const SIZE: usize = std::mem::size_of::<$t>();
            #[inline(always)]
            fn get(b: &[u8], e: Endian) -> Self {
                let a: [u8; std::mem::size_of::<$t>()] = b.try_into().expect("sample size");
                match e {
                    Endian::Little => <$t>::from_le_bytes(a),
                    Endian::Big => <$t>::from_be_bytes(a),
                }
            }
        }
    )*};
}
raw_sample!(i8, u8, i16, u16, i32, u32, i64, u64, f32, f64);

/// Reads `n` raw samples of type `scalar` in byte order `e` from file offset `off` of
/// `f` with `threads` threads, each populating and filling one part of the buffer.
#[cfg(unix)]
fn read_raw_parallel(
    f: &std::fs::File,
    off: u64,
    scalar: ScalarType,
    e: Endian,
    n: usize,
    threads: usize,
) -> std::io::Result<Data> {
    fn fill<T: RawSample>(
        v: &mut Vec<T>,
        f: &std::fs::File,
        off: u64,
        e: Endian,
        n: usize,
        threads: usize,
    ) -> std::io::Result<()> {
        use std::os::unix::fs::FileExt;
        crate::try_reserve(v, n, "the data")
            .map_err(|e| std::io::Error::new(std::io::ErrorKind::OutOfMemory, e.msg))?;
        advise_huge_pages(v.as_ptr() as usize, n * T::SIZE, false);
        let per = n.div_ceil(threads.max(1)).max(1);
        let parts = &mut v.spare_capacity_mut()[..n];
        std::thread::scope(|s| {
            let jobs: Vec<_> = parts
                .chunks_mut(per)
                .enumerate()
                .map(|(i, part)| {
                    s.spawn(move || -> std::io::Result<()> {
                        populate(part.as_ptr() as usize, std::mem::size_of_val(part));
                        let mut buf = vec![0u8; (256 << 10) / T::SIZE * T::SIZE];
                        let mut at = off + (i * per * T::SIZE) as u64;
                        for piece in part.chunks_mut(buf.len() / T::SIZE) {
                            let b = &mut buf[..piece.len() * T::SIZE];
                            f.read_exact_at(b, at)?;
                            for (d, c) in piece.iter_mut().zip(b.chunks_exact(T::SIZE)) {
                                d.write(T::get(c, e));
                            }
                            at += b.len() as u64;
                        }
                        Ok(())
                    })
                })
                .collect();
            jobs.into_iter().try_for_each(|j| {
                j.join()
                    .unwrap_or_else(|_| Err(std::io::Error::other("a reading thread failed")))
            })
        })?;
        // SAFETY: every one of the n samples was written above (each part whole, or an
        // error returned before this point), and the capacity is at least n.
        unsafe { v.set_len(n) };
        Ok(())
    }
    let mut data = from_f64(scalar, &[]);
    super::each_data!(&mut data, v => fill(v, f, off, e, n, threads))?;
    Ok(data)
}

/// Reserves room for `n` samples in `d` at once and, for large buffers, asks the kernel to
/// back them with huge pages (fewer TLB misses when rays wander through a big volume).
fn reserve_all(d: &mut Data, n: usize) -> Result<()> {
    fn reserve<T>(v: &mut Vec<T>, n: usize) -> Result<()> {
        crate::try_reserve(v, n, "the data")?;
        advise_huge_pages(
            v.as_ptr() as usize,
            v.capacity() * std::mem::size_of::<T>(),
            true,
        );
        Ok(())
    }
    super::each_data!(d, v => reserve(v, n))
}

/// Advises huge pages for the whole 2 MiB pages inside `[addr, addr + len)` (Linux; a
/// no-op elsewhere and for buffers under 8 MiB), and maps them all now when `fill`.
fn advise_huge_pages(addr: usize, len: usize, fill: bool) {
    #[cfg(target_os = "linux")]
    {
        const HUGE: usize = 2 << 20;
        if len < 4 * HUGE {
            return;
        }
        let start = addr.next_multiple_of(HUGE);
        let end = (addr + len) / HUGE * HUGE;
        if end > start {
            // SAFETY: [start, end) lies inside one live allocation; MADV_HUGEPAGE changes
            // only how the kernel backs those pages, never their contents, and a failure
            // (e.g. huge pages disabled) is harmless, so the result is ignored.
            unsafe {
                libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE);
            }
        }
        if fill {
            populate(addr, len);
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = (addr, len, fill);
}

/// Maps the pages of `[addr, addr + len)` (part of one live allocation) now, in one
/// call, rather than page by page as the data arrives (each fault is costly, more so in
/// a virtual machine). Older kernels refuse the advice; then the pages come on demand.
fn populate(addr: usize, len: usize) {
    #[cfg(target_os = "linux")]
    {
        if len == 0 {
            return;
        }
        let first = addr / 4096 * 4096;
        let last = (addr + len).next_multiple_of(4096);
        // SAFETY: the pages hold the caller's allocation; populating pages for writing
        // changes no contents (bytes of neighbouring data on a shared page included).
        unsafe {
            libc::madvise(
                first as *mut libc::c_void,
                last - first,
                libc::MADV_POPULATE_WRITE,
            );
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = (addr, len);
}

/// Appends the samples in `b` (whole samples) to `d`, reserving up to `total` samples
/// in steps as data arrives (so a stream that ends early never costs what its header
/// claimed); an allocation the system refuses is an error, not an abort.
fn append(d: &mut Data, b: &[u8], e: Endian, total: usize) -> Result<()> {
    fn go<T: RawSample>(v: &mut Vec<T>, b: &[u8], e: Endian, total: usize) -> Result<()> {
        let add = b.len() / T::SIZE;
        if v.capacity() - v.len() < add {
            let grow = (v.len() + add).max(2 * v.len()).min(total);
            crate::try_reserve(v, grow.saturating_sub(v.len()).max(add), "the data")?;
        }
        v.extend(b.chunks_exact(T::SIZE).map(|c| T::get(c, e)));
        Ok(())
    }
    super::each_data!(d, v => go(v, b, e, total))
}

/// Parses a NRRD (or plain-text array) held in memory; `dir` resolves detached data
/// files.
///
/// # Errors
/// [`crate::ErrorKind::Format`] for a bad header or data that do not match it;
/// [`crate::ErrorKind::Memory`] beyond the process's memory; IO errors of detached
/// data files.
pub fn read_bytes(bytes: &[u8], dir: &Path) -> Result<Nrrd> {
    if bytes.is_empty() {
        return Err(Error::msg(
            "empty (0 bytes): neither a NRRD file nor a text array",
        ));
    }
    if !bytes.starts_with(b"NRRD") {
        if bytes.starts_with(b"\x1f\x8b") {
            return Err(Error::msg(
                "not a NRRD file (looks like a bare gzip stream)",
            ));
        }
        // Text arrays written by hand may carry Latin-1 comments: read as for headers.
        let text = header_string(bytes).map_err(|_| {
            Error::msg("not a NRRD file (no NRRD magic) and not a text array (NUL bytes)")
        })?;
        return super::text::parse_text(&text);
    }
    let (hdr_text, data_off) = split_header(bytes)?;
    let (header, data_file) = parse_header(&hdr_text)?;
    let data = match data_file {
        None => decode(&header, &bytes[data_off..], &header.skips)?,
        Some(files) => read_detached(&header, &files, dir)?,
    };
    let Parsed { header, .. } = header;
    Ok(Nrrd { header, data })
}

/// Reads and decodes detached data files: each file is read only up to what its share
/// of the samples can need ([`data_limit_bytes`]), so a data file far larger than the
/// volume, or one file named many times, costs no more than the volume. Several files
/// must share the samples equally.
fn read_detached(h: &Parsed, files: &[String], dir: &Path) -> Result<Data> {
    let (n, nbytes) = data_size(h)?;
    let k = files.len();
    if k == 0 {
        return Err(Error::msg("data file: LIST names no files"));
    }
    if n % k != 0 {
        return Err(Error::msg(format!(
            "data file: {k} files can't hold {n} samples in equal parts"
        )));
    }
    let (share_n, share_bytes) = (n / k, nbytes / k);
    let limit = data_limit_bytes(h.encoding, share_n, share_bytes);
    // One file's payload: its skips passed over, then at most what its share needs.
    let read_one = |f: &String| -> Result<Vec<u8>> {
        let p = data_path(dir, f);
        let meta =
            std::fs::metadata(&p).map_err(|e| Error::io(&p, "can't read detached data", e))?;
        if meta.is_dir() {
            return Err(Error::at(&p, "detached data is a directory, not a file"));
        }
        let file =
            std::fs::File::open(&p).map_err(|e| Error::io(&p, "can't read detached data", e))?;
        let mut r = std::io::BufReader::with_capacity(1 << 16, file);
        if h.skips.byte == -1 {
            if !meta.is_file() {
                return Err(Error::at(
                    &p,
                    "byte skip -1 (data at the end) needs a regular file",
                ));
            }
            seek_tail(&mut r, h.encoding, meta.len(), share_bytes)
        } else if meta.is_file() {
            skip_file(&mut r, &h.skips, meta.len())
        } else {
            skip_stream(&mut r, &h.skips, false)
        }
        .map_err(|e| e.with_path(&p))?;
        read_up_to(r, limit).map_err(|e| e.with_path(&p))
    };
    if k == 1 {
        return decode(h, &read_one(&files[0])?, &Skips::default());
    }
    // Each file holds an equal share; their payloads are decoded as one (concatenated
    // compressed streams are one stream to the decoders).
    let mut joined = Vec::new();
    for f in files {
        let b = read_one(f)?;
        let take = if h.encoding == Encoding::Raw {
            b.len().min(share_bytes)
        } else {
            b.len()
        };
        joined.extend_from_slice(&b[..take]);
    }
    decode(h, &joined, &Skips::default())
}

/// Header plus reading-only fields.
struct Parsed {
    header: Header,
    skips: Skips,
}

impl std::ops::Deref for Parsed {
    type Target = Header;
    fn deref(&self) -> &Header {
        &self.header
    }
}

#[derive(Default, Clone, Copy)]
struct Skips {
    line: usize,
    byte: i64,
}

fn split_header(bytes: &[u8]) -> Result<(String, usize)> {
    // The header ends at the first empty line (or at EOF for detached headers).
    let mut pos = 0;
    let mut end = bytes.len();
    let mut data_off = bytes.len();
    while pos < bytes.len() {
        let nl = bytes[pos..]
            .iter()
            .position(|&b| b == b'\n')
            .map(|i| pos + i);
        let line_end = nl.unwrap_or(bytes.len());
        let line = &bytes[pos..line_end];
        let line = line.strip_suffix(b"\r").unwrap_or(line);
        if line.is_empty() && pos > 0 {
            end = pos;
            data_off = line_end + 1;
            break;
        }
        match nl {
            Some(n) => pos = n + 1,
            None => {
                pos = bytes.len();
            }
        }
    }
    if end > HEADER_MAX {
        return Err(header_too_long());
    }
    let text = header_string(&bytes[..end.min(bytes.len())])?;
    Ok((text, data_off.min(bytes.len())))
}

fn canonical_space(s: &str) -> String {
    let l = s.trim().to_ascii_lowercase();
    let c = match l.as_str() {
        "ras" => "right-anterior-superior",
        "las" => "left-anterior-superior",
        "lps" => "left-posterior-superior",
        "rast" => "right-anterior-superior-time",
        "last" => "left-anterior-superior-time",
        "lpst" => "left-posterior-superior-time",
        "scanner-xyz" => "scanner-xyz",
        "3d-right-handed" => "3D-right-handed",
        "3d-left-handed" => "3D-left-handed",
        _ => return s.trim().to_string(),
    };
    c.to_string()
}

fn parse_f64s(field: &str, v: &str, n: usize) -> Result<Vec<f64>> {
    let out: Vec<f64> = v
        .split_whitespace()
        .map(|w| {
            parse_f64(w).ok_or_else(|| {
                Error::msg(format!("{field}: can't parse \"{}\" as a number", short(w)))
            })
        })
        .collect::<Result<_>>()?;
    if out.len() != n {
        return Err(Error::msg(format!(
            "{field}: got {} values, dimension is {n}",
            out.len()
        )));
    }
    Ok(out)
}

/// Parses a number the way Teem writes them (also `nan`, `inf`, `-inf`).
pub(crate) fn parse_f64(w: &str) -> Option<f64> {
    let l = w.to_ascii_lowercase();
    match l.as_str() {
        "nan" | "-nan" | "+nan" => Some(f64::NAN),
        "inf" | "+inf" | "infinity" => Some(f64::INFINITY),
        "-inf" | "-infinity" => Some(f64::NEG_INFINITY),
        _ => w.parse::<f64>().ok(),
    }
}

fn parse_vector(s: &str) -> Result<Vec<f64>> {
    let inner = s
        .trim()
        .strip_prefix('(')
        .and_then(|x| x.strip_suffix(')'))
        .ok_or_else(|| Error::msg(format!("vector \"{s}\" is not in (x,y,z) form")))?;
    inner
        .split(',')
        .map(|w| {
            parse_f64(w.trim()).ok_or_else(|| {
                Error::msg(format!(
                    "can't parse \"{}\" in vector \"{}\"",
                    short(w),
                    short(s)
                ))
            })
        })
        .collect()
}

/// Splits "(a,b,c) none (d,e,f)" into items.
fn vector_items(v: &str) -> Vec<String> {
    let mut items = Vec::new();
    let mut cur = String::new();
    let mut depth = 0;
    for ch in v.chars() {
        match ch {
            '(' => {
                depth += 1;
                cur.push(ch);
            }
            ')' => {
                depth -= 1;
                cur.push(ch);
                if depth == 0 {
                    items.push(std::mem::take(&mut cur));
                }
            }
            c if c.is_whitespace() && depth == 0 => {
                if !cur.is_empty() {
                    items.push(std::mem::take(&mut cur));
                }
            }
            c => cur.push(c),
        }
    }
    if !cur.is_empty() {
        items.push(cur);
    }
    items
}

/// Largest number of dimensions accepted.
pub(crate) const MAX_DIM: usize = 16;

/// The header fields a NRRD may give once each.
const KNOWN_FIELDS: &[&str] = &[
    "type",
    "dimension",
    "sizes",
    "encoding",
    "endian",
    "content",
    "space",
    "space dimension",
    "space origin",
    "byte skip",
    "line skip",
    "data file",
    "space directions",
    "spacings",
    "axis mins",
    "axis maxs",
    "centerings",
    "kinds",
    "labels",
    "thicknesses",
    "units",
    "space units",
    "measurement frame",
    "block size",
    "min",
    "max",
    "old min",
    "old max",
    "number",
    "sample units",
];

fn parse_header(text: &str) -> Result<(Parsed, Option<Vec<String>>)> {
    let mut lines = text.lines();
    let magic = lines.next().unwrap_or("").trim_end();
    let version = match magic {
        "NRRD0001" => 1,
        "NRRD0002" => 2,
        "NRRD0003" => 3,
        "NRRD0004" => 4,
        "NRRD0005" => 5,
        _ => {
            let m: String = magic.chars().take(20).collect();
            return Err(Error::msg(format!(
                "bad magic \"{m}\" (need NRRD0001 .. NRRD0005)"
            )));
        }
    };
    let mut scalar = None;
    let mut dim: Option<usize> = None;
    let mut h = Header::new(ScalarType::U8, Vec::new());
    h.version = version;
    let mut sizes: Option<Vec<usize>> = None;
    let mut encoding = None;
    let mut endian = None;
    let mut skips = Skips::default();
    let mut data_file: Option<Vec<String>> = None;
    let mut list_mode = false;
    let mut seen: Vec<&'static str> = Vec::new();
    // Raw field strings that need the dimension to parse; parsed after the loop.
    let mut per_axis: Vec<(String, String)> = Vec::new();
    for (ln, line) in lines.enumerate() {
        let line = line.trim_end_matches('\r');
        if list_mode {
            if !line.trim().is_empty() {
                data_file
                    .get_or_insert_with(Vec::new)
                    .push(line.trim().to_string());
            }
            continue;
        }
        if let Some(c) = line.strip_prefix('#') {
            h.comments.push(c.trim().to_string());
            continue;
        }
        if line.trim().is_empty() {
            continue;
        }
        if let Some((k, v)) = line.split_once(":=") {
            if !k.contains(": ") {
                h.key_values.push((k.to_string(), v.to_string()));
                continue;
            }
        }
        let Some((field, value)) = line.split_once(": ").or_else(|| line.split_once(':')) else {
            return Err(Error::msg(format!(
                "header line {}: \"{}\" is not \"field: value\"",
                ln + 2,
                line.chars().take(60).collect::<String>()
            )));
        };
        let field = field.trim().to_ascii_lowercase();
        let value = value.trim();
        let canon = match field.as_str() {
            "byteskip" => "byte skip",
            "lineskip" => "line skip",
            "datafile" => "data file",
            "axismins" => "axis mins",
            "axismaxs" => "axis maxs",
            "centers" => "centerings",
            f => f,
        };
        if let Some(&known) = KNOWN_FIELDS.iter().find(|&&k| k == canon) {
            // Teem refuses a field given twice rather than letting one copy win.
            if seen.contains(&known) {
                return Err(Error::msg(format!(
                    "header line {}: field \"{known}\" given twice",
                    ln + 2
                )));
            }
            seen.push(known);
        }
        match canon {
            "type" => {
                scalar = Some(ScalarType::parse(value).ok_or_else(|| {
                    Error::msg(format!("type: unknown or unsupported type \"{value}\""))
                })?)
            }
            "dimension" => {
                let d: usize = value
                    .parse()
                    .map_err(|_| Error::msg(format!("dimension: can't parse \"{value}\"")))?;
                if d == 0 || d > MAX_DIM {
                    return Err(Error::msg(format!("dimension: {d} not in 1..={MAX_DIM}")));
                }
                dim = Some(d);
            }
            "sizes" => {
                let s: Vec<usize> = value
                    .split_whitespace()
                    .map(|w| {
                        w.parse::<usize>().map_err(|_| {
                            Error::msg(format!("sizes: can't parse \"{}\" as a size", short(w)))
                        })
                    })
                    .collect::<Result<_>>()?;
                sizes = Some(s);
            }
            "encoding" => {
                encoding = Some(Encoding::parse(value).ok_or_else(|| {
                    Error::msg(format!(
                        "encoding: unknown or unsupported encoding \"{value}\""
                    ))
                })?)
            }
            "endian" => {
                endian = Some(match value.to_ascii_lowercase().as_str() {
                    "little" => Endian::Little,
                    "big" => Endian::Big,
                    _ => {
                        return Err(Error::msg(format!(
                            "endian: \"{value}\" is not little or big"
                        )))
                    }
                })
            }
            "content" => h.content = Some(value.to_string()),
            "space" => h.space = Some(canonical_space(value)),
            "space dimension" => {
                let d: usize = value
                    .parse()
                    .map_err(|_| Error::msg(format!("space dimension: can't parse \"{value}\"")))?;
                if d == 0 || d > MAX_DIM {
                    return Err(Error::msg(format!("space dimension: {d} out of range")));
                }
                h.space_dimension = Some(d);
            }
            "space origin" => h.space_origin = Some(parse_vector(value)?),
            "byte skip" => {
                skips.byte = value
                    .parse()
                    .map_err(|_| Error::msg(format!("byte skip: can't parse \"{value}\"")))?;
                if skips.byte < -1 {
                    return Err(Error::msg(format!(
                        "byte skip: {} must be >= -1",
                        skips.byte
                    )));
                }
            }
            "line skip" => {
                skips.line = value
                    .parse()
                    .map_err(|_| Error::msg(format!("line skip: can't parse \"{value}\"")))?
            }
            "data file" => {
                if value == "LIST" || value.starts_with("LIST ") {
                    list_mode = true;
                    // The files follow, one a line; none at all is an error below.
                    data_file = Some(Vec::new());
                } else if value.contains('%') {
                    data_file = Some(expand_format(value)?);
                } else {
                    data_file = Some(vec![value.to_string()]);
                }
            }
            "space directions" | "spacings" | "axis mins" | "axis maxs" | "centerings"
            | "kinds" | "labels" => per_axis.push((canon.to_string(), value.to_string())),
            _ => h.other.push((field, value.to_string())),
        }
    }
    let scalar = scalar.ok_or_else(|| Error::msg("header has no \"type\" field"))?;
    let dim = dim.ok_or_else(|| Error::msg("header has no \"dimension\" field"))?;
    let sizes = sizes.ok_or_else(|| Error::msg("header has no \"sizes\" field"))?;
    if sizes.len() != dim {
        return Err(Error::msg(format!(
            "sizes: {} values but dimension is {dim}",
            sizes.len()
        )));
    }
    if sizes.contains(&0) {
        return Err(Error::msg(format!("sizes: an axis has size 0 ({sizes:?})")));
    }
    let encoding = encoding.ok_or_else(|| Error::msg("header has no \"encoding\" field"))?;
    let needs_endian = scalar.size() > 1
        && matches!(
            encoding,
            Encoding::Raw | Encoding::Gzip | Encoding::Bzip2 | Encoding::Hex
        );
    let endian = match endian {
        Some(e) => e,
        None if needs_endian => return Err(Error::msg("header has no \"endian\" field")),
        None => Endian::Little,
    };
    for (field, value) in per_axis {
        let words = || {
            value
                .split_whitespace()
                .map(str::to_string)
                .collect::<Vec<_>>()
        };
        let check = |n: usize| -> Result<()> {
            if n != dim {
                Err(Error::msg(format!(
                    "{field}: got {n} values, dimension is {dim}"
                )))
            } else {
                Ok(())
            }
        };
        match field.as_str() {
            "space directions" => {
                let items = vector_items(&value);
                check(items.len())?;
                let mut dirs = Vec::new();
                for it in items {
                    if it == "none" {
                        dirs.push(None);
                    } else {
                        let v = parse_vector(&it)?;
                        dirs.push(Some(v));
                    }
                }
                h.space_directions = Some(dirs);
            }
            "spacings" => h.spacings = Some(parse_f64s(&field, &value, dim)?),
            "axis mins" => h.axis_mins = Some(parse_f64s(&field, &value, dim)?),
            "axis maxs" => h.axis_maxs = Some(parse_f64s(&field, &value, dim)?),
            "centerings" => {
                let w = words();
                check(w.len())?;
                h.centerings = Some(
                    w.iter()
                        .map(|c| match c.as_str() {
                            "cell" => Ok(Centering::Cell),
                            "node" => Ok(Centering::Node),
                            "???" | "none" => Ok(Centering::Unknown),
                            _ => Err(Error::msg(format!("centerings: unknown centering \"{c}\""))),
                        })
                        .collect::<Result<_>>()?,
                );
            }
            "kinds" => {
                let w = words();
                check(w.len())?;
                h.kinds = Some(w);
            }
            "labels" => {
                let w: Vec<String> = value
                    .split('"')
                    .enumerate()
                    .filter(|(i, _)| i % 2 == 1)
                    .map(|(_, s)| s.to_string())
                    .collect();
                check(w.len())?;
                h.labels = Some(w);
            }
            _ => {}
        }
    }
    if let (Some(dirs), Some(sd)) = (&h.space_directions, h.space_dim()) {
        for d in dirs.iter().flatten() {
            if d.len() != sd {
                return Err(Error::msg(format!(
                    "space directions: vector of length {} but space dimension is {sd}",
                    d.len()
                )));
            }
        }
    }
    if let (Some(o), Some(sd)) = (&h.space_origin, h.space_dim()) {
        if o.len() != sd {
            return Err(Error::msg(format!(
                "space origin: {} values but space dimension is {sd}",
                o.len()
            )));
        }
    }
    h.scalar = scalar;
    h.sizes = sizes;
    h.encoding = encoding;
    h.endian = endian;
    Ok((Parsed { header: h, skips }, data_file))
}

fn expand_format(value: &str) -> Result<Vec<String>> {
    let w: Vec<&str> = value.split_whitespace().collect();
    if w.len() < 4 {
        return Err(Error::msg(format!(
            "data file: \"{value}\" needs <format> <min> <max> <step>"
        )));
    }
    let num = |s: &str| {
        s.parse::<i64>()
            .map_err(|_| Error::msg(format!("data file: can't parse \"{s}\" as an integer")))
    };
    let (min, max, step) = (num(w[1])?, num(w[2])?, num(w[3])?);
    // In i128 the range and count cannot overflow; the names are generated by count,
    // so no counter can wrap.
    let span = max as i128 - min as i128;
    let count = if step == 0 { -1 } else { span / step as i128 };
    if !(0..MAX_DATA_FILES as i128).contains(&count) {
        return Err(Error::msg(format!(
            "data file: range {min} {max} {step} does not give 1 to {MAX_DATA_FILES} files"
        )));
    }
    (0..=count)
        .map(|i| format_printf_int(w[0], (min as i128 + i * step as i128) as i64))
        .collect()
}

/// At most this many detached data files.
const MAX_DATA_FILES: usize = 100_000;

/// Expands one `%d` / `%03d`-style conversion (field width at most 64).
fn format_printf_int(fmt: &str, v: i64) -> Result<String> {
    let Some(p) = fmt.find('%') else {
        return Ok(fmt.to_string());
    };
    let rest = &fmt[p + 1..];
    let end = rest
        .find(|c: char| c.is_ascii_alphabetic())
        .ok_or_else(|| Error::msg(format!("data file: bad format \"{fmt}\"")))?;
    let spec = &rest[..end];
    if !matches!(&rest[end..end + 1], "d" | "u" | "i") {
        return Err(Error::msg(format!(
            "data file: only %d formats are supported (\"{fmt}\")"
        )));
    }
    let digits = spec.trim_start_matches('0');
    let width: usize = if digits.is_empty() {
        0
    } else {
        match digits.parse::<usize>() {
            Ok(w) if w <= 64 => w,
            _ => {
                return Err(Error::msg(format!(
                    "data file: field width \"{spec}\" in \"{fmt}\" is not a number up to 64"
                )))
            }
        }
    };
    let s = if spec.starts_with('0') {
        format!("{v:0width$}")
    } else {
        format!("{v:width$}")
    };
    Ok(format!("{}{}{}", &fmt[..p], s, &rest[end + 1..]))
}

/// Applies line and byte skips; `byte = -1` means "the data is the last `need` bytes".
fn skip_bytes<'a>(b: &'a [u8], sk: &Skips, need: Option<usize>) -> Result<&'a [u8]> {
    let mut b = b;
    for _ in 0..sk.line {
        match b.iter().position(|&c| c == b'\n') {
            Some(i) => b = &b[i + 1..],
            None => return Err(Error::msg("line skip goes past the end of the data")),
        }
    }
    if sk.byte == -1 {
        let need = need.ok_or_else(|| Error::msg("byte skip -1 needs raw encoding"))?;
        if b.len() < need {
            return Err(Error::msg(format!(
                "data is truncated: need {need} bytes, file has {}",
                b.len()
            )));
        }
        return Ok(&b[b.len() - need..]);
    }
    let s = sk.byte as usize;
    if s > b.len() {
        return Err(Error::msg("byte skip goes past the end of the data"));
    }
    Ok(&b[s..])
}

/// Refuses requests for more bytes than this process may allocate.
pub(crate) fn check_memory(bytes: usize, what: &str) -> Result<()> {
    crate::check_memory(bytes as u64, what)
}

/// Number of samples and bytes the header asks for, refused when they overflow or exceed
/// the machine's memory (checked before anything is allocated).
fn data_size(h: &Header) -> Result<(usize, usize)> {
    let overflow = || Error::msg(format!("sizes {:?} overflow", h.sizes));
    let n = h.count().ok_or_else(overflow)?;
    let nbytes = n.checked_mul(h.scalar.size()).ok_or_else(overflow)?;
    check_memory(nbytes, &format!("sizes {:?} of {}", h.sizes, h.scalar))?;
    Ok((n, nbytes))
}

fn decode(h: &Parsed, raw: &[u8], skips: &Skips) -> Result<Data> {
    let (n, nbytes) = data_size(h)?;
    let bytes: std::borrow::Cow<[u8]> = match h.encoding {
        Encoding::Raw => {
            let b = skip_bytes(raw, skips, Some(nbytes))?;
            if b.len() < nbytes {
                return Err(Error::msg(format!(
                    "data is truncated: sizes {:?} of {} need {nbytes} bytes, only {} present",
                    h.sizes,
                    h.scalar,
                    b.len()
                )));
            }
            std::borrow::Cow::Borrowed(&b[..nbytes])
        }
        Encoding::Gzip | Encoding::Bzip2 => {
            let b = skip_bytes(raw, skips, None)?;
            let mut out = Vec::new();
            let lim = nbytes as u64;
            let mut dec: Box<dyn Read> = if h.encoding == Encoding::Gzip {
                crate::codec::gunzip(b)?
            } else {
                crate::codec::bunzip2(b)?
            };
            (&mut dec).take(lim).read_to_end(&mut out).map_err(|e| {
                Error::msg(format!(
                    "{} data can't be decompressed: {e}",
                    h.encoding.as_str()
                ))
            })?;
            if out.len() == nbytes {
                check_stream_end(&mut dec, h.encoding)?;
            }
            if out.len() < nbytes {
                return Err(Error::msg(format!(
                    "data is truncated: {} stream gave {} bytes, sizes {:?} of {} need {nbytes}",
                    h.encoding.as_str(),
                    out.len(),
                    h.sizes,
                    h.scalar
                )));
            }
            std::borrow::Cow::Owned(out)
        }
        Encoding::Hex => {
            let b = skip_bytes(raw, skips, None)?;
            let mut out = Vec::new();
            let mut hi: Option<u8> = None;
            for &c in b {
                if out.len() == nbytes {
                    break;
                }
                let v = match c {
                    b'0'..=b'9' => c - b'0',
                    b'a'..=b'f' => c - b'a' + 10,
                    b'A'..=b'F' => c - b'A' + 10,
                    c if c.is_ascii_whitespace() => continue,
                    _ => {
                        return Err(Error::msg(format!(
                            "hex data: bad character {:?}",
                            c as char
                        )))
                    }
                };
                match hi.take() {
                    None => hi = Some(v),
                    Some(h4) => out.push(h4 << 4 | v),
                }
            }
            if out.len() < nbytes {
                return Err(Error::msg(format!(
                    "data is truncated: hex gave {} bytes, need {nbytes}",
                    out.len()
                )));
            }
            std::borrow::Cow::Owned(out)
        }
        Encoding::Ascii => {
            let b = skip_bytes(raw, skips, None)?;
            let text = std::str::from_utf8(b).map_err(|_| Error::msg("ascii data is not text"))?;
            return ascii_data(h.scalar, text, n);
        }
    };
    from_bytes(h.scalar, &bytes, h.endian, n)
}

fn ascii_data(t: ScalarType, text: &str, n: usize) -> Result<Data> {
    let mut vals = Vec::with_capacity(n.min(1 << 20));
    for w in text.split(|c: char| c.is_whitespace() || c == ',') {
        if w.is_empty() {
            continue;
        }
        if vals.len() == n {
            break;
        }
        let v = parse_f64(w)
            .ok_or_else(|| Error::msg(format!("ascii data: can't parse \"{}\"", short(w))))?;
        vals.push(v);
    }
    if vals.len() < n {
        return Err(Error::msg(format!(
            "data is truncated: ascii data has {} values, need {n}",
            vals.len()
        )));
    }
    Ok(from_f64(t, &vals))
}

/// Converts f64 values into typed data (saturating for integers).
pub(crate) fn from_f64(t: ScalarType, v: &[f64]) -> Data {
    match t {
        ScalarType::I8 => Data::I8(v.iter().map(|&x| x as i8).collect()),
        ScalarType::U8 => Data::U8(v.iter().map(|&x| x as u8).collect()),
        ScalarType::I16 => Data::I16(v.iter().map(|&x| x as i16).collect()),
        ScalarType::U16 => Data::U16(v.iter().map(|&x| x as u16).collect()),
        ScalarType::I32 => Data::I32(v.iter().map(|&x| x as i32).collect()),
        ScalarType::U32 => Data::U32(v.iter().map(|&x| x as u32).collect()),
        ScalarType::I64 => Data::I64(v.iter().map(|&x| x as i64).collect()),
        ScalarType::U64 => Data::U64(v.iter().map(|&x| x as u64).collect()),
        ScalarType::F32 => Data::F32(v.iter().map(|&x| x as f32).collect()),
        ScalarType::F64 => Data::F64(v.to_vec()),
    }
}

fn from_bytes(t: ScalarType, b: &[u8], e: Endian, n: usize) -> Result<Data> {
    let mut d = from_f64(t, &[]);
    append(&mut d, &b[..n * t.size()], e, n)?;
    Ok(d)
}

/// Reads `n` samples of type `t` in byte order `e` from `r` (raw binary, the way NIfTI,
/// MetaImage and DICOM store them), in pieces of at most 1 MiB so no second copy of the
/// data is held. The memory is checked and reserved first; fewer bytes than needed is an
/// error saying how many there were.
#[cfg_attr(not(any(feature = "nifti", feature = "metaimage")), allow(dead_code))]
pub(crate) fn read_samples(r: &mut dyn Read, t: ScalarType, e: Endian, n: usize) -> Result<Data> {
    let total = n
        .checked_mul(t.size())
        .ok_or_else(|| Error::msg(format!("{n} samples of {t} overflow")))?;
    check_memory(total, &format!("{n} samples of {t}"))?;
    // The stream's length is unknown (a gzip stream, a reader): memory grows with the
    // samples read (`append` doubles it), so a header that claims more than the data
    // holds costs no more than the data.
    let mut d = from_f64(t, &[]);
    let mut buf = vec![0u8; total.min(1 << 20)];
    let mut done = 0usize;
    while done < total {
        let want = (total - done).min(buf.len());
        let mut got = 0;
        while got < want {
            match r.read(&mut buf[got..want]) {
                Ok(0) => {
                    return Err(Error::msg(format!(
                        "data is truncated: {} bytes of samples, need {total}",
                        done + got
                    )))
                }
                Ok(k) => got += k,
                Err(err) if err.kind() == std::io::ErrorKind::Interrupted => {}
                Err(err) => return Err(read_error(err)),
            }
        }
        append(&mut d, &buf[..want], e, n)?;
        done += want;
    }
    Ok(d)
}

/// Parses `n` whitespace-separated numbers as samples of type `t` (ASCII data).
#[cfg_attr(not(feature = "metaimage"), allow(dead_code))]
pub(crate) fn text_samples(t: ScalarType, text: &str, n: usize) -> Result<Data> {
    ascii_data(t, text, n)
}

/// Centering helper for callers: per-axis centring or Unknown.
pub fn centering(h: &Header, axis: usize) -> Centering {
    h.centerings
        .as_ref()
        .and_then(|c| c.get(axis).copied())
        .unwrap_or(Centering::Unknown)
}
