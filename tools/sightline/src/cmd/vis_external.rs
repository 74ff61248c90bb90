//! `sightline vis` for compiled Quake 1 maps without their source: portals rebuilt from the
//! `.bsp`'s tree (`--portals-from-bsp`, [`sightline_compiler::bsp_portals`]) and the PVS written to
//! an external `.vis` file engines load beside the map (`--external-vis`,
//! [`sightline_formats::vispatch`]) instead of into the `.bsp`.
//!
//! # Folder mode
//! `sightline vis DIR --external-vis -o PACK.vis` vises every `*.bsp` directly in `DIR` (any case
//! of the extension; sorted by file name) with the same flags and writes one pack holding a record
//! per map. Engines read `maps/NAME.vis`, then `GAMEDIR.vis` in the game folder, so a pack for a
//! whole game is written as, for example, `-o id1/id1.vis`. A map that cannot be done is skipped
//! and listed with the reason: not BSP29 (engines load external `.vis` files for BSP29 maps
//! only), a file name of 32 bytes or more, a name equal to an earlier map's but for case, no `.prt`
//! beside it (without `--portals-from-bsp`), or any error reading or vising it. The pack holds the
//! rest, and the exit code is 1 when some map was skipped (a finding, like a validation miss), 2
//! when none could be done (nothing is written), 0 otherwise. `--state` is refused there (one
//! checkpoint cannot serve many maps).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, bail};
use sightline_compiler::bsp_portals::{BspPortalOptions, BspPortalStats};
use sightline_compiler::vis::{self, VisOptions, VisResult};
use sightline_compiler::visdata::{self, AmbientOptions, BspInput, Rows, VisInput};
use sightline_formats::bsp::BspVersion;
use sightline_formats::vispatch::{self, VisPatchRecord};

use crate::cli::Outcome;
use crate::cmd::vis::Args;

/// Refuses flag combinations that make no sense for `path` (a Quake 2 `.bsp` when `q2`).
pub(crate) fn check_flags(args: &Args, path: &Path, q2: bool) -> anyhow::Result<()> {
    let p = path.display();
    if (args.water.is_some() || args.no_clusters) && !args.portals_from_bsp {
        bail!(
            "{p}: --water and --no-clusters need --portals-from-bsp (a portal file has already decided which portals exist)"
        );
    }
    if args.output.is_some() && !args.external_vis {
        bail!("{p}: -o needs --external-vis (otherwise vis writes into the .bsp, or NAME.vis for a .prt)");
    }
    if !(args.portals_from_bsp || args.external_vis) {
        return Ok(());
    }
    if q2 {
        bail!(
            "{p}: --portals-from-bsp and --external-vis are for Quake 1 and Half-Life BSPs (BSP29, BSP2, BSP2-RMQ, BSP30)"
        );
    }
    if path.is_dir() {
        if !args.external_vis {
            bail!("{p}: a folder needs --external-vis (it makes one external .vis pack of every .bsp in it)");
        }
        if args.output.is_none() {
            bail!(
                "{p}: name the pack with -o (engines read maps/NAME.vis, then GAMEDIR.vis in the game folder: \
                 -o id1/id1.vis, for example)"
            );
        }
        if args.vis.state.is_some() {
            bail!("{p}: --state resumes one map, not a folder of them");
        }
    } else if !is_bsp(path) {
        bail!("{p}: --portals-from-bsp and --external-vis need a .bsp");
    }
    Ok(())
}

fn is_bsp(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("bsp"))
}

/// The vis input of `path`: its `.prt`, or its portals rebuilt from its tree under
/// `--portals-from-bsp` (with their counts). Under `--external-vis` the `.bsp` must be BSP29 and
/// its name fit a record; both are checked here, before any vis work.
pub(crate) fn read_input(args: &Args, path: &Path) -> anyhow::Result<(VisInput, Option<BspPortalStats>)> {
    if args.external_vis {
        map_name(path)?;
    }
    let (input, stats) = if args.portals_from_bsp {
        let opts = BspPortalOptions {
            liquids: args.water.unwrap_or_default().into(),
            no_clusters: args.no_clusters,
        };
        let (input, stats) = VisInput::from_bsp_tree(path, opts)?;
        (input, Some(stats))
    } else {
        (VisInput::read(path)?, None)
    };
    if args.external_vis
        && let Some(b) = &input.bsp
        && b.bsp.version != BspVersion::Bsp29
    {
        bail!(
            "{}: {} file: engines load external .vis files for BSP29 maps only",
            path.display(),
            b.bsp.version.name()
        );
    }
    Ok((input, stats))
}

/// The record name of the map at `path`: its file name, which must fit a record.
fn map_name(path: &Path) -> anyhow::Result<String> {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    if !vispatch::valid_name(&name) {
        bail!(
            "{}: an external .vis names its map in at most {} bytes; `{name}` does not fit",
            path.display(),
            vispatch::NAME_BYTES - 1
        );
    }
    Ok(name)
}

/// Writes the external `.vis` of one map (`-o`, else the `.bsp`'s name with `.vis`), for a
/// command started at `t0`; returns the file written.
pub(crate) fn write_single(
    args: &Args,
    path: &Path,
    b: &BspInput,
    result: &VisResult,
    rows: &Rows,
    ambient: &AmbientOptions,
    t0: Instant,
) -> anyhow::Result<PathBuf> {
    let record = visdata::vispatch_record(&map_name(path)?, &b.bytes, &b.bsp, result, rows, ambient)
        .with_context(|| format!("{}", path.display()))?;
    let out = args.output.clone().unwrap_or_else(|| path.with_extension("vis"));
    write_pack(&out, &[record], t0)?;
    Ok(out)
}

