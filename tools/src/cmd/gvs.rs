//! `sightline gvs` (work in progress: not wired yet).

use crate::cli::Outcome;

/// Arguments of `sightline gvs`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Input file.
    pub input: std::path::PathBuf,
}

/// Run the command.
pub fn run(_args: &Args) -> anyhow::Result<Outcome> {
    anyhow::bail!("`sightline gvs` is not implemented yet")
}
