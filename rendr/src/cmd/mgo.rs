//! `rendr mgo`: many renderings from one command file.

use std::path::Path;

use anyhow::{bail, Context};

use crate::args::{req, Args, CmdSpec};

pub static SPEC: CmdSpec = CmdSpec {
    name: "mgo",
    about: "run many \"rendr go\" commands from one file, re-using volumes",
    info: "Each non-empty line of the command file is a complete \"rendr go ...\" command \
           (# starts a comment; \"!!\" repeats the previous command). They run in order as \
           separate renderings, but a volume named on consecutive lines is read once (only the \
           last volume is kept in memory). Prints a \
           banner before and after each. Stops at the first failing line, naming it.",
    response_files: true,
    opts: &[req(
        &["i"],
        1,
        "cmdfile",
        "file of \"rendr go ...\" lines (- = stdin)",
    )],
    pos: &[],
};

pub fn run(a: &Args) -> anyhow::Result<()> {
    let f = a.get_str("i").unwrap_or_default();
    let text = rnd_std::files::read_text(Path::new(&f), 64 << 20)?;
    let mut cache = super::go::VolumeCache::default();
    // Outputs must overwrite neither the command file nor the @files of mgo's own line.
    let inputs: Vec<String> = std::iter::once(f.clone())
        .chain(
            a.response_files
                .iter()
                .map(|p| p.to_string_lossy().into_owned()),
        )
        .collect();
    let mut prev: Option<String> = None;
    for (ln, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let line = if line == "!!" {
            prev.clone()
                .with_context(|| format!("{f} line {}: \"!!\" with no previous command", ln + 1))?
        } else {
            line.to_string()
        };
        let words: Vec<String> = line.split_whitespace().map(str::to_string).collect();
        if words.len() < 2 || !words[0].ends_with("rendr") || words[1] != "go" {
            bail!(
                "{f} line {}: not a \"rendr go ...\" command: {line}",
                ln + 1
            );
        }
        outln!("================== running: {line}");
        let parsed = crate::args::parse(&super::go::SPEC, &words[2..]).map_err(|e| {
            anyhow::anyhow!(
                "{f} line {}: {}",
                ln + 1,
                match e {
                    crate::args::ArgError::Usage(_) => "missing required options".to_string(),
                    other => other.to_string(),
                }
            )
        })?;
        super::go::run_cached(&parsed, &mut cache, &inputs)
            .with_context(|| format!("{f} line {}", ln + 1))?;
        outln!("================== done");
        prev = Some(line);
    }
    Ok(())
}
