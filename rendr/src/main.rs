//! `rendr`: a direct volume renderer. A thin command-line front end over `rnd-core` and
//! `rnd-std`: one sub-command per file under `cmd/`.

mod args;
mod cmd;
mod fmt;

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

fn main() -> ExitCode {
    // A closed pipe (`rendr go -db ... | head`) ends the program quietly, as it does a
    // C tool, instead of failing a print with a panic.
    #[cfg(unix)]
    // SAFETY: called first thing, before any other thread exists; restoring the default
    // disposition of SIGPIPE has no other effect on the program.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    // Ctrl-C: remove any output still being written, then stop (status 130).
    let _ = ctrlc::set_handler(|| {
        rnd_std::files::remove_temp_files();
        eprintln!("\nrendr: interrupted");
        std::process::exit(130);
    });
    // RND_AVX2=0: convolve without AVX2 or AVX-512; RND_AVX512=0: without AVX-512 (the
    // same bits, slower; for comparisons).
    if std::env::var_os("RND_AVX512").is_some_and(|v| v == "0") {
        rnd_core::avx::set_avx512(false);
    }
    if std::env::var_os("RND_AVX2").is_some_and(|v| v == "0") {
        rnd_core::avx::set_avx2(false);
    }
    let argv: Vec<String> = std::env::args().skip(1).collect();
    let Some(name) = argv.first() else {
        print!("{}", list_commands());
        return ExitCode::SUCCESS;
    };
    if name == "--help" || name == "-h" || name == "help" {
        print!("{}", list_commands());
        return ExitCode::SUCCESS;
    }
    if name == "--version" || name == "-V" {
        println!("rendr {}", env!("CARGO_PKG_VERSION"));
        return ExitCode::SUCCESS;
    }
    let Some(c) = cmd::find(name) else {
        eprintln!("rendr: unknown command \"{name}\" (run \"rendr\" alone for the list)");
        return ExitCode::from(1);
    };
    let parsed = match args::parse(c.spec, &argv[1..]) {
        Ok(a) => a,
        Err(ArgError::Help) => {
            print!("{}", args::help(c.spec));
            return ExitCode::SUCCESS;
        }
        Err(ArgError::Usage(_)) => {
            eprintln!("{}", args::usage(c.spec));
            return ExitCode::from(1);
        }
        Err(ArgError::Bad(m)) => {
            eprintln!("rendr {}: {m}", c.spec.name);
            return ExitCode::from(1);
        }
    };
    match (c.run)(&parsed) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let msg = format!("{e:#}").replace('\n', " ");
            eprintln!("rendr {}: {msg}", c.spec.name);
            ExitCode::from(1)
        }
    }
}
