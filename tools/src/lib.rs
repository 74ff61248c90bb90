//! The `sightline` command line and the tool-side libraries behind it: validation, rendering,
//! benchmarking, GVS and map generators. `anyhow` is used here and nowhere below.

pub mod cli;
pub mod cmd;
pub mod gvs;
pub mod mapgen;
pub mod progress;
pub mod render;
pub mod scenegen;
pub mod validate;
