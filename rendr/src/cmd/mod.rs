//! The sub-commands, one per file, and the table `main` dispatches on.

use crate::args::{Args, CmdSpec};

/// An option table with the camera options (`-fr -at -up -nc -fc -fov -sz -ortho`, read
/// by `cam::camera_spec`) between the options in the first and the second list.
macro_rules! with_camera_opts {
    ([$($pre:expr),* $(,)?], [$($post:expr),* $(,)?]) => {
        &[
            $($pre,)*
            $crate::args::req(&["fr"], 3, "x y z", "look-from point"),
            $crate::args::req(&["at"], 3, "x y z", "look-at point"),
            $crate::args::req(&["up"], 3, "x y z", "up direction"),
            $crate::args::req(&["nc"], 1, "dist", "near clipping plane, relative to look-at"),
            $crate::args::req(&["fc"], 1, "dist", "far clipping plane, relative to look-at"),
            $crate::args::req(&["fov"], 1, "angle", "vertical field of view, in degrees"),
            $crate::args::req(&["sz"], 2, "horz vert", "image size in pixels"),
            $crate::args::flag(&["ortho"], "orthographic instead of perspective projection"),
            $($post),*
        ]
    };
}

mod about;
mod cam;
mod ceval;
mod convert;
pub(crate) mod go;
mod info;
mod keval;
mod klist;
mod levoy;
mod lgen;
mod lgen2;
mod m4ai;
mod mgo;
mod sdg;
mod teval;
mod turn;
mod view;

/// A sub-command: its option table, other names, and what it runs.
pub struct Command {
    /// Option table and descriptions.
    pub spec: &'static CmdSpec,
    /// Other accepted names.
    pub aliases: &'static [&'static str],
    /// The work.
    pub run: fn(&Args) -> anyhow::Result<()>,
}

/// Every command, in listing order.
pub static COMMANDS: &[Command] = &[
    Command {
        spec: &about::SPEC,
        aliases: &[],
        run: about::run,
    },
    Command {
        spec: &m4ai::SPEC,
        aliases: &["m4ai"],
        run: m4ai::run,
    },
    Command {
        spec: &cam::SPEC,
        aliases: &[],
        run: cam::run,
    },
    Command {
        spec: &teval::SPEC,
        aliases: &[],
        run: teval::run,
    },
    Command {
        spec: &lgen::SPEC,
        aliases: &[],
        run: lgen::run,
    },
    Command {
        spec: &lgen2::SPEC,
        aliases: &[],
        run: lgen2::run,
    },
    Command {
        spec: &levoy::SPEC,
        aliases: &[],
        run: levoy::run,
    },
    Command {
        spec: &ceval::SPEC,
        aliases: &[],
        run: ceval::run,
    },
    Command {
        spec: &go::SPEC,
        aliases: &[],
        run: go::run,
    },
    Command {
        spec: &mgo::SPEC,
        aliases: &[],
        run: mgo::run,
    },
    Command {
        spec: &klist::SPEC,
        aliases: &[],
        run: klist::run,
    },
    Command {
        spec: &keval::SPEC,
        aliases: &[],
        run: keval::run,
    },
    Command {
        spec: &info::SPEC,
        aliases: &[],
        run: info::run,
    },
    Command {
        spec: &convert::SPEC,
        aliases: &[],
        run: convert::run,
    },
    Command {
        spec: &turn::SPEC,
        aliases: &[],
        run: turn::run,
    },
    Command {
        spec: &view::SPEC,
        aliases: &[],
        run: view::run,
    },
    Command {
        spec: &sdg::SPEC,
        aliases: &[],
        run: sdg::run,
    },
];

/// Finds a command by name or alias.
pub fn find(name: &str) -> Option<&'static Command> {
    COMMANDS
        .iter()
        .find(|c| c.spec.name == name || c.aliases.contains(&name))
}

/// The `content:` text for an output: the command line that made it.
pub fn content(cmd: &str, a: &Args) -> String {
    let mut s = format!("rendr {cmd}");
    for t in &a.tokens {
        s.push(' ');
        s.push_str(t);
    }
    s
}

/// Prepares output `path` of a command before any work: refused when it is the same
/// file as one of `inputs` (a NRRD's detached data files, a NIfTI pair's image, a MetaImage's data file, a
/// DICOM series' slices included) or of the @files
/// read; the directory is checked and the temporary file created now, so a wrong output
/// is reported at once and a failed run leaves nothing behind.
pub fn output(path: &str, a: &Args, inputs: &[&str]) -> anyhow::Result<rnd_std::output::Output> {
    let mut all: Vec<std::path::PathBuf> = a.response_files.clone();
    for i in inputs.iter().filter(|i| !i.is_empty() && **i != "x") {
        all.extend(rnd_std::formats::input_files(std::path::Path::new(i)));
    }
    Ok(rnd_std::output::Output::create(
        std::path::Path::new(path),
        &all,
    )?)
}

/// The LUT output `-o` and, when given, its picture `-oi` (lgen, lgen2), prepared before
/// any work: neither may be one of `inputs`, and the picture may not be the LUT.
pub fn lut_outputs(
    a: &Args,
    inputs: &[&str],
) -> anyhow::Result<(rnd_std::output::Output, Option<rnd_std::output::Output>)> {
    use anyhow::Context;
    let o = a.get_str("o").unwrap_or_default();
    let out = output(&o, a, inputs).context("-o")?;
    let pic = match a.get_str("oi") {
        Some(oi) => {
            let same = oi == o
                || oi != "-"
                    && rnd_std::output::same_file(
                        std::path::Path::new(&oi),
                        std::path::Path::new(&o),
                    );
            if same {
                anyhow::bail!("-oi {oi}: the picture would overwrite the LUT output -o");
            }
            Some(output(&oi, a, inputs).context("-oi")?)
        }
        None => None,
    };
    Ok((out, pic))
}
