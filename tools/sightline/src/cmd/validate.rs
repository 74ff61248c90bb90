//! `sightline validate`: prove a PVS conservative by ray sampling and measure how tight it is.

use anyhow::Context;

use crate::limits::{self, MAX_RAYS};
use crate::outcome::Outcome;
use crate::progress::Bars;
use sightline_validate::{self as validate, DEFAULT_OFFSET, DEFAULT_RAYS, Options, OracleChoice, load, pvs};

/// `--oracle`: the values of [`OracleChoice`] on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum OracleArg {
    /// The BSP tree only.
    Tree,
    /// The face mesh only.
    Mesh,
    /// Both, and their disagreement.
    Both,
}

impl From<OracleArg> for OracleChoice {
    fn from(o: OracleArg) -> Self {
        match o {
            OracleArg::Tree => OracleChoice::Tree,
            OracleArg::Mesh => OracleChoice::Mesh,
            OracleArg::Both => OracleChoice::Both,
        }
    }
}

/// What `sightline validate` does: its line in `sightline --help` and the first line of its own help.
pub const ABOUT: &str = "Prove a PVS conservative by ray sampling and measure how tight it is";

/// Arguments of `sightline validate`.
#[derive(Debug, clap::Args)]
#[command(about = ABOUT)]
pub struct Args {
    /// A Quake-family `.bsp` with visdata (Quake 1, Half-Life, Quake 2), or a Sightline `.slvl`.
    pub input: std::path::PathBuf,
    /// Ray budget per oracle, spread evenly over the open leaves (10 rays per bundle: 5 lines
    /// cast both ways); at least 1 (every open leaf gets at least one bundle, so a small budget
    /// still casts rays from each); at most 10^12.
    #[arg(long, default_value_t = DEFAULT_RAYS, value_parser = clap::value_parser!(u64).range(1..=MAX_RAYS))]
    pub rays: u64,
    /// Seed of the random streams (results are identical for any thread count).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Worker threads, 0 to 1024 (0: one per core).
    #[arg(long, default_value_t = 0, value_parser = limits::threads_or_auto())]
    pub threads: usize,
    /// Bundle offset in world units, in [0, 64): each bundle is a centre line and four lines this
    /// far from it, and a leaf counts only when all five reach it. 0 casts single lines (reports
    /// crack noise).
    #[arg(long, default_value_t = DEFAULT_OFFSET, value_parser = limits::float_in::<f64>(0.0..64.0, "an offset in world units"))]
    pub offset: f64,
    /// Which oracle to sample against: the BSP tree, the face mesh (BVH), or both.
    #[arg(long, value_enum, default_value_t = OracleArg::Both)]
    pub oracle: OracleArg,
    /// Print the report as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<Outcome> {
    let bars = Bars::new(args.json);
    let level = load::load_level(&args.input, &bars)?;
    // Errors about the level name its file (the library only sees the level).
    let file = || args.input.display().to_string();
    if !level.has_vis() {
        eprintln!("note: {} has no PVS (everything visible): nothing can be missed", file());
    }
    let pvs = pvs::level_pvs(&level).with_context(file)?;
    let mut oracle = args.oracle;
    if level.faces.is_empty() && oracle == OracleArg::Both {
        // Quake 3 levels carry no faces (their surfaces are not needed to block sight: the
        // opaque leaves do); the mesh oracle has nothing to cast against.
        eprintln!("note: {} has no faces: sampling against the BSP tree only", file());
        oracle = OracleArg::Tree;
    }
    let opts = Options {
        rays: args.rays,
        seed: args.seed,
        offset: args.offset,
        oracle: oracle.into(),
        cancel: crate::interrupt::cancel(),
    };
    let pool = limits::pool(args.threads)?;
    let mut v = pool.install(|| validate::validate(&level, &pvs, &opts, &bars)).with_context(file)?;
    v.report.input = args.input.display().to_string();
    crate::out::report(args.json, &v.report, || v.report.text())?;
    Ok(if v.report.misses() > 0 { Outcome::Finding } else { Outcome::Clean })
}
