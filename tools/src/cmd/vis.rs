//! `sightline vis` (work in progress: not wired yet).

use crate::cli::Outcome;

/// Arguments of `sightline vis`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Input file.
    pub input: std::path::PathBuf,
}

/// Run the command.
pub fn run(_args: &Args) -> anyhow::Result<Outcome> {
    anyhow::bail!("`sightline vis` is not implemented yet")
}
