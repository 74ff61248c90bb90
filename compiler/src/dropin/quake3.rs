//! The drop-in vis of a Quake 3 `.bsp` (`IBSP` 46 or 47): the cluster PVS from q3map2's portal
//! file beside it, written into the visibility lump (lump 16), every other byte kept.
//!
//! q3map2's `.prt` ([`PrtFormat::Q3map2`], or a plain PRT1 over the same clusters) names
//! clusters, so vis runs on it as on a Quake 1 PRT1 and the rows are stored uncompressed, as
//! [`q3::vis_lump`] lays them out. The far plane and the PHS are refused, and the ambient options
//! do not apply (Quake 3 has no ambient levels). A `func_viscluster` brush entity merges the
//! clusters whose leaves lie in its model's box (`viscluster::level_merge`).

use std::path::Path;
use std::time::Instant;

use sightline_formats::bsp::{CompiledMap, Parsed, q3};
use sightline_formats::prt::PrtFormat;

use sightline_job::progress::Progress;

use super::{DropInError, DropInOptions, Q3Report};

/// How to get a portal file beside a Quake 3 map (the end of the error when there is none).
pub(crate) const PORTALS_HINT: &str = "; run q3map2 -bsp, or -vis with -saveprt";

/// Runs the drop-in vis on the Quake 3 `.bsp` at `path`, whose bytes are `bytes`.
pub fn run(
    path: &Path,
    bytes: Vec<u8>,
    opts: &DropInOptions,
    progress: &dyn Progress,
    t0: Instant,
) -> Result<Q3Report, DropInError> {
    super::quake2::refuse_quake1_options(path, opts)?;
    if opts.farplane().is_some() {
        return Err(DropInError::refused(path, "--farplane is not supported for Quake 3 BSPs yet"));
    }
    if opts.phs_only {
        return Err(DropInError::refused(
            path,
            "--phs-only needs a Quake 2 .bsp (IBSP 38); Quake 3 has no PHS",
        ));
    }
    let name = path.display();
    let map = CompiledMap::read(bytes).map_err(DropInError::bsp(path))?;
    map.check_vis_layout().map_err(DropInError::bsp(path))?;
    let (prt_path, portals) = super::portals_beside(path, PORTALS_HINT)?;
    let prt_path = &prt_path;
    let prt_name = prt_path.display().to_string();
    let clusters = map.clusters();
    let over_clusters = matches!(portals.format, PrtFormat::Q3map2 | PrtFormat::Prt1);
    if !over_clusters || portals.num_clusters as usize != clusters {
        return Err(DropInError::refused(
            prt_path,
            format!(
                "{} with {} clusters does not match the {clusters} clusters of {name} (q3map2 -bsp writes both)",
                portals.format.header(),
                portals.num_clusters,
            ),
        ));
    }
    let merge = match map.parsed() {
        Parsed::Quake3(f) => {
            let model_box = |m: u32| f.models.get(m as usize).map(|m| (m.mins, m.maxs));
            crate::viscluster::level_merge(&map.to_level(), model_box, &portals)
        }
        _ => None,
    };
    let result = super::flow_merged(&portals, merge.as_ref(), "clusters", opts, progress, path)?;
    let rows = super::cluster_rows(&result, clusters);
    let lump = q3::vis_lump(clusters, &rows).map_err(DropInError::bsp(path))?;
    let out = q3::write_with_visibility(map.bytes(), &lump).map_err(DropInError::bsp(path))?;
    super::write(path, &out, t0)?;
    Ok(Q3Report {
        input: name.to_string(),
        game: "quake3",
        prt: prt_name,
        prt_format: if portals.format == PrtFormat::Q3map2 { "q3map2" } else { "PRT1" },
        vis: result.stats.clone(),
        clusters,
        pvs_pairs: rows.iter().map(|b| u64::from(b.count_ones())).sum(),
        visibility_bytes: lump.len(),
        total_seconds: t0.elapsed().as_secs_f64(),
    })
}
