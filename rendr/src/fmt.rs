//! C-style number formatting (`%g`, `%.9g`) and matrix printing, so the output reads
//! like the reference program's.

/// Formats `x` like C's `%.{prec}g`.
pub fn g(x: f64, prec: usize) -> String {
    if x.is_nan() {
        return "nan".into();
    }
    if x.is_infinite() {
        return if x > 0.0 { "inf".into() } else { "-inf".into() };
    }
    if x == 0.0 {
        // Negative zero prints as 0 (derived matrices are full of it).
        return "0".into();
    }
    let prec = prec.max(1);
    let e = format!("{:.*e}", prec - 1, x);
    let (mant, exp) = e.split_once('e').unwrap_or((&e, "0"));
    let exp: i32 = exp.parse().unwrap_or(0);
    if exp < -4 || exp >= prec as i32 {
        let mant = trim(mant);
        format!("{mant}e{}{:02}", if exp < 0 { '-' } else { '+' }, exp.abs())
    } else {
        let dec = (prec as i32 - 1 - exp).max(0) as usize;
        trim(&format!("{x:.dec$}")).to_string()
    }
}

fn trim(s: &str) -> &str {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        s
    }
}

/// `%g` (6 significant digits).
pub fn g6(x: f64) -> String {
    g(x, 6)
}

/// `%.9g` (9 significant digits, as the float build prints).
pub fn g9(x: f64) -> String {
    g(x, 9)
}

/// Space-separated `%g` list.
pub fn list6(v: &[f64]) -> String {
    v.iter().map(|&x| g6(x)).collect::<Vec<_>>().join(" ")
}

/// Space-separated `%.9g` list.
pub fn list9(v: &[f64]) -> String {
    v.iter().map(|&x| g9(x)).collect::<Vec<_>>().join(" ")
}

/// A 4×4 matrix, one row per line, entries right-aligned to a common width.
pub fn matrix(m: &rnd_core::affine::Affine4, f: fn(f64) -> String) -> String {
    let cells: Vec<String> = m.m.iter().map(|&x| f(x)).collect();
    let w = cells.iter().map(String::len).max().unwrap_or(1);
    let mut s = String::new();
    for r in 0..4 {
        let row: Vec<String> = (0..4)
            .map(|c| format!("{:>w$}", cells[4 * r + c]))
            .collect();
        s.push_str(&row.join(" "));
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn like_printf() {
        assert_eq!(g6(11.7547811), "11.7548");
        assert_eq!(g6(0.0001), "0.0001");
        assert_eq!(g6(0.00001), "1e-05");
        assert_eq!(g6(1234567.0), "1.23457e+06");
        assert_eq!(g6(100000.0), "100000");
        assert_eq!(g9(0.0571428575), "0.0571428575");
        assert_eq!(g6(-2.0), "-2");
        assert_eq!(g6(999999.5), "1e+06");
    }
}
