//! `sightline compile <map.map|mesh.obj>`: a map or mesh to a level (`.slvl`) with portals
//! (`.prt`) and, unless `--no-vis`, the PVS.
//!
//! Exit codes: 0 compiled, 1 the map leaks (`<out>.pts` holds the path from the entity to the
//! void), 2 an error. Files are written atomically (temporary file, then rename), the portal file
//! (or pointfile) and the level together: all or none, the level last, recording which portal file
//! is its own. A sealed compile removes a pointfile an earlier leak left. An output folder
//! that is missing or takes no files is an error before anything is compiled.

use std::path::{Path, PathBuf};

use anyhow::Context;
use sightline_compiler::vis::VisError;
use sightline_compiler::{CompileError, CompileOptions, Compiled, LeakReport, Source, compile};

use crate::outcome::Outcome;
use crate::output;
use crate::progress::Bars;
use crate::vis_flags::VisFlags;

/// What `sightline compile` does: its line in `sightline --help` and the first line of its own help.
pub const ABOUT: &str = "Compile a `.map` or `.obj` into a level (`.slvl`) with portals and PVS";

/// Arguments of `sightline compile`.
#[derive(Debug, clap::Args)]
#[command(about = ABOUT)]
pub struct Args {
    /// Input file: a `.map` (Standard or Valve 220) or an `.obj` triangle mesh.
    pub input: PathBuf,
    /// Output level; the portal file and pointfile go beside it (`.prt`, `.pts`). Default: the
    /// input with the extension `.slvl`.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Worker threads, 1 to 1024 (default: every core). The output is the same for any count.
    #[arg(long, value_parser = crate::limits::threads())]
    pub threads: Option<usize>,
    /// Stop after portals: the level has no PVS.
    #[arg(long)]
    pub no_vis: bool,
    /// Vis options (`--state`: the same compile run again resumes vis, since the map compiles to
    /// the same portals).
    #[command(flatten)]
    pub vis: VisFlags,
    /// Write the level even when the map leaks (no outside fill, no vis); still exits 1.
    #[arg(long)]
    pub allow_leak: bool,
    /// Print the result as JSON on stdout (no progress bars).
    #[arg(long)]
    pub json: bool,
}

fn with_extension(path: &Path, ext: &str) -> PathBuf {
    path.with_extension(ext)
}

fn leak_json(leak: &LeakReport, pts: &Path) -> serde_json::Value {
    serde_json::json!({
        "classname": leak.classname,
        "origin": [leak.origin.x, leak.origin.y, leak.origin.z],
        "file": leak.file,
        "line": leak.line,
        "pointfile": pts.display().to_string(),
        "points": leak.path.len(),
        "explanation": LeakReport::EXPLANATION,
    })
}

fn print_leak(leak: &LeakReport, pts: &Path) {
    eprintln!("{leak}");
    eprintln!("pointfile: {} ({} points)", pts.display(), leak.path.len());
    eprintln!("{}", LeakReport::EXPLANATION);
}

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<Outcome> {
    let t0 = std::time::Instant::now();
    let out = args.output.clone().unwrap_or_else(|| with_extension(&args.input, "slvl"));
    let prt_path = with_extension(&out, "prt");
    let pts_path = with_extension(&out, "pts");
    // The level, portal file, pointfile and vis checkpoint: checked up front (apart from the map
    // and one another, and writable), rather than after the whole compile.
    let outputs: Vec<&Path> = [&out, &prt_path, &pts_path]
        .into_iter()
        .map(PathBuf::as_path)
        .chain(args.vis.state.as_deref())
        .collect();
    let source = Source::read(&args.input)?;
    output::check(&[&args.input], &outputs)?;
    let opts = CompileOptions {
        threads: args.threads,
        allow_leak: args.allow_leak,
        vis: (!args.no_vis).then(|| args.vis.options()),
        max_memory: args.vis.max_memory,
        cancel: crate::interrupt::cancel(),
    };
    // Some phases advance per brush or face from worker threads: gather 32 steps per update.
    let bars = Bars::batched(args.json, 32);
    let mut compiled = match compile(&source, &opts, &bars) {
        Ok(c) => c,
        Err(CompileError::Leak(leak)) => {
            output::write(&pts_path, leak.pointfile().as_bytes(), t0)?;
            if args.json {
                println!(
                    "{}",
                    serde_json::json!({ "input": args.input, "leak": leak_json(&leak, &pts_path) })
                );
            } else {
                print_leak(&leak, &pts_path);
            }
            return Ok(Outcome::Finding);
        }
        Err(CompileError::Vis(VisError::Interrupted { done, total })) => {
            anyhow::bail!("vis {}", crate::interrupt::interrupted(done, total, args.vis.state.is_some()))
        }
        Err(CompileError::Cancelled { phase }) => {
            crate::interrupt::announce_stop();
            anyhow::bail!("{}: stopped during {phase} on request; nothing was written", args.input.display())
        }
        // Vis's own message says what failed ("vis would need ..."): name the input before it.
        Err(CompileError::Vis(e)) => {
            return Err(anyhow::Error::new(e).context(args.input.display().to_string()));
        }
        Err(e) => return Err(e.into()),
    };
    // The portal file (or the pointfile of a leak) first and the level last, all or none: the
    // level records which portal file belongs to it (none for a leak).
    let wrote_prt = compiled.leak.is_none();
    let beside = match &compiled.leak {
        None => (prt_path.as_path(), sightline_formats::prt::write(&compiled.prt).into_bytes()),
        Some(leak) => (pts_path.as_path(), leak.pointfile().into_bytes()),
    };
    compiled.level.portal_file = wrote_prt.then(|| sightline_formats::prt::fingerprint(&beside.1));
    sightline_formats::slvl::validate(&compiled.level).context("the compiled level is inconsistent")?;
    let level =
        sightline_formats::slvl::write(&compiled.level, &sightline_formats::slvl::WriteOptions::default());
    output::write_together(&[(beside.0, &beside.1), (&out, &level)], t0)?;
    if wrote_prt {
        output::remove_stale(&pts_path, "pointfile of an earlier leak");
    }
    report(args, &compiled, &out, wrote_prt.then_some(prt_path.as_path()), &pts_path);
    Ok(if compiled.leak.is_some() { Outcome::Finding } else { Outcome::Clean })
}

