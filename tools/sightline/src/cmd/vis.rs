//! `sightline vis`: the PVS of a Quake `.bsp` (from its sibling `.prt`, written back into the
//! `.bsp` atomically) or of a `.prt` (written to `<name>.vis`).
//!
//! The library does the work: [`sightline_compiler::visdata`] reads the input, lays out the rows
//! and writes them into the `.bsp` (its module docs give the drop-in rules), and
//! [`sightline_formats::visfile`] is the `.vis` file. This module parses the arguments, handles
//! Ctrl-C, draws progress and prints the report.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::Instant;

use anyhow::{Context, bail};

use sightline_compiler::vis::{self, VisOptions, VisPhase, VisProgress, VisResult, VisStats};
use sightline_compiler::visdata::{self, Rows, VisInput};
use sightline_formats::prt::PortalFile;

use crate::cli::Outcome;

/// Arguments of `sightline vis`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// A Quake `.bsp` (its `.prt` must sit beside it) or a `.prt` file.
    pub input: PathBuf,
    /// Worker threads (0: every core). The result is the same for any count.
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Vis options.
    #[command(flatten)]
    pub vis: VisFlags,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

/// The vis flags that `sightline vis` and `sightline compile` share.
#[derive(Debug, Clone, clap::Args)]
pub struct VisFlags {
    /// Base vis only (like the reference `-fast`): fast and loose.
    #[arg(long)]
    pub fast: bool,
    /// Separator tests, 0..=4 as the reference `vis -level` defines them (4 is the tightest).
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u8).range(0..=4))]
    pub level: u8,
    /// Checkpoint file: resumed from when present, written every `--checkpoint-secs` and on
    /// Ctrl-C. The same command run again resumes from it.
    #[arg(long)]
    pub state: Option<PathBuf>,
    /// Seconds between checkpoints.
    #[arg(long, default_value_t = 180)]
    pub checkpoint_secs: u64,
    /// Stop after this many flow portals (after writing the state): for testing resumes.
    #[arg(long, hide = true)]
    pub stop_after: Option<usize>,
}

impl Default for VisFlags {
    /// The command-line defaults: full vis at level 4, no state file.
    fn default() -> Self {
        Self { fast: false, level: 4, state: None, checkpoint_secs: 180, stop_after: None }
    }
}

impl VisFlags {
    /// The vis options these flags ask for (every core; Ctrl-C stops at the next batch).
    pub fn options(&self) -> VisOptions {
        VisOptions {
            fast: self.fast,
            level: self.level,
            state: self.state.clone(),
            checkpoint_interval: std::time::Duration::from_secs(self.checkpoint_secs.max(1)),
            stop_after: self.stop_after,
            cancel: Some(ctrl_c_flag()),
            ..VisOptions::default()
        }
    }
}

/// What `sightline vis` reports (`--json` prints this).
#[derive(Debug, Clone, serde::Serialize)]
pub struct Report {
    /// Input file.
    pub input: String,
    /// File written (the `.bsp` itself, or the `.vis`).
    pub output: String,
    /// Portal file format (`PRT1`, `PRT2`, `PRT1-AM`).
    pub prt_format: String,
    /// Vis statistics (leaves, clusters, visible counts, chains, phase times).
    pub vis: VisStats,
    /// Bytes of compressed PVS rows written.
    pub compressed_bytes: usize,
    /// Seconds reading inputs.
    pub read_seconds: f64,
    /// Seconds compressing and writing.
    pub write_seconds: f64,
    /// Total seconds.
    pub total_seconds: f64,
}

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<Outcome> {
    let t0 = Instant::now();
    let input = VisInput::read(&args.input)?;
    let read_seconds = t0.elapsed().as_secs_f64();
    let opts = VisOptions { threads: args.threads, ..args.vis.options() };
    let result = compute(&input.prt, &opts, args.json)?;
    let t1 = Instant::now();
    let rows = Rows::new(&result);
    let output = match &input.bsp {
        Some(b) => {
            let out = visdata::write_into_bsp(&b.bytes, &b.bsp, &result, &rows)?;
            sightline_formats::atomic::write_file_atomic(&args.input, &out)
                .with_context(|| format!("cannot write {}", args.input.display()))?;
            args.input.clone()
        }
        None => {
            let path = args.input.with_extension("vis");
            sightline_formats::atomic::write_file_atomic(&path, &rows.vis_file()?)
                .with_context(|| format!("cannot write {}", path.display()))?;
            path
        }
    };
    let report = Report {
        input: args.input.display().to_string(),
        output: output.display().to_string(),
        prt_format: input.prt.format.header().to_string(),
        vis: result.stats.clone(),
        compressed_bytes: rows.data.len(),
        read_seconds,
        write_seconds: t1.elapsed().as_secs_f64(),
        total_seconds: t0.elapsed().as_secs_f64(),
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print!("{}", text_report(&report));
    }
    Ok(Outcome::Clean)
}

