//! One module per subcommand: its clap `Args` and its `run`.

pub mod bench;
pub mod compile;
pub mod gvs;
pub mod info;
pub mod portals;
pub mod render;
pub mod trace;
pub mod validate;
pub mod vis;
