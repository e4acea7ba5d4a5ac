//! Reading NRRD files (and plain-text arrays via [`super::text`]).

use std::io::Read;
use std::path::{Path, PathBuf};

use super::header::{Centering, Encoding, Endian, Header, ScalarType};
use super::{Data, Nrrd};
use crate::{Error, Result};

/// Reads a NRRD or plain-text array from `path` (`-` = stdin).
pub fn read(path: &Path) -> Result<Nrrd> {
    read_with_threads(path, 1)
}

/// [`read`], reading large raw data with `threads` threads at once (each fills its own
/// part of the samples; the same result for any count).
pub fn read_with_threads(path: &Path, threads: usize) -> Result<Nrrd> {
    if path.as_os_str() == "-" {
        let mut b = Vec::new();
        std::io::stdin()
            .read_to_end(&mut b)
            .map_err(|e| Error::io(path, "can't read", e))?;
        return read_bytes(&b, Path::new(".")).map_err(|e| e.with_path(path));
    }
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    match read_streaming(path, threads) {
        Ok(Some(n)) => Ok(n),
        Ok(None) => {
            let b = std::fs::read(path).map_err(|e| Error::io(path, "can't read", e))?;
            read_bytes(&b, &dir).map_err(|e| e.with_path(path))
        }
        Err(e) => Err(e.with_path(path)),
    }
}

/// Reads an attached-header NRRD with raw, gzip or bzip2 data straight from the file into
/// typed samples, so a volume needs its own size in memory and not twice that. Returns
/// None for everything else (text arrays, detached headers, ascii/hex data, byte skip
/// -1), which the in-memory reader handles.
fn read_streaming(path: &Path, threads: usize) -> Result<Option<Nrrd>> {
    use std::io::BufRead;
    // Pipes and other special files are read once, whole, by the in-memory reader.
    match std::fs::metadata(path) {
        Ok(m) if m.is_file() => {}
        _ => return Ok(None),
    }
    let f = std::fs::File::open(path).map_err(|e| Error::io(path, "can't read", e))?;
    let file_len = f.metadata().map(|m| m.len()).unwrap_or(u64::MAX);
    let mut r = std::io::BufReader::with_capacity(1 << 16, f);
    let head = r.fill_buf().map_err(|e| Error::io(path, "can't read", e))?;
    if !head.starts_with(b"NRRD") {
        return Ok(None);
    }
    // Header: lines up to the first empty one (bounded).
    let mut text = Vec::new();
    loop {
        let mut line = Vec::new();
        let n = r
            .read_until(b'\n', &mut line)
            .map_err(|e| Error::io(path, "can't read", e))?;
        if n == 0 {
            break;
        }
        let body = line.strip_suffix(b"\n").unwrap_or(&line);
        let body = body.strip_suffix(b"\r").unwrap_or(body);
        if body.is_empty() && !text.is_empty() {
            break;
        }
        text.extend_from_slice(&line);
        if text.len() > 1 << 20 {
            return Err(Error::msg("NRRD header is longer than 1 MiB"));
        }
    }
    let header_len = text.len() as u64 + 1;
    let text =
        std::str::from_utf8(&text).map_err(|_| Error::msg("NRRD header is not valid text"))?;
    let (parsed, data_file) = parse_header(text)?;
    let enc = parsed.encoding;
    if data_file.is_some()
        || !matches!(enc, Encoding::Raw | Encoding::Gzip | Encoding::Bzip2)
        || parsed.skips.byte < 0
    {
        return Ok(None);
    }
    let (n, nbytes) = data_size(&parsed)?;
    let tsz = parsed.scalar.size();
    for _ in 0..parsed.skips.line {
        let mut l = Vec::new();
        if r.read_until(b'\n', &mut l)
            .map_err(|e| Error::io(path, "can't read", e))?
            == 0
        {
            return Err(Error::msg("line skip goes past the end of the data"));
        }
    }
    let skip = parsed.skips.byte as u64;
    if std::io::copy(&mut (&mut r).take(skip), &mut std::io::sink())
        .map_err(|e| Error::io(path, "can't read", e))?
        < skip
    {
        return Err(Error::msg("byte skip goes past the end of the data"));
    }
    if enc == Encoding::Raw && file_len.saturating_sub(header_len + skip) < nbytes as u64 {
        return Err(Error::msg(format!(
            "data is truncated: sizes {:?} of {} need {nbytes} bytes, only {} present",
            parsed.sizes,
            parsed.scalar,
            file_len.saturating_sub(header_len + skip)
        )));
    }
    #[cfg(unix)]
    if enc == Encoding::Raw && threads > 1 && nbytes >= PARALLEL_MIN {
        use std::io::Seek;
        let off = r
            .stream_position()
            .map_err(|e| Error::io(path, "can't read", e))?;
        let data = read_raw_parallel(r.get_ref(), off, parsed.scalar, parsed.endian, n, threads)
            .map_err(|e| Error::io(path, "can't read", e))?;
        let Parsed { header, .. } = parsed;
        return Ok(Some(Nrrd { header, data }));
    }
    let mut src: Box<dyn Read> = match enc {
        Encoding::Gzip => Box::new(flate2::read::MultiGzDecoder::new(r)),
        Encoding::Bzip2 => Box::new(bzip2::read::MultiBzDecoder::new(r)),
        _ => Box::new(r),
    };
    let mut data = from_bytes(parsed.scalar, &[], parsed.endian, 0);
    if enc == Encoding::Raw {
        // The file holds all the data (checked above): one allocation of the final size.
        reserve_all(&mut data, n);
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
        append(&mut data, &chunk[..whole], parsed.endian, n);
        chunk.copy_within(whole..avail, 0);
        carry = avail - whole;
    }
    let Parsed { header, .. } = parsed;
    Ok(Some(Nrrd { header, data }))
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
        v.reserve_exact(n);
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
    let mut data = from_bytes(scalar, &[], e, 0);
    super::each_data!(&mut data, v => fill(v, f, off, e, n, threads))?;
    Ok(data)
}

