//! A small table-driven, hest-compatible option parser (SPEC §2).
//!
//! Options are single-dash words with a fixed number of values (`-sz 300 300`), a
//! variable number (`-i a b c`), or none (`-ortho`); positional parameters are taken in
//! order; `@file` (for commands that allow it) splices in the whitespace-separated tokens
//! of a file (`#` comments to end of line); a later occurrence of an option overrides an
//! earlier one; negative numbers are values, never options.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::str::FromStr;

/// How many values an option takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Arity {
    /// None: presence sets it.
    Flag,
    /// Exactly this many.
    Fixed(usize),
    /// At least this many (up to the next option).
    Var(usize),
}

/// One option in a command's table.
#[derive(Debug, Clone, Copy)]
pub struct Opt {
    /// Spellings without the leading dash; the first is the primary name (`["i", "-input"]`
    /// accepts `-i` and `--input`).
    pub names: &'static [&'static str],
    /// Value count.
    pub arity: Arity,
    /// Default, as text (None with `required = false`: absent).
    pub default: Option<&'static str>,
    /// Whether it must be given.
    pub required: bool,
    /// Value placeholder for usage text (`x y z`).
    pub meta: &'static str,
    /// What it does.
    pub help: &'static str,
}

impl Opt {
    /// Primary name.
    pub fn name(&self) -> &'static str {
        self.names[0]
    }
}

/// Shorthand constructors for option tables.
pub const fn req(
    names: &'static [&'static str],
    n: usize,
    meta: &'static str,
    help: &'static str,
) -> Opt {
    Opt {
        names,
        arity: Arity::Fixed(n),
        default: None,
        required: true,
        meta,
        help,
    }
}
/// Optional option with a default.
pub const fn def(
    names: &'static [&'static str],
    n: usize,
    default: &'static str,
    meta: &'static str,
    help: &'static str,
) -> Opt {
    Opt {
        names,
        arity: Arity::Fixed(n),
        default: Some(default),
        required: false,
        meta,
        help,
    }
}
/// Optional option without a default.
pub const fn opt(
    names: &'static [&'static str],
    n: usize,
    meta: &'static str,
    help: &'static str,
) -> Opt {
    Opt {
        names,
        arity: Arity::Fixed(n),
        default: None,
        required: false,
        meta,
        help,
    }
}
/// A flag.
pub const fn flag(names: &'static [&'static str], help: &'static str) -> Opt {
    Opt {
        names,
        arity: Arity::Flag,
        default: None,
        required: false,
        meta: "",
        help,
    }
}

/// A positional parameter.
#[derive(Debug, Clone, Copy)]
pub struct Pos {
    /// Name in usage text.
    pub name: &'static str,
    /// Value count (Fixed or Var).
    pub arity: Arity,
    /// What it is.
    pub help: &'static str,
}

/// A sub-command's description.
#[derive(Debug)]
pub struct CmdSpec {
    /// Command name.
    pub name: &'static str,
    /// One-line description.
    pub about: &'static str,
    /// Longer description for `--help`.
    pub info: &'static str,
    /// Whether `@file` response files are expanded.
    pub response_files: bool,
    /// Options.
    pub opts: &'static [Opt],
    /// Positional parameters, in order.
    pub pos: &'static [Pos],
}

/// Why parsing stopped.
#[derive(Debug)]
pub enum ArgError {
    /// Nothing or too little was given: print the short usage.
    Usage(String),
    /// `--help`: print the full help.
    Help,
    /// A specific problem (one line).
    Bad(String),
}

impl std::fmt::Display for ArgError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ArgError::Usage(s) | ArgError::Bad(s) => f.write_str(s),
            ArgError::Help => f.write_str("help requested"),
        }
    }
}

impl std::error::Error for ArgError {}

/// Parsed arguments.
#[derive(Debug)]
pub struct Args {
    spec: &'static CmdSpec,
    vals: HashMap<&'static str, Vec<String>>,
    pos: Vec<Vec<String>>,
    /// The tokens after `@file` expansion (for `content:` lines).
    pub tokens: Vec<String>,
    /// The response files read (inputs an output must not overwrite).
    pub response_files: Vec<std::path::PathBuf>,
}

