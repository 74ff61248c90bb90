//! The `sightline` binary: argument parsing, progress bars and printing over the library crates
//! (`sightline-formats`, `-compiler`, `-runtime`, `-gvs`, `-validate`); the work is theirs.
//! `anyhow` is used here and nowhere below. Exit codes: 0 success, 1 a finding (a leak, a
//! validation miss), 2 an error.

// Every print in this crate goes through `out`, which never panics (a closed stdout pipe, as in
// `sightline info x | head -1`, is not an error): these shadow the standard macros, which panic
// when a write fails. Defined before the modules so that they are in scope in all of them; kept
// even when unused, so that a new `print!` cannot reach the standard one.
#[allow(unused_macros)]
macro_rules! print {
    ($($arg:tt)*) => { $crate::out::stdout(format_args!($($arg)*), false) };
}
macro_rules! println {
    () => { $crate::out::stdout(format_args!(""), true) };
    ($($arg:tt)*) => { $crate::out::stdout(format_args!($($arg)*), true) };
}
#[allow(unused_macros)]
macro_rules! eprint {
    ($($arg:tt)*) => { $crate::out::stderr(format_args!($($arg)*), false) };
}
macro_rules! eprintln {
    () => { $crate::out::stderr(format_args!(""), true) };
    ($($arg:tt)*) => { $crate::out::stderr(format_args!($($arg)*), true) };
}

mod cli;
mod cmd;
mod interrupt;
mod limits;
mod out;
mod outcome;
mod output;
mod progress;
mod vis_flags;

fn main() {
    std::process::exit(cli::main());
}
