//! `sightline vis` on a Quake 3 `.bsp` (`IBSP` 46 or 47): the cluster PVS from q3map2's portal
//! file beside it, written into the visibility lump (lump 16), every other byte kept.
//!
//! q3map2's `.prt` ([`PrtFormat::Q3map2`], or a plain PRT1 over the same clusters) names
//! clusters, so vis runs on it as on a Quake 1 PRT1 and the rows are stored uncompressed, as
//! [`q3::vis_lump`] lays them out. Vis options (`--fast`, `--level`, `--threads`, `--state`,
//! `--max-memory`) work as for Quake 1; `--farplane` and `--phs-only` are refused, and the
//! ambient options do not apply (Quake 3 has no ambient levels).

use std::path::Path;
use std::time::Instant;

use anyhow::{Context, bail};

use sightline_compiler::vis::{VisOptions, VisStats};
use sightline_formats::bsp::q3;
use sightline_formats::prt::{self, PrtFormat};

use super::vis::{Args, compute, remove_state};
use crate::cli::Outcome;

/// True when `path` is a file that starts like a Quake 3 BSP ([`q3::is_q3`]).
pub fn starts_like_q3(path: &Path) -> bool {
    super::vis::file_head(path).is_some_and(|h| q3::is_q3(&h))
}

/// What `sightline vis` reports for a Quake 3 `.bsp` (`--json` prints this).
#[derive(Debug, Clone, serde::Serialize)]
pub struct Q3Report {
    /// Input (and output) file.
    pub input: String,
    /// Always `"quake3"`.
    pub game: &'static str,
    /// The portal file read.
    pub prt: String,
    /// Its dialect (`"q3map2"` or `"PRT1"`).
    pub prt_format: &'static str,
    /// Vis statistics.
    pub vis: VisStats,
    /// Clusters.
    pub clusters: usize,
    /// Ordered visible cluster pairs written, self included.
    pub pvs_pairs: u64,
    /// Bytes of the visibility lump written.
    pub visibility_bytes: usize,
    /// Total seconds.
    pub total_seconds: f64,
}

/// Runs vis on the Quake 3 BSP at `path` (see the module docs).
pub fn run(args: &Args, path: &Path, t0: Instant) -> anyhow::Result<Outcome> {
    let name = path.display();
    if args.farplane.is_some_and(|d| d > 0.0) {
        bail!("{name}: --farplane is not supported for Quake 3 BSPs yet");
    }
    if args.phs_only {
        bail!("{name}: --phs-only needs a Quake 2 .bsp (IBSP 38); Quake 3 has no PHS");
    }
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {name}"))?;
    let file = q3::read(&bytes).with_context(|| format!("{name}"))?;
    q3::check_vis_layout(&file.lumps).with_context(|| format!("{name}"))?;
    let tried = prt::beside_bsp(path);
    let Some(prt_path) = tried.iter().find(|p| p.is_file()) else {
        bail!("{name}: no portal file beside it (tried {tried:?}; run q3map2 -bsp, or -vis with -saveprt)");
    };
    let prt_name = prt_path.display().to_string();
    let prt_bytes = std::fs::read(prt_path).with_context(|| format!("cannot read {prt_name}"))?;
    let portals = prt::read_bytes(&prt_bytes, &prt_name)?;
    let clusters = file.leaf_cluster_count();
    let over_clusters = matches!(portals.format, PrtFormat::Q3map2 | PrtFormat::Prt1);
    if !over_clusters || portals.num_clusters as usize != clusters {
        bail!(
            "{prt_name}: {} with {} clusters does not match the {clusters} clusters of {name} (q3map2 -bsp writes both)",
            portals.format.header(),
            portals.num_clusters,
        );
    }
    remove_state(args)?;
    let opts = VisOptions { threads: args.threads, ..args.vis.options() };
    let result = compute(&portals, &opts, args.json || args.no_progress, path)?;
    let mut rows = Vec::with_capacity(clusters * sightline_formats::bits::bytes::len(clusters));
    let mut row = Vec::new();
    for c in 0..clusters {
        result.leaf_row_bytes(c, &mut row);
        rows.extend_from_slice(&row);
    }
    let lump = q3::vis_lump(clusters, &rows).with_context(|| format!("{name}"))?;
    let out = q3::write_with_visibility(&bytes, &lump).with_context(|| format!("{name}"))?;
    crate::output::write(path, &out, t0)?;
    let report = Q3Report {
        input: name.to_string(),
        game: "quake3",
        prt: prt_name,
        prt_format: if portals.format == PrtFormat::Q3map2 { "q3map2" } else { "PRT1" },
        vis: result.stats.clone(),
        clusters,
        pvs_pairs: rows.iter().map(|b| u64::from(b.count_ones())).sum(),
        visibility_bytes: lump.len(),
        total_seconds: t0.elapsed().as_secs_f64(),
    };
    crate::out::report(args.json, &report, || text_report(&report))?;
    Ok(Outcome::Clean)
}

fn text_report(r: &Q3Report) -> String {
    let v = &r.vis;
    let mode = if v.fast { "fast (base vis only)".to_string() } else { format!("full, level {}", v.level) };
    format!(
        "{} (Quake 3, {} portals from {}): {} clusters\n\
         vis {mode}, {} threads; base {:.3} s, flow {:.3} s\n\
         PVS pairs {} (average {:.1} clusters)\n\
         visibility lump: {} bytes -> {}\ntime: total {:.3} s\n",
        r.input,
        r.prt_format,
        r.prt,
        r.clusters,
        v.threads,
        v.base_seconds,
        v.flow_seconds,
        r.pvs_pairs,
        r.pvs_pairs as f64 / r.clusters.max(1) as f64,
        r.visibility_bytes,
        r.input,
        r.total_seconds
    )
}
