//! The drop-in vis of a Quake 2 `.bsp` (`IBSP` 38): qbsp's PRT1 beside it names clusters, so vis
//! computes cluster rows, [`crate::phs`] adds the PHS, and the visibility lump is replaced
//! ([`sightline_formats::bsp::q2`]). With [`DropInOptions::phs_only`] only the PHS of a vised
//! file is recomputed, every PVS byte kept. A `func_viscluster` brush entity merges the
//! clusters whose leaves lie in its model's box (`viscluster::level_merge`). The far plane culls
//! by cluster boxes made from the file's leaves ([`visdata::level_cluster_boxes`]) before the PHS
//! is formed; ambient options do not apply (Quake 2 has no ambient levels).

use std::path::Path;
use std::time::Instant;

use sightline_formats::bits;
use sightline_formats::bsp::{CompiledMap, Parsed, q2};
use sightline_formats::prt::PrtFormat;

use sightline_job::progress::Progress;

use super::{DropInError, DropInOptions, Q2Report};
use crate::{phs, vis, visdata};

/// Runs the drop-in vis on the Quake 2 `.bsp` at `path`, whose bytes are `bytes`.
pub fn run(
    path: &Path,
    bytes: Vec<u8>,
    opts: &DropInOptions,
    progress: &dyn Progress,
    t0: Instant,
) -> Result<Q2Report, DropInError> {
    refuse_quake1_options(path, opts)?;
    let map = CompiledMap::read(bytes).map_err(DropInError::bsp(path))?;
    let Parsed::Quake2(_) = map.parsed() else {
        return Err(DropInError::refused(path, "not a Quake 2 .bsp (IBSP 38)"));
    };
    map.check_vis_layout().map_err(DropInError::bsp(path))?;
    let bytes = map.bytes();
    let farplane = opts.farplane();
    if opts.phs_only && farplane.is_some() {
        return Err(DropInError::refused(
            path,
            "--farplane changes the PVS, which --phs-only keeps byte for byte",
        ));
    }
    let (out, report) = if opts.phs_only {
        let (out, repair) = phs::repair_phs(bytes).map_err(DropInError::bsp(path))?;
        let report = Q2Report {
            input: path.display().to_string(),
            game: "quake2",
            mode: "phs-only",
            prt: None,
            vis: None,
            clusters: repair.clusters,
            pvs_pairs: repair.pvs_pairs,
            phs_pairs: repair.phs_pairs,
            phs_repair: Some(repair),
            farplane: None,
            farplane_hidden_pairs: None,
            visibility_bytes: 0,
            total_seconds: 0.0,
        };
        (out, report)
    } else {
        let (prt_path, prt) = super::portals_beside(path, "")?;
        let prt_path = &prt_path;
        let clusters = map.clusters();
        if prt.format != PrtFormat::Prt1 || prt.num_leaves as usize != clusters {
            return Err(DropInError::refused(
                prt_path,
                format!(
                    "{} with {} leaves does not match the {clusters} clusters of {} (Quake 2 qbsp writes PRT1 over clusters)",
                    prt.format.header(),
                    prt.num_leaves,
                    path.display()
                ),
            ));
        }
        let (level, repairs) = map.to_level_with_repairs();
        let model_box = |m: u32| level.models.get(m as usize).map(|m| (m.mins, m.maxs));
        let merge = crate::viscluster::level_merge(&level, model_box, &prt);
        let mut result = super::flow_merged(&prt, merge.as_ref(), "clusters", opts, progress, path)?;
        let mut farplane_hidden_pairs = None;
        if let Some(d) = farplane {
            for r in repairs.iter().filter(|r| r.record == "leaf") {
                progress.warn(&format!(
                    "{}: {r} (the far plane culls clusters by their leaves' boxes)",
                    path.display()
                ));
            }
            let boxes = visdata::level_cluster_boxes(&level, &prt);
            farplane_hidden_pairs =
                Some(vis::farplane::cull(&mut result, &boxes, d).map_err(DropInError::vis_at(path))?);
        }
        let n = clusters;
        let rows = super::cluster_rows(&result, n);
        let words = bits::words(n);
        let pvs = phs::words_from_bytes(&rows, n);
        let phs_rows = phs::phs(&pvs, words, n);
        let lump = phs::q2_vis_lump(&pvs, &phs_rows, words, n).map_err(DropInError::bsp(path))?;
        let out = q2::write_with_visibility(bytes, &lump).map_err(DropInError::bsp(path))?;
        let report = Q2Report {
            input: path.display().to_string(),
            game: "quake2",
            mode: "vis",
            prt: Some(prt_path.display().to_string()),
            vis: Some(result.stats.clone()),
            clusters: n,
            pvs_pairs: bits::count(&pvs),
            phs_pairs: bits::count(&phs_rows),
            phs_repair: None,
            farplane,
            farplane_hidden_pairs,
            visibility_bytes: 0,
            total_seconds: 0.0,
        };
        (out, report)
    };
    super::write(path, &out, t0)?;
    let visibility_bytes = q2::read_header(&out).map_or(0, |l| l[q2::lump::VISIBILITY].length);
    Ok(Q2Report { visibility_bytes, total_seconds: t0.elapsed().as_secs_f64(), ..report })
}

/// Refuses the options only Quake 1 and Half-Life files take (Quake 2 and 3 alike).
pub(crate) fn refuse_quake1_options(path: &Path, opts: &DropInOptions) -> Result<(), DropInError> {
    if opts.portals_from_tree.is_some() || opts.external_vis.is_some() {
        return Err(DropInError::refused(
            path,
            "--portals-from-bsp and --external-vis are for Quake 1 and Half-Life BSPs (BSP29, BSP2, BSP2-RMQ, BSP30)",
        ));
    }
    Ok(())
}
