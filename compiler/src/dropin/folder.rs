//! One external `.vis` pack of every `.bsp` directly in a folder (any case of the extension,
//! sorted by file name), each vised with the same options and written as one record.
//!
//! Engines read `maps/NAME.vis`, then `GAMEDIR.vis` in the game folder, so a pack for a whole game
//! is written as, for example, `id1/id1.vis`. A map that cannot be done is skipped and listed with
//! the reason: not BSP29 (engines load external `.vis` files for BSP29 maps only), a file name of
//! 32 bytes or more, a name equal to an earlier map's but for case, no `.prt` beside it (without
//! portals rebuilt from the tree), or any error reading or vising it. The pack holds the rest;
//! when no map could be done nothing is written. A state file is refused (one checkpoint cannot
//! serve many maps).

use std::path::{Path, PathBuf};
use std::time::Instant;

use sightline_formats::vispatch::{self, VisPatchRecord};

use super::quake::{is_bsp, map_name, vis_input, write_pack};
use sightline_job::input::{InputError, read_input};
use sightline_job::progress::Progress;

use super::{DropInError, DropInOptions, PackReport, PackedMap, SkippedMap};
use crate::vis::{self, VisResult};
use crate::visdata::{self, Rows};

/// Vises every `.bsp` in `dir` with `opts` into the pack `out` (see the module docs);
/// [`DropInOptions::external_vis`] is ignored. A report with skipped maps is a finding for the
/// caller; `Err` when no map could be done.
pub fn run(
    dir: &Path,
    out: &Path,
    opts: &DropInOptions,
    progress: &dyn Progress,
) -> Result<PackReport, DropInError> {
    let t0 = Instant::now();
    if opts.vis.state.is_some() {
        return Err(DropInError::refused(dir, "--state resumes one map, not a folder of them"));
    }
    let opts = DropInOptions { external_vis: Some(out.to_path_buf()), ..opts.clone() };
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|source| InputError::Io { path: dir.into(), source })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| is_bsp(p) && p.is_file())
        .collect();
    files.sort();
    let inputs: Vec<PathBuf> = files.iter().flat_map(|f| super::inputs_of(f)).collect();
    let inputs: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
    sightline_job::apart::check_outputs(&inputs, &[out])?;
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
        match pack_one(file, &opts, progress, &records) {
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
            Err(e) => report.skipped.push(SkippedMap { file: file.display().to_string(), reason: chain(&e) }),
        }
    }
    if records.is_empty() {
        let why: Vec<String> = report.skipped.iter().map(|s| format!("  {}: {}", s.file, s.reason)).collect();
        return Err(DropInError::refused(
            dir,
            format!("no .bsp in it could be vised; nothing written\n{}", why.join("\n")),
        ));
    }
    write_pack(out, &records, t0)?;
    report.output = Some(out.display().to_string());
    report.total_seconds = t0.elapsed().as_secs_f64();
    Ok(report)
}

/// An error with its causes, joined by `": "` (as the binary prints errors).
fn chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut source = e.source();
    while let Some(cause) = source {
        s += &format!(": {cause}");
        source = cause.source();
    }
    s
}

/// The record of one map of a pack (`done` are the records made so far).
fn pack_one(
    file: &Path,
    opts: &DropInOptions,
    progress: &dyn Progress,
    done: &[VisPatchRecord],
) -> Result<(VisPatchRecord, VisResult), DropInError> {
    let name = map_name(file)?;
    if let Some(other) = vispatch::find(done, &name) {
        return Err(DropInError::refused(
            file,
            format!(
                "the pack already has `{}` (engines compare names without regard to case)",
                other.map_name
            ),
        ));
    }
    let (input, _) = vis_input(file, read_input(file)?, opts)?;
    let Some(b) = &input.bsp else { return Err(DropInError::refused(file, "not a .bsp")) };
    let mut result = super::flow(&input.prt, opts, progress, file)?;
    if let Some(d) = opts.farplane() {
        vis::farplane::cull(&mut result, &visdata::cluster_boxes(&b.bsp, &input.prt), d)
            .map_err(DropInError::vis_at(file))?;
    }
    let rows = Rows::new(&result);
    let ambient = input.ambient_options(opts.ambient_off);
    let record = visdata::vispatch_record(&name, &b.bytes, &b.bsp, &result, &rows, &ambient)
        .map_err(|source| DropInError::At { path: file.into(), source: Box::new(source) })?;
    Ok((record, result))
}
