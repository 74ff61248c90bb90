//! The `sightline` command line and the tool-side libraries behind it: validation, rendering,
//! benchmarking, GVS and map generators. `anyhow` is used here and nowhere below.

pub mod cli;
pub mod cmd;
pub mod progress;
