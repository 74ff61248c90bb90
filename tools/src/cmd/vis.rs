//! `sightline vis`: the PVS of a Quake `.bsp` (from its sibling `.prt`, written back into the
//! `.bsp` atomically) or of a `.prt` (written to `<name>.vis`).
//!
//! Drop-in rules for a `.bsp`: vis leaf `j` of the portal file is BSP leaf `j + 1` and owns PVS
//! row `j`; leaves of one cluster share one compressed row, identical rows are stored once; every
//! vis leaf's ambient sound levels (water, sky, slime, lava) become 255 when its PVS holds a face
//! textured with that liquid or sky, else 0, as the reference tool writes them. Leaves that are not
//! vis leaves keep their `visofs` and ambient levels.
//!
//! The `.vis` file written for a `.prt` input: the 8 bytes `SLVIS001`, then little-endian `u32`s
//! `leaves`, `row_bytes`, `data_bytes`, then one `u32` offset per leaf into the data, then the data:
//! Quake RLE rows (bit `j` of a row = leaf `j` visible).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::Instant;

use anyhow::{Context, bail};

use sightline_compiler::vis::{self, VisOptions, VisPhase, VisProgress, VisResult, VisStats};
use sightline_formats::bsp::{self, Bsp};
use sightline_formats::prt::{self, PortalFile};
use sightline_formats::rle;

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
    let is_bsp = args.input.extension().is_some_and(|e| e.eq_ignore_ascii_case("bsp"));
    let prt_path = if is_bsp { args.input.with_extension("prt") } else { args.input.clone() };
    let bsp_bytes = if is_bsp {
        Some(std::fs::read(&args.input).with_context(|| format!("cannot read {}", args.input.display()))?)
    } else {
        None
    };
    let bsp =
        bsp_bytes.as_deref().map(bsp::read).transpose().with_context(|| args.input.display().to_string())?;
    let prt = read_prt(&prt_path, is_bsp)?;
    if let Some(bsp) = &bsp
        && bsp.visleafs() != prt.num_leaves as usize
    {
        bail!(
            "{} has {} vis leaves but {} has {}: they come from different compiles",
            args.input.display(),
            bsp.visleafs(),
            prt_path.display(),
            prt.num_leaves
        );
    }
    let read_seconds = t0.elapsed().as_secs_f64();
    let opts = VisOptions { threads: args.threads, ..args.vis.options() };
    let result = compute(&prt, &opts, args.json)?;
    let t1 = Instant::now();
    let rows = Rows::new(&result);
    let output = match (&bsp, &bsp_bytes) {
        (Some(bsp), Some(bytes)) => {
            let out = write_into_bsp(bytes, bsp, &result, &rows)?;
            sightline_formats::atomic::write_file_atomic(&args.input, &out)
                .with_context(|| format!("cannot write {}", args.input.display()))?;
            args.input.clone()
        }
        _ => {
            let path = args.input.with_extension("vis");
            sightline_formats::atomic::write_file_atomic(&path, &rows.vis_file())
                .with_context(|| format!("cannot write {}", path.display()))?;
            path
        }
    };
    let report = Report {
        input: args.input.display().to_string(),
        output: output.display().to_string(),
        prt_format: match prt.format {
            prt::PrtFormat::Prt1 => "PRT1",
            prt::PrtFormat::Prt2 => "PRT2",
            prt::PrtFormat::Prt1Am => "PRT1-AM",
        }
        .to_string(),
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

fn read_prt(path: &Path, beside_bsp: bool) -> anyhow::Result<PortalFile> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if beside_bsp && e.kind() == std::io::ErrorKind::NotFound => bail!(
            "{} not found: vis needs the portal file your BSP compiler writes beside the .bsp (none is written when the map leaks)",
            path.display()
        ),
        Err(e) => return Err(e).with_context(|| format!("cannot read {}", path.display())),
    };
    Ok(prt::read(&text, &path.display().to_string())?)
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

/// Compressed PVS rows: one per cluster, identical rows stored once.
#[derive(Debug, Clone)]
pub struct Rows {
    /// Row bytes back to back.
    pub data: Vec<u8>,
    /// Offset of each vis leaf's row in `data`.
    pub leaf_offsets: Vec<u32>,
    /// Uncompressed row length.
    pub row_bytes: usize,
}

