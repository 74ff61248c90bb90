//! Argument parsing, dispatch and exit codes.
//!
//! Exit codes: 0 success, 1 a finding (a leak, a validation miss), 2 an error (bad input, IO).

use std::ffi::OsString;

use clap::{CommandFactory, Parser, Subcommand};

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
    /// Rebuild the portal file (`.prt`) of a compiled Quake `.bsp` from its tree.
    Portals(cmd::portals::Args),
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
///
/// A `vis` command line may be ericw-tools' or id's (single-dash options, see
/// [`cmd::vis::ericw_args`]); it is turned into Sightline's flags first, and clap parses the
/// result.
pub fn main() -> i32 {
    let args = match translate_vis_args(std::env::args_os().collect()) {
        Ok(a) => a,
        Err(msg) => {
            eprintln!("error: {msg}");
            return 2;
        }
    };
    let cli = Cli::parse_from(args);
    let result = match &cli.command {
        Command::Compile(a) => cmd::compile::run(a),
        Command::Vis(a) => cmd::vis::run(a),
        Command::Portals(a) => cmd::portals::run(a),
        Command::Validate(a) => cmd::validate::run(a),
        Command::Info(a) => cmd::info::run(a),
        Command::Render(a) => cmd::render::run(a),
        Command::Bench(a) => cmd::bench::run(a),
        Command::Gvs(a) => cmd::gvs::run(a),
    };
    // Printing never panics (see `crate::out`); a stdout that failed for another reason than a
    // closed pipe makes the exit code 2.
    crate::out::exit_code(match result {
        Ok(Outcome::Clean) => 0,
        Ok(Outcome::Finding) => 1,
        Err(err) => {
            eprintln!("error: {err:#}");
            2
        }
    })
}

/// `args` (the program name first) with a `vis` subcommand's ericw-tools / id options turned into
/// Sightline's flags ([`cmd::vis::ericw_args`]); other command lines are returned unchanged.
pub fn translate_vis_args(args: Vec<OsString>) -> Result<Vec<OsString>, String> {
    // The subcommand is the first word that is not a flag (`sightline` has no global option that
    // takes a value).
    let Some(at) = args.iter().skip(1).position(|a| !a.to_str().is_some_and(|s| s.starts_with('-'))) else {
        return Ok(args);
    };
    let at = at + 1;
    if args[at].to_str() != Some("vis") {
        return Ok(args);
    }
    let cmd = Cli::command();
    let Some(vis) = cmd.find_subcommand("vis") else { return Ok(args) };
    let mut takes_value = Vec::new();
    let mut shorts = vec!['h', 'V'];
    for arg in vis.get_arguments() {
        if arg.get_action().takes_values() {
            takes_value.extend(arg.get_long_and_visible_aliases().into_iter().flatten().map(str::to_string));
            takes_value.extend(arg.get_all_aliases().into_iter().flatten().map(str::to_string));
        }
        shorts.extend(arg.get_short());
    }
    let rest = cmd::vis::ericw_args(&args[at + 1..], &|long| takes_value.iter().any(|l| l == long), &shorts)?;
    Ok(args[..=at].iter().cloned().chain(rest).collect())
}