fn looks_numeric(s: &str) -> bool {
    let t = s.trim_start_matches(['-', '+']);
    t.starts_with(|c: char| c.is_ascii_digit() || c == '.')
        || matches!(t.to_ascii_lowercase().as_str(), "nan" | "inf" | "infinity")
}

/// Splits response-file bytes into words: whitespace separated, `#` to end of line is
/// a comment (comments may hold any bytes; the words must be UTF-8).
pub fn tokenize_response(bytes: &[u8]) -> Result<Vec<String>, String> {
    let mut out = Vec::new();
    for line in bytes.split(|&b| b == b'\n') {
        let code = line.split(|&b| b == b'#').next().unwrap_or(&[]);
        for w in code
            .split(u8::is_ascii_whitespace)
            .filter(|w| !w.is_empty())
        {
            let w = std::str::from_utf8(w).map_err(|_| {
                format!(
                    "the word \"{}\" is not valid UTF-8",
                    String::from_utf8_lossy(w)
                )
            })?;
            out.push(w.to_string());
        }
    }
    Ok(out)
}

/// All response files of one command line together are read up to this many bytes.
pub const RESPONSE_MAX_BYTES: u64 = 64 << 20;
/// At most this many response files are read (each inclusion counts).
pub const RESPONSE_MAX_FILES: usize = 1000;
/// At most this many words after expansion.
pub const RESPONSE_MAX_WORDS: usize = 1 << 22;
/// Response files nest at most this deep.
pub const RESPONSE_MAX_DEPTH: usize = 8;

/// Expands `@file`s within the limits above; a file that includes itself (directly or
/// through others) is refused.
#[derive(Default)]
struct Expander {
    bytes: u64,
    files: usize,
    /// The files being expanded, outermost first (their identities and names).
    stack: Vec<(std::path::PathBuf, String)>,
    out: Vec<String>,
    read: Vec<std::path::PathBuf>,
}

impl Expander {
    fn expand(&mut self, argv: &[String]) -> Result<(), ArgError> {
        for a in argv {
            let Some(f) = a.strip_prefix('@').filter(|f| !f.is_empty()) else {
                if self.out.len() >= RESPONSE_MAX_WORDS {
                    return Err(ArgError::Bad(format!(
                        "@files expand to more than {RESPONSE_MAX_WORDS} words"
                    )));
                }
                self.out.push(a.clone());
                continue;
            };
            let bad = |m: String| ArgError::Bad(format!("@{f}: {m}"));
            if self.stack.len() >= RESPONSE_MAX_DEPTH {
                return Err(bad(format!(
                    "response files nested more than {RESPONSE_MAX_DEPTH} deep"
                )));
            }
            self.files += 1;
            if self.files > RESPONSE_MAX_FILES {
                return Err(bad(format!(
                    "more than {RESPONSE_MAX_FILES} response files read in all"
                )));
            }
            let path = std::path::PathBuf::from(f);
            let meta = std::fs::metadata(&path)
                .map_err(|e| bad(format!("can't read response file: {e}")))?;
            if meta.is_dir() {
                return Err(bad("is a directory, not a response file".into()));
            }
            let id = std::fs::canonicalize(&path).unwrap_or_else(|_| path.clone());
            if let Some(pos) = self.stack.iter().position(|(p, _)| *p == id) {
                let chain: Vec<&str> = self.stack[pos..].iter().map(|(_, n)| n.as_str()).collect();
                return Err(bad(format!(
                    "includes itself (@{} -> @{f})",
                    chain.join(" -> @")
                )));
            }
            let room = RESPONSE_MAX_BYTES - self.bytes;
            let text = rnd_std::files::read_text_bytes(&path, room).map_err(|e| {
                // The limit is on all response files together.
                if e.msg.starts_with("longer than") {
                    bad(format!(
                        "response files hold more than {} in all",
                        rnd_std::human_bytes(RESPONSE_MAX_BYTES)
                    ))
                } else {
                    bad(e.msg)
                }
            })?;
            self.bytes += text.len() as u64;
            let words = tokenize_response(&text).map_err(bad)?;
            self.read.push(path);
            self.stack.push((id, f.to_string()));
            self.expand(&words)?;
            self.stack.pop();
        }
        Ok(())
    }
}

