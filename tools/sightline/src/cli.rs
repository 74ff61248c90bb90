//! Argument parsing, dispatch and exit codes.
//!
//! Exit codes: 0 success, 1 a finding (a leak, a validation miss), 2 an error (bad input, IO).

use clap::{Parser, Subcommand};

use crate::cmd;

/// Sightline compiles Quake-style levels and answers "what can be seen from here".
#[derive(Debug, Parser)]
#[command(name = "sightline", version, about, propagate_version = true)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Compile a `.map` or `.obj` into a level (`.slvl`) with portals and PVS.
    Compile(cmd::compile::Args),
    /// Compute visibility for a Quake `.bsp` (reading its `.prt`) or a `.prt` file.
    Vis(cmd::vis::Args),
    /// Prove a PVS conservative by ray sampling and measure how tight it is.
    Validate(cmd::validate::Args),
    /// Print counts and bounds of any file Sightline reads.
    Info(cmd::info::Args),
    /// Render a level or BSP to PNG: first-person, plan, leak path or PVS matrix.
    Render(cmd::render::Args),
    /// Benchmark the runtime backends on random camera poses.
    Bench(cmd::bench::Args),
    /// Guided visibility sampling for triangle meshes.
    Gvs(cmd::gvs::Args),
}

/// What a successful command found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Nothing to report: exit 0.
    Clean,
    /// A finding such as a leak or a validation miss: exit 1.
    Finding,
}

/// Parse the command line, run it, print any error, and return the process exit code.
pub fn main() -> i32 {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Compile(a) => cmd::compile::run(a),
        Command::Vis(a) => cmd::vis::run(a),
        Command::Validate(a) => cmd::validate::run(a),
        Command::Info(a) => cmd::info::run(a),
        Command::Render(a) => cmd::render::run(a),
        Command::Bench(a) => cmd::bench::run(a),
        Command::Gvs(a) => cmd::gvs::run(a),
    };
    match result {
        Ok(Outcome::Clean) => 0,
        Ok(Outcome::Finding) => 1,
        Err(err) => {
            eprintln!("error: {err:#}");
            2
        }
    }
}
