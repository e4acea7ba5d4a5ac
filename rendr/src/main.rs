//! `rendr`: a direct volume renderer. A thin command-line front end over `rnd-core` and
//! `rnd-std`: one sub-command per file under `cmd/`.

#[macro_use]
mod out;
mod args;
mod cmd;
mod fmt;
#[cfg(feature = "mpi")]
mod job;
mod view;

use std::process::ExitCode;

use args::ArgError;

fn list_commands() -> String {
    let mut s = String::from(
        "rendr: a direct volume renderer (ray casting through a convolution-reconstructed volume)\n\
         Usage: rendr <command> [options]; \"rendr <command> --help\" for a command's options\n\n",
    );
    let w = cmd::COMMANDS
        .iter()
        .map(|c| c.spec.name.len())
        .max()
        .unwrap_or(0);
    for c in cmd::COMMANDS {
        s.push_str(&format!(" rendr {:w$} ... {}\n", c.spec.name, c.spec.about));
    }
    s
}

/// Cleans up on SIGINT, SIGTERM and SIGHUP: removes any output still being written,
/// says so, and exits with 128 + the signal's number. The signals are blocked in every
/// thread and taken by one waiting thread, so the cleanup runs as ordinary code (not in
/// a signal handler). A signal the program was started with ignored (`nohup`) stays
/// ignored.
#[cfg(unix)]
fn handle_signals() {
    // SAFETY: plain libc calls on a sigset_t and sigaction we own, made before any
    // other thread exists, so every thread created later inherits the mask.
    let set = unsafe {
        let mut set: libc::sigset_t = std::mem::zeroed();
        libc::sigemptyset(&mut set);
        for sig in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP] {
            let mut old: libc::sigaction = std::mem::zeroed();
            if libc::sigaction(sig, std::ptr::null(), &mut old) == 0
                && old.sa_sigaction == libc::SIG_IGN
            {
                continue;
            }
            libc::sigaddset(&mut set, sig);
        }
        libc::pthread_sigmask(libc::SIG_BLOCK, &set, std::ptr::null_mut());
        set
    };
    std::thread::spawn(move || loop {
        let mut sig: libc::c_int = 0;
        // SAFETY: sigwait reads the set and writes the signal number into `sig`.
        if unsafe { libc::sigwait(&set, &mut sig) } != 0 {
            continue;
        }
        rnd_std::output::remove_temp_files();
        let name = match sig {
            libc::SIGINT => "interrupted",
            libc::SIGTERM => "terminated",
            _ => "hung up",
        };
        eprintln!("\nrendr: {name}; no output written");
        std::process::exit(128 + sig);
    });
}

/// The arguments as text; a word that is not UTF-8 is refused by position.
fn arguments() -> Result<Vec<String>, String> {
    std::env::args_os()
        .skip(1)
        .enumerate()
        .map(|(i, a)| {
            a.into_string().map_err(|a| {
                format!(
                    "argument {} (\"{}\") is not valid UTF-8; rendr needs UTF-8 options and \
                     file names",
                    i + 1,
                    a.to_string_lossy()
                )
            })
        })
        .collect()
}

/// Prints a command's error as one line, control characters escaped.
fn report(cmd: &str, msg: &str) {
    let one = msg.replace(['\n', '\r'], " ");
    let sep = if cmd.is_empty() { "" } else { " " };
    eprintln!("rendr{sep}{cmd}: {}", rnd_std::error::escape_controls(&one));
}

/// The option that sets a library parameter.
fn option_of(p: rnd_core::Param) -> Option<&'static str> {
    use rnd_core::Param as P;
    Some(match p {
        P::CameraFrom => "-fr",
        P::CameraAt => "-at",
        P::CameraUp => "-up",
        P::CameraNear => "-nc",
        P::CameraFar => "-fc",
        P::CameraFov => "-fov",
        P::ImageSize => "-sz",
        P::PlaneSep => "-s",
        P::UnitStep => "-us",
        P::AlphaNear1 => "-a1",
        P::Phong => "-ph",
        P::DepthCue => "-dcn/-dcf",
        P::Probe => "-p",
        P::Blend => "-b",
        P::Lut => "-lut",
        P::LutDomain => "-mm",
        P::Lights => "-lit",
        P::Reference => "-ref",
        P::Volume => "-i",
        P::SdgSizes => "-sz",
        P::SdgLengths => "-l",
        P::SdgFunction => "-w",
        P::CurvMinGrad => "-gmc",
        _ => return None,
    })
}

/// An error's one-line text, with the option of the parameter the library names (when
/// it does) put first: the library speaks of "plane separation", the user typed `-s`.
fn with_option(e: &anyhow::Error) -> String {
    // The library's advice, in the CLI's words.
    let text = format!("{e:#}").replace(
        "use the f64 arithmetic",
        "use the f64 arithmetic (-ref false)",
    );
    let param = e.chain().find_map(|c| {
        c.downcast_ref::<rnd_core::Error>()
            .and_then(|x| x.param)
            .or_else(|| c.downcast_ref::<rnd_std::Error>().and_then(|x| x.param))
    });
    match param.and_then(option_of) {
        Some(o) if !text.starts_with(o) => format!("{o}: {text}"),
        _ => text,
    }
}

fn main() -> ExitCode {
    let code = run();
    out::flush();
    code
}

fn run() -> ExitCode {
    // A closed pipe (`rendr go -db ... | head`) ends the program quietly, as it does a
    // C tool, instead of failing a print.
    #[cfg(unix)]
    // SAFETY: called first thing, before any other thread exists; restoring the default
    // disposition of SIGPIPE has no other effect on the program.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    #[cfg(unix)]
    handle_signals();
    let argv = match arguments() {
        Ok(a) => a,
        Err(m) => {
            report("", &m);
            return ExitCode::from(1);
        }
    };
    let Some(name) = argv.first() else {
        out!("{}", list_commands());
        return ExitCode::SUCCESS;
    };
    if name == "--help" || name == "-h" || name == "help" {
        out!("{}", list_commands());
        return ExitCode::SUCCESS;
    }
    if name == "--version" || name == "-V" {
        outln!("rendr {}", env!("CARGO_PKG_VERSION"));
        return ExitCode::SUCCESS;
    }
    let Some(c) = cmd::find(name) else {
        report(
            "",
            &format!("unknown command \"{name}\" (run \"rendr\" alone for the list)"),
        );
        return ExitCode::from(1);
    };
    let _ = out::COMMAND.set(c.spec.name);
    let parsed = match args::parse(c.spec, &argv[1..]) {
        Ok(a) => a,
        Err(ArgError::Help) => {
            out!("{}", args::help(c.spec));
            return ExitCode::SUCCESS;
        }
        Err(ArgError::Usage(_)) => {
            eprintln!("{}", args::usage(c.spec));
            return ExitCode::from(1);
        }
        Err(ArgError::Bad(m)) => {
            report(c.spec.name, &m);
            return ExitCode::from(1);
        }
    };
    // Under mpirun (with the `mpi` feature) MPI lives until the command returns.
    #[cfg(feature = "mpi")]
    let _universe = job::start();
    match (c.run)(&parsed) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            report(c.spec.name, &with_option(&e));
            ExitCode::from(1)
        }
    }
}