impl Rows {
    /// Compress the rows of `result` (leaves of a cluster share one row).
    pub fn new(result: &VisResult) -> Self {
        let mut data = Vec::new();
        let mut seen: HashMap<Vec<u8>, u32> = HashMap::new();
        let mut cluster_offset: Vec<Option<u32>> = vec![None; result.num_clusters()];
        let mut leaf_offsets = Vec::with_capacity(result.num_leaves());
        let mut row = Vec::new();
        let mut packed = Vec::new();
        for (leaf, &c) in result.leaf_clusters().iter().enumerate() {
            let slot = &mut cluster_offset[c as usize];
            let ofs = match *slot {
                Some(o) => o,
                None => {
                    result.leaf_row_bytes(leaf, &mut row);
                    packed.clear();
                    rle::encode_row(&row, &mut packed);
                    let o = *seen.entry(packed.clone()).or_insert_with(|| {
                        let o = data.len() as u32;
                        data.extend_from_slice(&packed);
                        o
                    });
                    *slot = Some(o);
                    o
                }
            };
            leaf_offsets.push(ofs);
        }
        Self { data, leaf_offsets, row_bytes: result.num_leaves().div_ceil(8) }
    }

    /// The `.vis` file (see the module docs).
    pub fn vis_file(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(20 + 4 * self.leaf_offsets.len() + self.data.len());
        out.extend_from_slice(b"SLVIS001");
        for v in [self.leaf_offsets.len(), self.row_bytes, self.data.len()] {
            out.extend_from_slice(&(v as u32).to_le_bytes());
        }
        for o in &self.leaf_offsets {
            out.extend_from_slice(&o.to_le_bytes());
        }
        out.extend_from_slice(&self.data);
        out
    }
}

/// Which ambient sound (water, sky, slime, lava) a texture makes, if any.
fn ambient_of(texture: &str) -> Option<usize> {
    let t = texture.to_ascii_lowercase();
    if t.starts_with("sky") {
        Some(1)
    } else if t.starts_with("*slime") {
        Some(2)
    } else if t.starts_with("*lava") {
        Some(3)
    } else if t.starts_with('*') {
        Some(0)
    } else {
        None
    }
}

/// Ambient levels of every BSP leaf: vis leaves from their PVS, other leaves unchanged.
pub fn ambient_levels(bsp: &Bsp, result: &VisResult) -> Vec<[u8; 4]> {
    // Sounds present in each vis leaf's own faces.
    let own: Vec<[bool; 4]> = (0..result.num_leaves())
        .map(|j| {
            let mut s = [false; 4];
            if let Some(leaf) = bsp.leaves.get(j + 1) {
                let first = leaf.first_marksurface as usize;
                let marks =
                    bsp.marksurfaces.get(first..first + leaf.num_marksurfaces as usize).unwrap_or_default();
                for &m in marks {
                    if let Some(k) =
                        bsp.faces.get(m as usize).and_then(|f| ambient_of(bsp.face_texture_name(f)))
                    {
                        s[k] = true;
                    }
                }
            }
            s
        })
        .collect();
    let mut out: Vec<[u8; 4]> = bsp.leaves.iter().map(|l| l.ambient).collect();
    let mut row = Vec::new();
    for j in 0..result.num_leaves() {
        result.leaf_row_bytes(j, &mut row);
        let mut s = [false; 4];
        for (k, sounds) in own.iter().enumerate() {
            if row[k >> 3] >> (k & 7) & 1 != 0 {
                for (a, b) in s.iter_mut().zip(sounds) {
                    *a |= *b;
                }
            }
        }
        if let Some(slot) = out.get_mut(j + 1) {
            *slot = s.map(|on| if on { 255 } else { 0 });
        }
    }
    out
}

/// The `.bsp` bytes with our visdata, `visofs` and ambient levels.
pub fn write_into_bsp(
    original: &[u8],
    bsp: &Bsp,
    result: &VisResult,
    rows: &Rows,
) -> anyhow::Result<Vec<u8>> {
    let mut visofs: Vec<i32> = bsp.leaves.iter().map(|l| l.visofs).collect();
    for (j, &o) in rows.leaf_offsets.iter().enumerate() {
        if let Some(slot) = visofs.get_mut(j + 1) {
            *slot = i32::try_from(o).context("visdata larger than 2 GiB")?;
        }
    }
    let ambient = ambient_levels(bsp, result);
    Ok(bsp::write_with_visdata(original, &rows.data, &visofs, Some(&ambient))?)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ambient_sounds_follow_texture_names() {
        assert_eq!(ambient_of("*water1"), Some(0));
        assert_eq!(ambient_of("*04water"), Some(0));
        assert_eq!(ambient_of("SKY4"), Some(1));
        assert_eq!(ambient_of("*slime0"), Some(2));
        assert_eq!(ambient_of("*lava1"), Some(3));
        assert_eq!(ambient_of("wall5"), None);
        assert_eq!(ambient_of(""), None);
    }
}
