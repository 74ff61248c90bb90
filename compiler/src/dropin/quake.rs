//! The drop-in vis of a Quake 1 or Half-Life `.bsp` (BSP29, BSP2, BSP2-RMQ, BSP30), or of a
//! portal file alone.
//!
//! A `.bsp` takes its portals from the `.prt` beside it ([`VisInput::from_bytes`]) or rebuilt from
//! its tree ([`VisInput::from_bsp_tree_of`]); the rows, with ambient levels, go back into the `.bsp`
//! ([`visdata::write_into_bsp_with`]) or, with [`DropInOptions::external_vis`], into an external
//! `.vis` record engines load beside a BSP29 map ([`visdata::vispatch_record`]). A portal file
//! alone gives `NAME.vis` ([`Rows::vis_file`]). The far plane needs the `.bsp` (its leaf bounds).

use std::path::Path;
use std::time::Instant;

use sightline_formats::bsp::BspVersion;
use sightline_formats::bsp::bounds::{self, BoundsRepair};
use sightline_formats::texture::Ambient;
use sightline_formats::vispatch::{self, VisPatchRecord};

use sightline_job::progress::Progress;

use super::{DropInError, DropInOptions, QuakeReport};
use crate::bsp_portals::BspPortalStats;
use crate::vis;
use crate::visdata::{self, BspInput, Rows, VisInput};

/// Runs the drop-in vis on the Quake 1 or Half-Life `.bsp`, or the portal file, at `path`, whose
/// bytes are `bytes`.
pub fn run(
    path: &Path,
    bytes: Vec<u8>,
    opts: &DropInOptions,
    progress: &dyn Progress,
    t0: Instant,
) -> Result<QuakeReport, DropInError> {
    if opts.phs_only {
        return Err(DropInError::refused(path, "--phs-only needs a Quake 2 .bsp (IBSP 38)"));
    }
    let (input, rebuilt) = vis_input(path, bytes, opts)?;
    let farplane = opts.farplane();
    if farplane.is_some() && input.bsp.is_none() {
        return Err(DropInError::refused(
            path,
            "--farplane needs the .bsp (its leaf bounds bound what each cluster holds); run vis on the .bsp",
        ));
    }
    let ambient = input.ambient_options(opts.ambient_off);
    let texinfo_side = input.bsp.as_ref().and_then(|b| b.texinfo_json.as_ref());
    if let Some(side) = texinfo_side.filter(|s| !s.matches) {
        progress.warn(&format!(
            "{} names texinfo {} but the BSP has {}: it belongs to another compile, its flags are ignored",
            side.path.display(),
            side.flags.max_texinfo.unwrap_or(0),
            input.bsp.as_ref().map_or(0, |b| b.bsp.texinfo.len())
        ));
    }
    let read_seconds = t0.elapsed().as_secs_f64();
    let merge = input.bsp.as_ref().and_then(|b| crate::viscluster::bsp_merge(&b.bsp, &input.prt));
    let mut result = super::flow_merged(&input.prt, merge.as_ref(), "vis leaves", opts, progress, path)?;
    let mut farplane_hidden_pairs = 0;
    if let (Some(d), Some(b)) = (farplane, &input.bsp) {
        let unbounded: Vec<u32> = (1..=b.bsp.visleafs())
            .filter(|&l| b.bsp.leaves.get(l).is_some_and(|l| !bounds::usable(l.mins, l.maxs)))
            .map(|l| l as u32)
            .collect();
        if !unbounded.is_empty() {
            let stand_in = "the far plane culls no cluster holding one";
            let r = BoundsRepair { record: "leaf", indices: unbounded, stand_in };
            progress.warn(&format!("{}: {r}", path.display()));
        }
        let boxes = visdata::cluster_boxes(&b.bsp, &input.prt);
        farplane_hidden_pairs =
            vis::farplane::cull(&mut result, &boxes, d).map_err(DropInError::vis_at(path))?;
    }
    let t1 = Instant::now();
    let rows = Rows::new(&result);
    let output = match (&input.bsp, &opts.external_vis) {
        (Some(b), Some(out)) => {
            let record =
                visdata::vispatch_record(&map_name(path)?, &b.bytes, &b.bsp, &result, &rows, &ambient)
                    .map_err(|source| DropInError::At { path: path.into(), source: Box::new(source) })?;
            write_pack(out, &[record], t0)?;
            out.clone()
        }
        (Some(b), None) => {
            let out = visdata::write_into_bsp_with(&b.bytes, &b.bsp, &result, &rows, &ambient)?;
            super::write(path, &out, t0)?;
            path.to_path_buf()
        }
        (None, _) => {
            let vis_path = path.with_extension("vis");
            super::write(&vis_path, &rows.vis_file()?, t0)?;
            vis_path
        }
    };
    let used_side = texinfo_side.filter(|s| s.matches);
    Ok(QuakeReport {
        input: path.display().to_string(),
        output: output.display().to_string(),
        prt_format: input.prt.format.header().to_string(),
        portals_rebuilt: rebuilt,
        vis: result.stats.clone(),
        compressed_bytes: rows.data.len(),
        farplane,
        farplane_hidden_pairs,
        ambient_off: [Ambient::Water, Ambient::Sky, Ambient::Slime, Ambient::Lava]
            .into_iter()
            .filter(|a| ambient.off[a.index()])
            .map(Ambient::name)
            .collect(),
        texinfo_json: used_side.map(|s| s.path.display().to_string()),
        noambient_texinfos: used_side.map_or(0, |s| s.flags.noambient.len()),
        read_seconds,
        write_seconds: t1.elapsed().as_secs_f64(),
        total_seconds: t0.elapsed().as_secs_f64(),
    })
}

