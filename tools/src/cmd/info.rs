//! `sightline info` (work in progress: not wired yet).

use crate::cli::Outcome;

/// Arguments of `sightline info`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Input file.
    pub input: std::path::PathBuf,
}

/// Run the command.
pub fn run(_args: &Args) -> anyhow::Result<Outcome> {
    anyhow::bail!("`sightline info` is not implemented yet")
}