/// Parses `argv` (the words after the command name) against `spec`.
pub fn parse(spec: &'static CmdSpec, argv: &[String]) -> Result<Args, ArgError> {
    if argv.iter().any(|a| a == "--help" || a == "-help") {
        return Err(ArgError::Help);
    }
    let (toks, response_files) = if spec.response_files {
        let mut e = Expander::default();
        e.expand(argv)?;
        (e.out, e.read)
    } else {
        (argv.to_vec(), Vec::new())
    };
    let find = |t: &str| -> Option<&'static Opt> {
        let name = t.strip_prefix('-')?;
        spec.opts.iter().find(|o| o.names.contains(&name))
    };
    let mut vals: HashMap<&'static str, Vec<String>> = HashMap::new();
    let mut loose: Vec<String> = Vec::new();
    let mut i = 0;
    while i < toks.len() {
        let t = &toks[i];
        if let Some(o) = find(t) {
            i += 1;
            let v: Vec<String> = match o.arity {
                Arity::Flag => Vec::new(),
                Arity::Fixed(n) => {
                    if i + n > toks.len() {
                        return Err(ArgError::Bad(format!(
                            "-{}: needs {n} value{} ({}), got {}",
                            o.name(),
                            if n == 1 { "" } else { "s" },
                            o.meta,
                            toks.len() - i
                        )));
                    }
                    let v = toks[i..i + n].to_vec();
                    i += n;
                    v
                }
                Arity::Var(min) => {
                    let mut v = Vec::new();
                    while i < toks.len() && find(&toks[i]).is_none() {
                        v.push(toks[i].clone());
                        i += 1;
                    }
                    if v.len() < min {
                        return Err(ArgError::Bad(format!(
                            "-{}: needs at least {min} value(s) ({})",
                            o.name(),
                            o.meta
                        )));
                    }
                    v
                }
            };
            vals.insert(o.name(), v);
            continue;
        }
        if t.len() > 1 && t.starts_with('-') && !looks_numeric(t) {
            return Err(ArgError::Bad(format!(
                "unknown option \"{t}\" (\"rendr {} --help\" lists the options)",
                spec.name
            )));
        }
        loose.push(t.clone());
        i += 1;
    }
    // Positional parameters.
    let mut pos = Vec::new();
    let mut li = 0;
    for (pi, p) in spec.pos.iter().enumerate() {
        match p.arity {
            Arity::Fixed(n) => {
                if li + n > loose.len() {
                    if loose.is_empty() && vals.is_empty() {
                        return Err(ArgError::Usage(String::new()));
                    }
                    return Err(ArgError::Bad(format!(
                        "missing <{}> ({} value{} needed)",
                        p.name,
                        n,
                        if n == 1 { "" } else { "s" }
                    )));
                }
                pos.push(loose[li..li + n].to_vec());
                li += n;
            }
            Arity::Var(min) => {
                // Takes everything left except what later fixed positionals need.
                let later: usize = spec.pos[pi + 1..]
                    .iter()
                    .map(|q| if let Arity::Fixed(n) = q.arity { n } else { 0 })
                    .sum();
                let take = loose.len().saturating_sub(li + later);
                if take < min {
                    if loose.is_empty() && vals.is_empty() {
                        return Err(ArgError::Usage(String::new()));
                    }
                    return Err(ArgError::Bad(format!(
                        "missing <{}> (at least {min} needed)",
                        p.name
                    )));
                }
                pos.push(loose[li..li + take].to_vec());
                li += take;
            }
            Arity::Flag => pos.push(Vec::new()),
        }
    }
    if li < loose.len() {
        return Err(ArgError::Bad(format!(
            "unexpected argument \"{}\" (\"rendr {} --help\" lists the options)",
            loose[li], spec.name
        )));
    }
    let missing: Vec<&str> = spec
        .opts
        .iter()
        .filter(|o| o.required && !vals.contains_key(o.name()))
        .map(|o| o.name())
        .collect();
    if !missing.is_empty() {
        if vals.is_empty() && loose.is_empty() {
            return Err(ArgError::Usage(String::new()));
        }
        let list: Vec<String> = missing.iter().map(|m| format!("-{m}")).collect();
        return Err(ArgError::Bad(format!(
            "missing required option{} {}",
            if list.len() > 1 { "s" } else { "" },
            list.join(" ")
        )));
    }
    Ok(Args {
        spec,
        vals,
        pos,
        tokens: toks,
        response_files,
    })
}

