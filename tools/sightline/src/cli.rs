//! Argument parsing, dispatch and exit codes.
//!
//! Exit codes: 0 success, 1 a finding (a leak, a validation miss), 2 an error (bad input, IO).

use std::ffi::OsString;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

use crate::cmd;
use crate::outcome::Outcome;

/// Sightline compiles Quake-style levels and answers "what can be seen from here". The summary
/// that starts `--help` names the subcommands, taken from them ([`command`]).
#[derive(Debug, Parser)]
#[command(name = "sightline", version, propagate_version = true)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The command line, its one-line summary naming every subcommand in their order (built from the
/// subcommands, so no list is kept by hand).
pub fn command() -> clap::Command {
    let cmd = Cli::command();
    // Hidden ones (`vis-shards`, reached as `sightline vis plan|shard|merge|status`) are not named.
    let names: Vec<String> =
        cmd.get_subcommands().filter(|c| !c.is_hide_set()).map(|c| c.get_name().to_string()).collect();
    cmd.about(format!("The sightline command line: {}.", names.join(", "))).long_about(None)
}

/// The subcommands. Each one's arguments are built only when it is the one run (or its help is
/// printed): building every subcommand's took about a tenth of a small vis's time.
#[derive(Debug, Subcommand)]
#[command(defer = true)]
pub enum Command {
    #[command(about = cmd::compile::ABOUT)]
    Compile(cmd::compile::Args),
    #[command(about = cmd::vis::ABOUT)]
    Vis(cmd::vis::Args),
    #[command(about = cmd::portals::ABOUT)]
    Portals(cmd::portals::Args),
    #[command(about = cmd::validate::ABOUT)]
    Validate(cmd::validate::Args),
    #[command(about = cmd::info::ABOUT)]
    Info(cmd::info::Args),
    #[command(about = cmd::render::ABOUT)]
    Render(cmd::render::Args),
    #[command(about = cmd::trace::ABOUT)]
    Trace(cmd::trace::Args),
    #[command(about = cmd::bench::ABOUT)]
    Bench(cmd::bench::Args),
    #[command(about = cmd::gvs::ABOUT)]
    Gvs(cmd::gvs::Args),
    /// `sightline vis plan|shard|merge|status`, reached through `vis` ([`translate_vis_args`]).
    #[command(name = "vis-shards", hide = true)]
    VisShards(cmd::vis::shards::Args),
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
    let matches = command().get_matches_from(join_negative_values(args));
    let cli = Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    // Commands that stop on request take Ctrl-C and SIGTERM from the start (the reading of a large
    // input included), not only once their long work begins.
    if matches!(
        cli.command,
        Command::Compile(_)
            | Command::Vis(_)
            | Command::VisShards(_)
            | Command::Validate(_)
            | Command::Gvs(_)
    ) {
        crate::interrupt::ctrl_c_flag();
    }
    let result = match &cli.command {
        Command::Compile(a) => cmd::compile::run(a),
        Command::Vis(a) => cmd::vis::run(a),
        Command::Portals(a) => cmd::portals::run(a),
        Command::Validate(a) => cmd::validate::run(a),
        Command::Info(a) => cmd::info::run(a),
        Command::Render(a) => cmd::render::run(a),
        Command::Trace(a) => cmd::trace::run(a),
        Command::Bench(a) => cmd::bench::run(a),
        Command::Gvs(a) => cmd::gvs::run(a),
        Command::VisShards(a) => cmd::vis::shards::run(a),
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

/// `args` with every negative number that follows a long option joined to it (`--level -1` becomes
/// `--level=-1`, `--cell -64,-64,0,64,64,128` becomes `--cell=-64,...`): clap would take the
/// number for an unknown flag and say so without naming the option; joined, it is the option's
/// value, which the option's range check refuses naming it (or takes, when its range allows it).
/// Nothing after `--` changes, nor a word that only starts with `-` (`-o`, `--json`).
pub fn join_negative_values(args: Vec<OsString>) -> Vec<OsString> {
    let negative = |w: &OsString| {
        w.to_str().and_then(|w| w.strip_prefix('-')).is_some_and(|rest| {
            rest.starts_with(|c: char| c.is_ascii_digit() || c == '.') || rest.parse::<f64>().is_ok()
        })
    };
    let mut out: Vec<OsString> = Vec::with_capacity(args.len());
    let mut rest = args.into_iter();
    while let Some(word) = rest.next() {
        let option = word.to_str().is_some_and(|w| w.starts_with("--") && w.len() > 2 && !w.contains('='));
        if word == "--" {
            out.push(word);
            out.extend(rest.by_ref());
            break;
        }
        out.push(word);
        if option && rest.as_slice().first().is_some_and(negative) {
            let value = rest.next().unwrap_or_default();
            if let Some(last) = out.last_mut() {
                last.push("=");
                last.push(value);
            }
        }
    }
    out
}

/// The words after `vis` that name a step of a sharded vis (`cmd::vis::shards`), not an input.
const SHARD_STEPS: [&str; 4] = ["plan", "shard", "merge", "status"];

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
    // `vis plan|shard|merge|status`: the steps of a sharded vis, with Sightline's flags only.
    if args.get(at + 1).and_then(|w| w.to_str()).is_some_and(|w| SHARD_STEPS.contains(&w)) {
        let mut args = args;
        args[at] = OsString::from("vis-shards");
        return Ok(args);
    }
    // Without a single-dash option there is nothing to turn (and no need to build the flags).
    let words = &args[at + 1..];
    let before_end = words.iter().take_while(|w| w.to_str() != Some("--"));
    if !before_end.filter_map(|w| w.to_str()).any(|w| cmd::vis::single_dash_name(w).is_some()) {
        return Ok(args);
    }
    let vis = <cmd::vis::Args as clap::Args>::augment_args(clap::Command::new("vis"));
    let mut takes_value = Vec::new();
    let mut shorts = vec!['h', 'V'];
    for arg in vis.get_arguments() {
        if arg.get_action().takes_values() {
            takes_value.extend(arg.get_long_and_visible_aliases().into_iter().flatten().map(str::to_string));
            takes_value.extend(arg.get_all_aliases().into_iter().flatten().map(str::to_string));
        }
        shorts.extend(arg.get_short());
    }
    let rest = cmd::vis::ericw_args(words, &|long| takes_value.iter().any(|l| l == long), &shorts)?;
    Ok(args[..=at].iter().cloned().chain(rest).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn words(line: &str) -> Vec<OsString> {
        line.split(' ').map(OsString::from).collect()
    }

    #[test]
    fn a_negative_number_after_a_long_option_is_its_value() {
        let joined = |line: &str| join_negative_values(words(line));
        assert_eq!(joined("s vis a.prt --level -1"), words("s vis a.prt --level=-1"));
        assert_eq!(
            joined("s gvs g --cell -64,-6,0,1,1,1 --eps -inf"),
            words("s gvs g --cell=-64,-6,0,1,1,1 --eps=-inf")
        );
        assert_eq!(joined("s render a -o -x.png --z -.5..2"), words("s render a -o -x.png --z=-.5..2"));
        for same in [
            "s info --json a.bsp",
            "s vis --level=-1 a",
            "s x --fov -- -1",
            "s x --json -o a",
            "s x -- --a -1",
        ] {
            assert_eq!(joined(same), words(same), "{same}");
        }
    }
}