/// True when `path` is named `.bsp` (any case).
pub(crate) fn is_bsp(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("bsp"))
}

/// The vis input of `path` (whose bytes are `bytes`): its `.prt`, or its portals rebuilt from its
/// tree (with their counts). With an external `.vis` the `.bsp` must be BSP29 and its name fit a
/// record; both are checked here, before any vis work.
pub(crate) fn vis_input(
    path: &Path,
    bytes: Vec<u8>,
    opts: &DropInOptions,
) -> Result<(VisInput, Option<BspPortalStats>), DropInError> {
    if (opts.portals_from_tree.is_some() || opts.external_vis.is_some()) && !is_bsp(path) {
        return Err(DropInError::refused(path, "--portals-from-bsp and --external-vis need a .bsp"));
    }
    if opts.external_vis.is_some() {
        map_name(path)?;
    }
    let (input, stats) = match opts.portals_from_tree {
        Some(tree) => {
            let (input, stats) = VisInput::from_bsp_tree_of(BspInput::from_bytes(path, bytes)?, tree)?;
            (input, Some(stats))
        }
        None => (VisInput::from_bytes(path, bytes)?, None),
    };
    if opts.external_vis.is_some()
        && let Some(b) = &input.bsp
        && b.bsp.version != BspVersion::Bsp29
    {
        return Err(DropInError::refused(
            path,
            format!("{} file: engines load external .vis files for BSP29 maps only", b.bsp.version.name()),
        ));
    }
    Ok((input, stats))
}

/// The record name of the map at `path`: its file name, which must fit a record (and be UTF-8:
/// a record spelling another name than the file's would never be found by an engine).
pub(crate) fn map_name(path: &Path) -> Result<String, DropInError> {
    let Some(name) = path.file_name().unwrap_or_default().to_str().map(str::to_string) else {
        return Err(DropInError::refused(
            path,
            "an external .vis names its map in UTF-8; this file name is not",
        ));
    };
    if !vispatch::valid_name(&name) {
        return Err(DropInError::refused(
            path,
            format!(
                "an external .vis names its map in at most {} bytes; `{name}` does not fit",
                vispatch::NAME_BYTES - 1
            ),
        ));
    }
    Ok(name)
}

/// Writes an external `.vis` pack of `records` to `out`.
pub(crate) fn write_pack(out: &Path, records: &[VisPatchRecord], t0: Instant) -> Result<(), DropInError> {
    let bytes = vispatch::write(records).map_err(|e| DropInError::Write {
        path: out.to_path_buf(),
        source: std::io::Error::new(std::io::ErrorKind::InvalidData, e),
    })?;
    super::write(out, &bytes, t0)
}