/// Reserves room for `n` samples in `d` at once and, for large buffers, asks the kernel to
/// back them with huge pages (fewer TLB misses when rays wander through a big volume).
fn reserve_all(d: &mut Data, n: usize) {
    fn reserve<T>(v: &mut Vec<T>, n: usize) {
        v.reserve_exact(n);
        advise_huge_pages(
            v.as_ptr() as usize,
            v.capacity() * std::mem::size_of::<T>(),
            true,
        );
    }
    super::each_data!(d, v => reserve(v, n));
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
/// in steps as data arrives.
fn append(d: &mut Data, b: &[u8], e: Endian, total: usize) {
    fn go<T: RawSample>(v: &mut Vec<T>, b: &[u8], e: Endian, total: usize) {
        let add = b.len() / T::SIZE;
        if v.capacity() - v.len() < add {
            let grow = (v.len() + add).max(2 * v.len()).min(total);
            v.reserve_exact(grow.saturating_sub(v.len()).max(add));
        }
        v.extend(b.chunks_exact(T::SIZE).map(|c| T::get(c, e)));
    }
    super::each_data!(d, v => go(v, b, e, total))
}

/// Parses a NRRD (or plain-text array) held in memory; `dir` resolves detached data
/// files.
pub fn read_bytes(bytes: &[u8], dir: &Path) -> Result<Nrrd> {
    if !bytes.starts_with(b"NRRD") {
        if bytes.starts_with(b"\x1f\x8b") {
            return Err(Error::msg(
                "not a NRRD file (looks like a bare gzip stream)",
            ));
        }
        let text = std::str::from_utf8(bytes)
            .map_err(|_| Error::msg("not a NRRD file (no NRRD magic) and not a text array"))?;
        return super::text::parse_text(text);
    }
    let (hdr_text, data_off) = split_header(bytes)?;
    let (header, data_file) = parse_header(hdr_text)?;
    let data = match data_file {
        None => decode(&header, &bytes[data_off..], &header.skips)?,
        Some(files) => {
            let mut all = Vec::new();
            for f in &files {
                let p = if Path::new(f).is_absolute() {
                    PathBuf::from(f)
                } else {
                    dir.join(f)
                };
                let meta = std::fs::metadata(&p)
                    .map_err(|e| Error::io(&p, "can't read detached data", e))?;
                if !meta.is_file() {
                    return Err(Error::at(&p, "detached data is not a regular file"));
                }
                let b =
                    std::fs::read(&p).map_err(|e| Error::io(&p, "can't read detached data", e))?;
                all.push(b);
            }
            if all.len() == 1 {
                decode(&header, &all[0], &header.skips)?
            } else {
                // Each file holds an equal slab; decode them as one by concatenating the
                // decompressed/raw payloads after skips.
                let mut joined = Vec::new();
                for b in &all {
                    joined.extend_from_slice(skip_bytes(b, &header.skips, None)?);
                }
                let no_skip = Skips::default();
                decode(&header, &joined, &no_skip)?
            }
        }
    };
    let Parsed { header, .. } = header;
    Ok(Nrrd { header, data })
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

fn split_header(bytes: &[u8]) -> Result<(&str, usize)> {
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
    let text = std::str::from_utf8(&bytes[..end.min(bytes.len())])
        .map_err(|_| Error::msg("NRRD header is not valid text"))?;
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
            parse_f64(w)
                .ok_or_else(|| Error::msg(format!("{field}: can't parse \"{w}\" as a number")))
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
            parse_f64(w.trim())
                .ok_or_else(|| Error::msg(format!("can't parse \"{w}\" in vector \"{s}\"")))
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
const MAX_DIM: usize = 16;

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
        match field.as_str() {
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
                            Error::msg(format!("sizes: can't parse \"{w}\" as a size"))
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
            "byte skip" | "byteskip" => {
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
            "line skip" | "lineskip" => {
                skips.line = value
                    .parse()
                    .map_err(|_| Error::msg(format!("line skip: can't parse \"{value}\"")))?
            }
            "data file" | "datafile" => {
                if value == "LIST" || value.starts_with("LIST ") {
                    list_mode = true;
                } else if value.contains('%') {
                    data_file = Some(expand_format(value)?);
                } else {
                    data_file = Some(vec![value.to_string()]);
                }
            }
            "space directions" | "spacings" | "axis mins" | "axismins" | "axis maxs"
            | "axismaxs" | "centerings" | "centers" | "kinds" | "labels" => {
                per_axis.push((field, value.to_string()))
            }
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
            "axis mins" | "axismins" => h.axis_mins = Some(parse_f64s(&field, &value, dim)?),
            "axis maxs" | "axismaxs" => h.axis_maxs = Some(parse_f64s(&field, &value, dim)?),
            "centerings" | "centers" => {
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
    if step == 0 || (max - min) / step < 0 || (max - min) / step > 100_000 {
        return Err(Error::msg(format!(
            "data file: bad range {min} {max} {step}"
        )));
    }
    let mut out = Vec::new();
    let mut i = min;
    while (step > 0 && i <= max) || (step < 0 && i >= max) {
        out.push(format_printf_int(w[0], i)?);
        i += step;
    }
    Ok(out)
}

/// Expands one `%d` / `%03d`-style conversion.
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
    let width: usize = spec.trim_start_matches('0').parse().unwrap_or(0);
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

/// Refuses requests for more bytes than the machine has memory.
pub(crate) fn check_memory(bytes: usize, what: &str) -> Result<()> {
    if let Some(total) = crate::mem_total() {
        if bytes as u64 > total {
            return Err(Error::msg(format!(
                "{what} would need {} of memory; this machine has {}",
                crate::human_bytes(bytes as u64),
                crate::human_bytes(total)
            )));
        }
    }
    Ok(())
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
            let r = if h.encoding == Encoding::Gzip {
                flate2::read::MultiGzDecoder::new(b)
                    .take(lim)
                    .read_to_end(&mut out)
            } else {
                bzip2::read::MultiBzDecoder::new(b)
                    .take(lim)
                    .read_to_end(&mut out)
            };
            r.map_err(|e| {
                Error::msg(format!(
                    "{} data can't be decompressed: {e}",
                    h.encoding.as_str()
                ))
            })?;
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
    Ok(from_bytes(h.scalar, &bytes, h.endian, n))
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
        let v =
            parse_f64(w).ok_or_else(|| Error::msg(format!("ascii data: can't parse \"{w}\"")))?;
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

fn from_bytes(t: ScalarType, b: &[u8], e: Endian, n: usize) -> Data {
    let mut d = from_f64(t, &[]);
    append(&mut d, &b[..n * t.size()], e, n);
    d
}

/// Centering helper for callers: per-axis centring or Unknown.
pub fn centering(h: &Header, axis: usize) -> Centering {
    h.centerings
        .as_ref()
        .and_then(|c| c.get(axis).copied())
        .unwrap_or(Centering::Unknown)
}
