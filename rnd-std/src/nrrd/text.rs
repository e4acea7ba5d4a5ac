//! Plain-text numeric arrays: one row per line, numbers separated by
//! whitespace (or commas), `#` comments, `#key:=value` pairs; ragged rows are refused.

use std::io::Write;

use super::header::{Centering, Header, ScalarType};
use super::read::parse_f64;
use super::{Data, Nrrd};
use crate::{Error, Result};

/// Parses a text array into a 2-D f64 NRRD of sizes `[columns, rows]`.
///
/// # Errors
/// [`crate::ErrorKind::Format`] for ragged rows, numbers that do not parse or no
/// numbers at all.
pub fn parse_text(text: &str) -> Result<Nrrd> {
    let mut kv = Vec::new();
    let mut vals = Vec::new();
    let mut cols: Option<usize> = None;
    let mut rows = 0usize;
    for (ln, line) in text.lines().enumerate() {
        let line = line.trim();
        if let Some(c) = line.strip_prefix('#') {
            if let Some((k, v)) = c.split_once(":=") {
                kv.push((k.trim().to_string(), v.trim().to_string()));
            }
            continue;
        }
        // Trailing comments are not part of the text format.
        let line = line.split('#').next().unwrap_or("");
        let words: Vec<&str> = line
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|w| !w.is_empty())
            .collect();
        if words.is_empty() {
            continue;
        }
        for w in &words {
            let v = parse_f64(w).ok_or_else(|| {
                Error::msg(format!(
                    "line {}: can't parse \"{}\" as a number",
                    ln + 1,
                    super::read::short(w)
                ))
            })?;
            vals.push(v);
        }
        match cols {
            None => cols = Some(words.len()),
            Some(c) if c != words.len() => {
                return Err(Error::msg(format!(
                    "line {}: {} numbers, but earlier rows have {c} (ragged rows)",
                    ln + 1,
                    words.len()
                )))
            }
            _ => {}
        }
        rows += 1;
    }
    let cols = cols.ok_or_else(|| Error::msg("text array has no numbers"))?;
    let mut header = Header::new(ScalarType::F64, vec![cols, rows]);
    header.key_values = kv;
    header.centerings = Some(vec![Centering::Unknown; 2]);
    header.centerings = None;
    Ok(Nrrd {
        header,
        data: Data::F64(vals),
    })
}

/// Writes a 1-D or 2-D array as text: key/values as `#key:=value`, then one row per line.
///
/// # Errors
/// As [`super::check_header`]; more than two axes; [`crate::ErrorKind::Io`] when
/// writing fails.
pub fn write_text(n: &Nrrd, w: &mut dyn Write) -> Result<()> {
    super::check_header(n)?;
    let io = |e: std::io::Error| Error::msg(format!("write failed: {e}"));
    let sizes = n.sizes();
    let cols = match sizes.len() {
        1 => 1,
        2 => sizes[0],
        _ => {
            return Err(Error::msg(format!(
                "text output needs 1-D or 2-D data, not {}-D",
                sizes.len()
            )))
        }
    };
    for (k, v) in &n.header.key_values {
        writeln!(w, "#{k}:={v}").map_err(io)?;
    }
    let len = n.data.len();
    let mut i = 0;
    while i < len {
        let row: Vec<String> = (i..(i + cols).min(len)).map(|j| fmt_num(n, j)).collect();
        writeln!(w, "{}", row.join(" ")).map_err(io)?;
        i += cols;
    }
    Ok(())
}

fn fmt_num(n: &Nrrd, j: usize) -> String {
    match &n.data {
        Data::F32(v) => format!("{}", v[j]),
        Data::F64(v) => format!("{}", v[j]),
        d => format!("{}", d.get_f64(j)),
    }
}
