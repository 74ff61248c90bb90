//! The `sightline` command line: argument parsing, progress bars and printing over the library
//! crates (`sightline-formats`, `-compiler`, `-runtime`, `-gvs`, `-validate`). `anyhow` is used
//! here and nowhere below.

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

pub mod cli;
pub mod cmd;
pub mod out;
pub mod output;
pub mod progress;
