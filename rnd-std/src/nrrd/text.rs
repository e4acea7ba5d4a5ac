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
    // Row by row, never the whole array's text at once.
    let cols = cols.max(1);
    let mut row = Vec::with_capacity(cols);
    for t in n.data.texts(|x| x.to_string()) {
        row.push(t);
        if row.len() == cols {
            writeln!(w, "{}", row.join(" ")).map_err(io)?;
            row.clear();
        }
    }
    if !row.is_empty() {
        writeln!(w, "{}", row.join(" ")).map_err(io)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::{write_to, Data, Encoding, Endian, Nrrd, WriteOptions};
    use super::write_text;

    fn text(n: &Nrrd) -> String {
        let mut out = Vec::new();
        write_text(n, &mut out).unwrap();
        String::from_utf8(out).unwrap()
    }

    fn ascii_body(n: &Nrrd) -> String {
        let mut out = Vec::new();
        let opt = WriteOptions {
            encoding: Encoding::Ascii,
            endian: Endian::Little,
        };
        write_to(n, opt, &mut out).unwrap();
        let s = String::from_utf8(out).unwrap();
        s[s.find("\n\n").unwrap() + 2..].to_string()
    }

    #[test]
    fn samples_print_in_rows_with_their_own_digits() {
        // f32 prints its shortest digits (0.1, not 0.10000000149011612).
        let f = Nrrd::new(vec![2, 2], Data::F32(vec![0.1, -2.0, 1.5e-8, 3.25])).unwrap();
        assert_eq!(text(&f), "0.1 -2\n0.000000015 3.25\n");
        assert_eq!(ascii_body(&f), "0.1 -2\n0.000000015 3.25\n");
        let i = Nrrd::new(vec![3, 1], Data::I16(vec![-3, 7, 32767])).unwrap();
        assert_eq!(text(&i), "-3 7 32767\n");
        assert_eq!(ascii_body(&i), "-3 7 32767\n");
        let d = Nrrd::new(vec![3], Data::F64(vec![0.1, f64::NAN, f64::NEG_INFINITY])).unwrap();
        assert_eq!(text(&d), "0.1\nNaN\n-inf\n");
        assert_eq!(ascii_body(&d), "0.1 nan -inf\n");
    }
}
