//! The `sightline` command line: argument parsing, progress bars and printing over the library
//! crates (`sightline-formats`, `-compiler`, `-runtime`, `-gvs`, `-validate`). `anyhow` is used
//! here and nowhere below.

pub mod cli;
pub mod cmd;
pub mod progress;