fn write_pack(out: &Path, records: &[VisPatchRecord], t0: Instant) -> anyhow::Result<()> {
    let bytes = vispatch::write(records).with_context(|| format!("cannot write {}", out.display()))?;
    crate::output::write(out, &bytes, t0)
}

/// One map of a pack, as reported.
#[derive(Debug, Clone, serde::Serialize)]
pub struct PackedMap {
    /// The record's map name.
    pub map: String,
    /// Vis leaves.
    pub vis_leaves: usize,
    /// Average visible leaves per vis leaf.
    pub avg_visible: f64,
    /// Portals vis ran on (rebuilt from the tree under `--portals-from-bsp`).
    pub portals: usize,
    /// Bytes of the record's visdata.
    pub visdata_bytes: usize,
    /// Seconds for this map.
    pub seconds: f64,
}

/// A map left out of a pack.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SkippedMap {
    /// The file.
    pub file: String,
    /// Why.
    pub reason: String,
}

/// What folder mode reports (`--json` prints this).
#[derive(Debug, Clone, serde::Serialize)]
pub struct PackReport {
    /// The folder read.
    pub input: String,
    /// The pack written (absent when no map could be done).
    pub output: Option<String>,
    /// Maps in the pack, in order.
    pub maps: Vec<PackedMap>,
    /// Maps left out.
    pub skipped: Vec<SkippedMap>,
    /// Total seconds.
    pub total_seconds: f64,
}

/// Folder mode (see the module docs).
pub(crate) fn run_folder(args: &Args, dir: &Path) -> anyhow::Result<Outcome> {
    let t0 = Instant::now();
    let out = args.output.clone().context("folder mode needs -o")?;
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("cannot list {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| is_bsp(p) && p.is_file())
        .collect();
    files.sort();
    let mut records: Vec<VisPatchRecord> = Vec::new();
    let mut report = PackReport {
        input: dir.display().to_string(),
        output: None,
        maps: Vec::new(),
        skipped: Vec::new(),
        total_seconds: 0.0,
    };
    for file in &files {
        let t = Instant::now();
        match pack_one(args, file, &records) {
            Ok((record, result)) => {
                report.maps.push(PackedMap {
                    map: record.map_name.clone(),
                    vis_leaves: result.stats.leaves as usize,
                    avg_visible: result.stats.avg_visible,
                    portals: result.stats.portals,
                    visdata_bytes: record.visdata.len(),
                    seconds: t.elapsed().as_secs_f64(),
                });
                records.push(record);
            }
            Err(e) => {
                report.skipped.push(SkippedMap { file: file.display().to_string(), reason: format!("{e:#}") })
            }
        }
    }
    if records.is_empty() {
        let why: Vec<String> = report.skipped.iter().map(|s| format!("  {}: {}", s.file, s.reason)).collect();
        bail!("{}: no .bsp in it could be vised; nothing written\n{}", dir.display(), why.join("\n"));
    }
    write_pack(&out, &records, t0)?;
    report.output = Some(out.display().to_string());
    report.total_seconds = t0.elapsed().as_secs_f64();
    crate::out::report(args.json, &report, || pack_text(&report))?;
    Ok(if report.skipped.is_empty() { Outcome::Clean } else { Outcome::Finding })
}

/// The record of one map of a pack (`done` are the records made so far).
fn pack_one(
    args: &Args,
    file: &Path,
    done: &[VisPatchRecord],
) -> anyhow::Result<(VisPatchRecord, VisResult)> {
    let name = map_name(file)?;
    if let Some(other) = vispatch::find(done, &name) {
        bail!(
            "{}: the pack already has `{}` (engines compare names without regard to case)",
            file.display(),
            other.map_name
        );
    }
    let (input, _) = read_input(args, file)?;
    let Some(b) = &input.bsp else { bail!("{}: not a .bsp", file.display()) };
    let opts = VisOptions { threads: args.threads, ..args.vis.options() };
    let mut result = crate::cmd::vis::compute(&input.prt, &opts, true, file)?;
    if let Some(d) = args.farplane.filter(|&d| d > 0.0) {
        vis::farplane::cull(&mut result, &visdata::cluster_boxes(&b.bsp, &input.prt), d)?;
    }
    let rows = Rows::new(&result);
    let ambient = input.ambient_options(args.ambient_off());
    let record = visdata::vispatch_record(&name, &b.bytes, &b.bsp, &result, &rows, &ambient)
        .with_context(|| format!("{}", file.display()))?;
    Ok((record, result))
}

fn pack_text(r: &PackReport) -> String {
    let mut s = format!("{}: {} maps", r.input, r.maps.len());
    if let Some(out) = &r.output {
        s += &format!(" -> {out}");
    }
    s += "\n";
    for m in &r.maps {
        s += &format!(
            "  {}: {} vis leaves, {} portals, average {:.1} visible, visdata {} bytes, {:.3} s\n",
            m.map, m.vis_leaves, m.portals, m.avg_visible, m.visdata_bytes, m.seconds
        );
    }
    if !r.skipped.is_empty() {
        s += &format!("skipped {} (not in the pack):\n", r.skipped.len());
        for k in &r.skipped {
            s += &format!("  {}: {}\n", k.file, k.reason);
        }
    }
    s + &format!("time: total {:.3} s\n", r.total_seconds)
}
