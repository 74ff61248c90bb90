//! `sightline portals`: the portal file (PRT1) of a compiled Quake `.bsp` (BSP29, BSP2,
//! BSP2-RMQ) rebuilt from its world tree alone ([`sightline_compiler::bsp_portals`]), for a map
//! whose source and `.prt` are lost. Its vis leaves are the BSP's own, so `sightline vis` can read
//! it beside the `.bsp` and write the PVS back into that file.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use sightline_compiler::bsp_portals::{self, BspPortalOptions, BspPortalStats};
use sightline_compiler::contents::LiquidSight;
use sightline_formats::bsp;

use crate::outcome::Outcome;

/// What `sightline portals` does: its line in `sightline --help` and the first line of its own help.
pub const ABOUT: &str = "Rebuild the portal file (`.prt`) of a compiled Quake `.bsp` from its tree";

/// Arguments of `sightline portals`.
#[derive(Debug, clap::Args)]
#[command(about = ABOUT)]
pub struct Args {
    /// A Quake `.bsp` (BSP29, BSP2 or BSP2-RMQ) or a Half-Life one (BSP30).
    pub input: PathBuf,
    /// Portal file to write (default: the input with the extension `.prt`).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Whether water, slime and lava let sight through.
    #[arg(long, value_enum, default_value_t)]
    pub water: Water,
    /// Give every leaf its own cluster, even where the file's own PVS gives all open leaves under
    /// a node one row (qbsp's detail clusters): tighter, slower to vis on maps with detail.
    #[arg(long)]
    pub no_clusters: bool,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Whether liquid surfaces let sight through (`--water`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Water {
    /// See-through liquids (ericw-tools' default, `-transwater`).
    #[default]
    Transparent,
    /// A liquid surface blocks sight (id's qbsp): no portal joins water and air.
    Opaque,
}

impl From<Water> for LiquidSight {
    fn from(w: Water) -> Self {
        match w {
            Water::Transparent => LiquidSight::Transparent,
            Water::Opaque => LiquidSight::Opaque,
        }
    }
}

/// What `sightline portals` reports (`--json` prints this).
#[derive(Debug, Clone, serde::Serialize)]
pub struct Report {
    /// The `.bsp` read.
    pub input: String,
    /// The portal file written.
    pub output: String,
    /// `--water`.
    pub water: Water,
    /// `PRT1`, or `PRT2` when leaves were kept together as clusters.
    pub format: String,
    /// Counts of the rebuild.
    pub portals: BspPortalStats,
    /// Seconds rebuilding the portals (reading and writing excluded).
    pub build_seconds: f64,
    /// Total seconds.
    pub total_seconds: f64,
}

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<Outcome> {
    let t0 = Instant::now();
    let path = &args.input;
    let output = args.output.clone().unwrap_or_else(|| path.with_extension("prt"));
    let bytes = sightline_job::input::read_input(path)?;
    crate::output::check(&[path], &[&output])?;
    let file = bsp::read(&bytes).with_context(|| format!("{}: invalid BSP", path.display()))?;
    let t1 = Instant::now();
    let opts = BspPortalOptions { liquids: args.water.into(), no_clusters: args.no_clusters };
    let built = bsp_portals::build(&file, opts)
        .with_context(|| format!("{}: cannot rebuild portals from its tree", path.display()))?;
    let build_seconds = t1.elapsed().as_secs_f64();
    sightline_job::atomic::write_file_atomic(&output, sightline_formats::prt::write(&built.prt).as_bytes())
        .with_context(|| format!("cannot write {}", output.display()))?;
    let report = Report {
        input: path.display().to_string(),
        output: output.display().to_string(),
        water: args.water,
        format: built.prt.format.header().to_string(),
        portals: built.stats,
        build_seconds,
        total_seconds: t0.elapsed().as_secs_f64(),
    };
    crate::out::report(args.json, &report, || text_report(&report))?;
    Ok(Outcome::Clean)
}

/// The summary line of a rebuild, shared with `vis --portals-from-bsp`.
pub fn stats_line(s: &BspPortalStats) -> String {
    let mut line = format!(
        "portals rebuilt from the BSP tree: {} portals, {} vis leaves, {} clusters ({} open leaves in a tree of {} nodes)",
        s.portals, s.vis_leaves, s.clusters, s.open_leaves, s.nodes
    );
    if s.liquid_portals_dropped > 0 {
        line += &format!("; {} liquid portals left out (opaque water)", s.liquid_portals_dropped);
    }
    if s.tiny_portals_kept > 0 {
        line += &format!("; {} tiny portals kept", s.tiny_portals_kept);
    }
    line + "\n"
}

fn text_report(r: &Report) -> String {
    format!(
        "{}: {}{} -> {}\ntime: portals {:.3} s, total {:.3} s\n",
        r.input,
        stats_line(&r.portals),
        r.format,
        r.output,
        r.build_seconds,
        r.total_seconds
    )
}