/// Parses a boolean word.
pub fn parse_bool(s: &str) -> Option<bool> {
    match s.to_ascii_lowercase().as_str() {
        "true" | "yes" | "on" | "1" | "t" | "y" | "yea" => Some(true),
        "false" | "no" | "off" | "0" | "f" | "n" | "nope" => Some(false),
        _ => None,
    }
}

/// A value type the parser can produce, with a name for error messages.
pub trait Value: Sized {
    /// What it is called in errors ("real number").
    const WHAT: &'static str;
    /// Parses one word.
    fn parse_word(s: &str) -> Option<Self>;
}

impl Value for f64 {
    const WHAT: &'static str = "real number";
    fn parse_word(s: &str) -> Option<f64> {
        match s.to_ascii_lowercase().as_str() {
            "nan" => Some(f64::NAN),
            "inf" | "+inf" => Some(f64::INFINITY),
            "-inf" => Some(f64::NEG_INFINITY),
            _ => s.parse().ok(),
        }
    }
}
impl Value for f32 {
    const WHAT: &'static str = "real number";
    fn parse_word(s: &str) -> Option<f32> {
        f64::parse_word(s).map(|x| x as f32)
    }
}
impl Value for u32 {
    const WHAT: &'static str = "non-negative integer";
    fn parse_word(s: &str) -> Option<u32> {
        s.parse().ok()
    }
}
impl Value for usize {
    const WHAT: &'static str = "non-negative integer";
    fn parse_word(s: &str) -> Option<usize> {
        s.parse().ok()
    }
}
impl Value for i32 {
    const WHAT: &'static str = "integer";
    fn parse_word(s: &str) -> Option<i32> {
        s.parse().ok()
    }
}
impl Value for bool {
    const WHAT: &'static str = "boolean (true/false, yes/no, on/off, 1/0)";
    fn parse_word(s: &str) -> Option<bool> {
        parse_bool(s)
    }
}
impl Value for String {
    const WHAT: &'static str = "string";
    fn parse_word(s: &str) -> Option<String> {
        Some(s.to_string())
    }
}

/// Parses a name-like value through `FromStr` (kernels, probes, blends).
pub fn parse_named<T: FromStr>(opt: &str, s: &str) -> Result<T, ArgError>
where
    T::Err: std::fmt::Display,
{
    s.parse::<T>()
        .map_err(|e| ArgError::Bad(format!("-{opt}: {e}")))
}

