//! Errors of the std layer: core errors and IO errors, with the file they concern.

use std::fmt;
use std::path::{Path, PathBuf};

/// What went wrong, broadly; the message says exactly what.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum ErrorKind {
    /// Reading or writing failed (the system's error is in the message and in
    /// [`Error::source`]).
    Io,
    /// A file's content is not what it claims or what rendr reads (a bad header,
    /// truncated data, an unsupported variant).
    Format,
    /// More memory than this process may use, or than the system gives.
    Memory,
    /// The output cannot be written safely (it is an input, its folder is missing, ...).
    Output,
    /// An error of the core library, with its kind (a bad parameter, volume, transfer
    /// function, ...).
    Core(rnd_core::ErrorKind),
    /// The caller stopped the work (a cancelled render).
    Cancelled,
}

/// An error from `rnd-std`: its kind, the file (when there is one), the parameter (when
/// the core library named one) and what is wrong.
#[derive(Debug)]
#[non_exhaustive]
pub struct Error {
    /// Broad category.
    pub kind: ErrorKind,
    /// The file concerned, if any.
    pub path: Option<PathBuf>,
    /// The parameter concerned, when the core library named one (a front end puts its
    /// own name for it before the message).
    pub param: Option<rnd_core::Param>,
    /// What went wrong.
    pub msg: String,
    /// The underlying IO error, if any (its text is part of `msg` already).
    pub source: Option<std::io::Error>,
}

impl Error {
    /// A message without a file, of kind [`ErrorKind::Format`] (change it with
    /// [`Error::with_kind`]).
    pub fn msg(msg: impl Into<String>) -> Self {
        Error {
            kind: ErrorKind::Format,
            path: None,
            param: None,
            msg: msg.into(),
            source: None,
        }
    }
    /// A message about `path`, of kind [`ErrorKind::Format`].
    pub fn at(path: &Path, msg: impl Into<String>) -> Self {
        Error {
            path: Some(path.to_path_buf()),
            ..Error::msg(msg)
        }
    }
    /// An IO error while doing `what` with `path` ([`ErrorKind::Io`]).
    pub fn io(path: &Path, what: &str, e: std::io::Error) -> Self {
        Error {
            kind: ErrorKind::Io,
            path: Some(path.to_path_buf()),
            param: None,
            msg: format!("{what}: {e}"),
            source: Some(e),
        }
    }
    /// The same error with kind `kind`.
    pub fn with_kind(mut self, kind: ErrorKind) -> Self {
        self.kind = kind;
        self
    }
    /// Sets the path if none is set.
    pub fn with_path(mut self, path: &Path) -> Self {
        if self.path.is_none() {
            self.path = Some(path.to_path_buf());
        }
        self
    }
}

/// Writes `s` with every control character (C0, DEL, C1) and bidirectional-text
/// override shown as an escape (`\u{1b}`), so text taken from a file (a header line, a
/// file name) cannot drive the terminal it is printed on. Printable text, tabs aside,
/// is unchanged; escaping twice changes nothing more.
pub fn escape_controls(s: &str) -> std::borrow::Cow<'_, str> {
    fn bad(c: char) -> bool {
        c.is_control() || matches!(c, '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}')
    }
    if !s.chars().any(bad) {
        return std::borrow::Cow::Borrowed(s);
    }
    let mut out = String::with_capacity(s.len() + 8);
    for c in s.chars() {
        if bad(c) {
            out.push_str(&format!("\\u{{{:x}}}", c as u32));
        } else {
            out.push(c);
        }
    }
    std::borrow::Cow::Owned(out)
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let msg = escape_controls(&self.msg);
        match &self.path {
            Some(p) if p.as_os_str() == "-" => write!(f, "(stdin): {msg}"),
            Some(p) => write!(f, "{}: {msg}", escape_controls(&p.display().to_string())),
            None => f.write_str(&msg),
        }
    }
}

/// The message already contains the IO error's text, so [`source`] is `None` (error
/// reporters that print the chain would print it twice); the IO error itself stays in
/// the `source` field for callers that want its kind.
///
/// [`source`]: std::error::Error::source
impl std::error::Error for Error {}

/// Keeps the core error's kind (as [`ErrorKind::Core`], or [`ErrorKind::Memory`] and
/// [`ErrorKind::Cancelled`] as themselves) and parameter.
impl From<rnd_core::Error> for Error {
    fn from(e: rnd_core::Error) -> Self {
        let kind = match e.kind {
            rnd_core::ErrorKind::Memory => ErrorKind::Memory,
            rnd_core::ErrorKind::Cancelled => ErrorKind::Cancelled,
            k => ErrorKind::Core(k),
        };
        Error {
            kind,
            param: e.param,
            ..Error::msg(e.msg)
        }
    }
}

/// Result alias.
pub type Result<T> = std::result::Result<T, Error>;