fn report(args: &Args, c: &Compiled, out: &Path, prt: Option<&Path>, pts: &Path) {
    let s = &c.stats;
    if args.json {
        let v = serde_json::json!({
            "input": args.input,
            "output": out,
            "prt": prt,
            "prt_format": format!("{:?}", c.prt.format),
            "prt_portals": c.prt.portals.len(),
            "stats": s,
            "vis": c.vis,
            "leak": c.leak.as_ref().map(|l| leak_json(l, pts)),
        });
        println!("{v}");
        return;
    }
    let total: f64 = s.phases.iter().map(|p| p.seconds).sum();
    println!("compiled {} -> {} in {total:.3} s", args.input.display(), out.display());
    let phases: Vec<String> = s.phases.iter().map(|p| format!("{} {:.3} s", p.name, p.seconds)).collect();
    println!("  phases: {}", phases.join(", "));
    println!(
        "  brushes {} (world {}, detail {}, submodels {}), faces {}, planes {}, nodes {}, leaves {}",
        s.brushes, s.world_brushes, s.detail_brushes, s.submodels, s.faces, s.planes, s.nodes, s.leaves
    );
    println!(
        "  vis leaves {}, clusters {}, portals {} ({} in the {:?} file), outside leaves filled solid {}",
        s.vis_leaves,
        s.clusters,
        s.portals,
        c.prt.portals.len(),
        c.prt.format,
        s.filled_leaves
    );
    for v in &s.visclusters {
        println!("  func_viscluster at line {}: {} vis leaves in one cluster", v.line, v.leaves);
    }
    if let Some(v) = &c.vis {
        println!(
            "  vis: average {:.1} visible clusters ({:.1} %), max {}, {} bytes of PVS",
            v.avg_visible,
            v.percent_visible,
            v.max_visible,
            c.level.pvs_data.len()
        );
        if v.resumed_portals > 0 {
            println!("  vis: {} portals resumed from the state file", v.resumed_portals);
        }
        if let Some(k) = &v.coarsened {
            println!(
                "  vis: merged {} clusters into {} to fit its memory or work limit (--coarsen): the PVS is looser, {} visible leaf pairs against at least {} unmerged (at most {:.1} times)",
                k.clusters_before,
                k.clusters_after,
                v.visible_pairs,
                k.fine_pairs_lower,
                v.visible_pairs as f64 / k.fine_pairs_lower.max(1) as f64
            );
            for g in &k.largest_groups {
                let [x, y, z] = g.centre;
                println!(
                    "  vis: merged group of {} leaves ({} clusters) around ({x:.0} {y:.0} {z:.0})",
                    g.leaves, g.clusters
                );
            }
        }
    } else {
        println!("  no vis: the level has no PVS");
    }
    for w in &s.warnings {
        println!("  warning: {w}");
    }
    if let Some(p) = prt {
        println!("  portals: {}", p.display());
    }
    if let Some(leak) = &c.leak {
        print_leak(leak, pts);
    }
}
