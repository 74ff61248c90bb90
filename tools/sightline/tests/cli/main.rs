//! The real `sightline` binary, run as a user or a build script would: exit codes (0 success,
//! 1 a finding, 2 an error), `--json` output that parses, errors that name the file.

mod ericw;
mod errors;
mod exit_codes;
mod games;
mod help;
mod interrupt;
mod limits;
mod revis;
mod support;