/// What to tell the user when vis stopped on request after `done` of `total` flow portals, with or
/// without a state file to resume from.
pub(crate) fn interrupted(done: usize, total: usize, saved: bool) -> String {
    if saved {
        format!("stopped after {done} of {total} portals; run again with the same --state to resume")
    } else {
        format!(
            "stopped after {done} of {total} portals; nothing was saved (give --state FILE to make a run resumable)"
        )
    }
}

/// A flag set by Ctrl-C, so vis stops at the next batch boundary and saves its state. If a handler
/// cannot be installed, Ctrl-C keeps its default effect (the flag then never turns on).
fn ctrl_c_flag() -> Arc<AtomicBool> {
    static FLAG: OnceLock<Arc<AtomicBool>> = OnceLock::new();
    FLAG.get_or_init(|| {
        let flag = Arc::new(AtomicBool::new(false));
        let handler = flag.clone();
        // A second Ctrl-C while the first is being honoured ends the process at once.
        let _ = ctrlc::set_handler(move || {
            if handler.swap(true, Ordering::SeqCst) {
                std::process::exit(130);
            }
            eprintln!("\ninterrupt: stopping at the next batch of portals (Ctrl-C again to quit now)");
        });
        flag
    })
    .clone()
}

/// Run vis with a progress bar (hidden under `--json` or without a terminal).
fn compute(prt: &PortalFile, opts: &VisOptions, quiet: bool) -> anyhow::Result<VisResult> {
    let base = crate::progress::bar("base", 0, quiet);
    let flow = crate::progress::bar("flow", 0, quiet);
    // Bars are updated every 32 portals (and at the end): an update per portal cost a third of
    // the flow time on small maps. Hidden bars are not updated at all.
    let report = |p: VisProgress| {
        if quiet || (!p.done.is_multiple_of(32) && p.done != p.total) {
            return;
        }
        let bar = if p.phase == VisPhase::Base { &base } else { &flow };
        bar.set_length(p.total as u64);
        bar.set_position(p.done as u64);
    };
    let result = vis::run(prt, opts, &report);
    base.finish_and_clear();
    flow.finish_and_clear();
    match result {
        Ok(r) => Ok(r),
        Err(vis::VisError::Interrupted { done, total }) => {
            bail!(interrupted(done, total, opts.state.is_some()))
        }
        Err(e) => Err(e.into()),
    }
}

fn text_report(r: &Report) -> String {
    let v = &r.vis;
    let mode = if v.fast { "fast (base vis only)".to_string() } else { format!("full, level {}", v.level) };
    format!(
        "{input} ({fmt}): {leaves} leaves, {clusters} clusters, {portals} portals{dropped}\n\
         vis {mode}, {threads} threads\n\
         visible leaves: average {avg:.1} ({pct:.1} %), median {med}, max {max}; base vis average {might:.1}\n\
         portal chains visited: {chains}{resumed}\n\
         compressed PVS: {bytes} bytes -> {output}\n\
         time: read {read:.3} s, base {base:.3} s, flow {flow:.3} s, rows {rows:.3} s, write {write:.3} s, total {total:.3} s\n",
        input = r.input,
        fmt = r.prt_format,
        leaves = v.leaves,
        clusters = v.clusters,
        portals = v.portals,
        dropped = if v.dropped_portals > 0 {
            format!(" ({} without area dropped)", v.dropped_portals)
        } else {
            String::new()
        },
        threads = v.threads,
        avg = v.avg_visible,
        pct = v.percent_visible,
        med = v.median_visible,
        max = v.max_visible,
        might = v.avg_mightsee,
        chains = v.chains,
        resumed = if v.resumed_portals > 0 {
            format!(" ({} portals resumed from the state file)", v.resumed_portals)
        } else {
            String::new()
        },
        bytes = r.compressed_bytes,
        output = r.output,
        read = r.read_seconds,
        base = v.base_seconds,
        flow = v.flow_seconds,
        rows = v.rows_seconds,
        write = r.write_seconds,
        total = r.total_seconds,
    )
}