impl Args {
    fn opt(&self, name: &str) -> &'static Opt {
        self.spec
            .opts
            .iter()
            .find(|o| o.name() == name)
            .unwrap_or_else(|| panic!("option -{name} not in the table of {}", self.spec.name))
    }

    /// Raw words of option `name` (given, or the default split on whitespace), or None.
    pub fn words(&self, name: &str) -> Option<Vec<String>> {
        if let Some(v) = self.vals.get(name) {
            return Some(v.clone());
        }
        self.opt(name)
            .default
            .map(|d| d.split_whitespace().map(str::to_string).collect())
    }

    /// Whether option `name` was given on the command line.
    pub fn given(&self, name: &str) -> bool {
        self.vals.contains_key(name)
    }

    /// Whether flag `name` is set.
    pub fn flag(&self, name: &str) -> bool {
        self.given(name)
    }

    /// The `n` values of option `name`.
    pub fn get_n<T: Value>(&self, name: &str) -> Result<Vec<T>, ArgError> {
        let w = self
            .words(name)
            .ok_or_else(|| ArgError::Bad(format!("-{name}: not given")))?;
        w.iter()
            .map(|s| {
                T::parse_word(s).ok_or_else(|| {
                    ArgError::Bad(format!("-{name}: can't parse \"{s}\" as a {}", T::WHAT))
                })
            })
            .collect()
    }

    /// Exactly `N` values of option `name`.
    pub fn get_arr<T: Value + Copy + Default, const N: usize>(
        &self,
        name: &str,
    ) -> Result<[T; N], ArgError> {
        let v = self.get_n::<T>(name)?;
        if v.len() != N {
            return Err(ArgError::Bad(format!(
                "-{name}: need {N} values, got {}",
                v.len()
            )));
        }
        let mut a = [T::default(); N];
        a.copy_from_slice(&v);
        Ok(a)
    }

    /// The single value of option `name`.
    pub fn get<T: Value + Copy + Default>(&self, name: &str) -> Result<T, ArgError> {
        Ok(self.get_arr::<T, 1>(name)?[0])
    }

    /// The single string value of option `name` (None when absent without default).
    pub fn get_str(&self, name: &str) -> Option<String> {
        self.words(name).and_then(|w| w.into_iter().next())
    }

    /// Positional parameter `i`'s words.
    pub fn pos(&self, i: usize) -> &[String] {
        &self.pos[i]
    }
}

/// The short usage line(s) shown when required options are missing.
pub fn usage(spec: &CmdSpec) -> String {
    let mut s = format!(
        "rendr {}: {}\nUsage: rendr {}",
        spec.name, spec.about, spec.name
    );
    if spec.response_files {
        s.push_str(" [@file ...]");
    }
    for o in spec.opts {
        let m = if o.meta.is_empty() {
            String::new()
        } else {
            format!(" <{}>", o.meta)
        };
        if o.required {
            let _ = write!(s, " -{}{m}", o.name());
        } else {
            let _ = write!(s, " [-{}{m}]", o.name());
        }
    }
    for p in spec.pos {
        let _ = write!(s, " <{}>", p.name);
    }
    let _ = write!(s, "\n\"rendr {} --help\" for more information", spec.name);
    s
}

/// The full help: description, usage and the option table with defaults.
pub fn help(spec: &CmdSpec) -> String {
    let mut s = usage(spec);
    s.truncate(s.rfind('\n').unwrap_or(s.len()));
    if !spec.info.is_empty() {
        let _ = write!(s, "\n\n{}", spec.info);
    }
    s.push('\n');
    let rows: Vec<(String, String)> = spec
        .opts
        .iter()
        .map(|o| {
            let names: Vec<String> = o.names.iter().map(|n| format!("-{n}")).collect();
            let m = if o.meta.is_empty() {
                String::new()
            } else {
                format!(" <{}>", o.meta)
            };
            let tail = if o.required {
                " (required)".to_string()
            } else if let Some(d) = o.default {
                format!(" (default: \"{d}\")")
            } else if o.arity == Arity::Flag {
                String::new()
            } else {
                " (optional)".to_string()
            };
            (
                format!("{}{m}", names.join(",")),
                format!("{}{tail}", o.help),
            )
        })
        .chain(
            spec.pos
                .iter()
                .map(|p| (format!("<{}>", p.name), p.help.to_string())),
        )
        .collect();
    let w = rows.iter().map(|r| r.0.len()).max().unwrap_or(0);
    for (a, b) in rows {
        let _ = write!(s, "\n  {a:w$} = {b}");
    }
    if spec.response_files {
        let _ = write!(
            s,
            "\n  {:w$} = read more options from file (whitespace separated, # comments)",
            "@file"
        );
    }
    s.push('\n');
    s
}
