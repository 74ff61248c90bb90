//! Printing that never panics: every `print!`/`println!`/`eprint!`/`eprintln!` in this crate
//! comes here (the crate root shadows the standard macros with these).
//!
//! The standard macros panic when a write fails, so `sightline info map.bsp | head -1` would die
//! with exit 101 once `head` closes the pipe. Here a closed stdout (`BrokenPipe`) is not an error:
//! the rest of the output is dropped and the command finishes with its own exit code (the same
//! the full output would have had). Any other failure to write stdout (a full disk) also drops
//! the rest, and [`exit_code`] turns it into an error exit. Failures to write stderr are ignored:
//! there is nowhere left to report them.

use std::fmt;
use std::io::{ErrorKind, Write};
use std::sync::OnceLock;
use std::sync::atomic::{AtomicBool, Ordering};

/// Set once stdout failed: nothing more is written to it.
static STDOUT_DONE: AtomicBool = AtomicBool::new(false);

/// The first failure to write stdout other than a closed pipe.
static STDOUT_ERROR: OnceLock<String> = OnceLock::new();

/// Write `args` (and a newline) to stdout, flushed; see the module docs for failures.
pub fn stdout(args: fmt::Arguments<'_>, newline: bool) {
    if STDOUT_DONE.load(Ordering::Relaxed) {
        return;
    }
    let mut out = std::io::stdout().lock();
    let written = out
        .write_fmt(args)
        .and_then(|()| if newline { out.write_all(b"\n") } else { Ok(()) })
        .and_then(|()| out.flush());
    if let Err(e) = written {
        STDOUT_DONE.store(true, Ordering::Relaxed);
        if e.kind() != ErrorKind::BrokenPipe {
            let _ = STDOUT_ERROR.set(e.to_string());
        }
    }
}

/// A command's report on stdout: pretty JSON under `--json`, else the text `text` makes.
pub fn report<R: serde::Serialize>(
    json: bool,
    report: &R,
    text: impl FnOnce() -> String,
) -> anyhow::Result<()> {
    if json {
        stdout(format_args!("{}", serde_json::to_string_pretty(report)?), true);
    } else {
        stdout(format_args!("{}", text()), false);
    }
    Ok(())
}

/// Write `args` (and a newline) to stderr, ignoring failures.
pub fn stderr(args: fmt::Arguments<'_>, newline: bool) {
    let mut err = std::io::stderr().lock();
    let _ = err.write_fmt(args).and_then(|()| if newline { err.write_all(b"\n") } else { Ok(()) });
}

/// The process exit code for a command that ended with `code`: 2 (after saying why) when stdout
/// could not be written for another reason than a closed pipe.
pub fn exit_code(code: i32) -> i32 {
    match STDOUT_ERROR.get() {
        Some(e) if code != 2 => {
            stderr(format_args!("error: cannot write to stdout: {e}"), true);
            2
        }
        _ => code,
    }
}
