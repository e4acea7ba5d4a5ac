//! Standard output for the commands' printed results. Every write is checked: a full
//! disk (`> /dev/full`), a closed descriptor or any other failure ends the command with
//! a one-line error and status 1, never a panic; output still being written is removed
//! first. (Rust's own `println!` panics on a failed write and silently drops writes to
//! a closed descriptor 1.) A reader that goes away (`| head`) ends the program quietly,
//! through SIGPIPE, as it does a C tool.

use std::fs::File;
use std::io::{LineWriter, Write};
use std::sync::{Mutex, OnceLock};

/// The command being run, for error messages.
pub static COMMAND: OnceLock<&'static str> = OnceLock::new();

static STDOUT: Mutex<Option<LineWriter<File>>> = Mutex::new(None);

/// Ends the program after a failed write to standard output.
pub fn fail(e: &dyn std::fmt::Display) -> ! {
    rnd_std::output::remove_temp_files();
    let cmd = COMMAND.get().copied().unwrap_or("");
    let sep = if cmd.is_empty() { "" } else { " " };
    eprintln!("rendr{sep}{cmd}: can't write to standard output: {e}");
    std::process::exit(1)
}

/// Writes formatted text to standard output, ending the program on failure.
pub fn write_fmt(args: std::fmt::Arguments<'_>) {
    let mut g = STDOUT.lock().unwrap_or_else(|e| e.into_inner());
    if g.is_none() {
        match rnd_std::output::stdout() {
            Ok(f) => *g = Some(LineWriter::new(f)),
            Err(e) => {
                drop(g);
                fail(&e.msg)
            }
        }
    }
    if let Some(w) = g.as_mut() {
        if let Err(e) = w.write_fmt(args) {
            drop(g);
            fail(&e)
        }
    }
}

/// Flushes what is buffered (at the end of a command).
pub fn flush() {
    let mut g = STDOUT.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(w) = g.as_mut() {
        if let Err(e) = w.flush() {
            drop(g);
            fail(&e)
        }
    }
}

/// `print!` that fails cleanly.
macro_rules! out {
    ($($t:tt)*) => { $crate::out::write_fmt(format_args!($($t)*)) };
}

/// `println!` that fails cleanly.
macro_rules! outln {
    () => { $crate::out::write_fmt(format_args!("\n")) };
    ($($t:tt)*) => { $crate::out::write_fmt(format_args!("{}\n", format_args!($($t)*))) };
}
