//! What the drop-in vis reports: one record per game (serialised as the `--json` report of
//! `sightline vis`), and the folder pack's.

use crate::bsp_portals::BspPortalStats;
use crate::phs::PhsRepair;
use crate::vis::VisStats;

/// The report of one run, by game; serialised as the game's own record.
#[derive(Debug, Clone, serde::Serialize)]
#[serde(untagged)]
pub enum Report {
    /// Quake 1, Half-Life, or a portal file alone.
    Quake(QuakeReport),
    /// Quake 2.
    Quake2(Q2Report),
    /// Quake 3.
    Quake3(Q3Report),
}

/// What the drop-in vis of a Quake 1 or Half-Life `.bsp`, or of a portal file, reports.
#[derive(Debug, Clone, serde::Serialize)]
pub struct QuakeReport {
    /// Input file (a base name resolved to its `.bsp`).
    pub input: String,
    /// File written (the `.bsp` itself, or the `.vis`).
    pub output: String,
    /// Portal file format (`PRT1`, `PRT2`, `PRT1-AM`).
    pub prt_format: String,
    /// Under `--portals-from-bsp`: the counts of the portals rebuilt from the tree.
    pub portals_rebuilt: Option<BspPortalStats>,
    /// Vis statistics (leaves, clusters, visible counts, chains, phase times).
    pub vis: VisStats,
    /// Bytes of compressed PVS rows written.
    pub compressed_bytes: usize,
    /// The far plane applied, when one was.
    pub farplane: Option<f64>,
    /// Cluster pairs the far plane hid from each other.
    pub farplane_hidden_pairs: u64,
    /// Ambient sounds switched off (`water`, `sky`, `slime`, `lava`).
    pub ambient_off: Vec<&'static str>,
    /// The `NAME.texinfo.json` whose `noambient` flags were used.
    pub texinfo_json: Option<String>,
    /// Texinfos it flags `noambient`.
    pub noambient_texinfos: usize,
    /// Seconds reading inputs.
    pub read_seconds: f64,
    /// Seconds compressing and writing.
    pub write_seconds: f64,
    /// Total seconds.
    pub total_seconds: f64,
}

/// What the drop-in vis of a Quake 2 `.bsp` reports.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Q2Report {
    /// Input (and output) file.
    pub input: String,
    /// Always `"quake2"`.
    pub game: &'static str,
    /// `"vis"` (PVS from the `.prt`, then PHS) or `"phs-only"`.
    pub mode: &'static str,
    /// The portal file read (not under `--phs-only`).
    pub prt: Option<String>,
    /// Vis statistics (not under `--phs-only`).
    pub vis: Option<VisStats>,
    /// Clusters.
    pub clusters: usize,
    /// Ordered visible cluster pairs (self included) of the PVS.
    pub pvs_pairs: u64,
    /// Ordered cluster pairs of the PHS written.
    pub phs_pairs: u64,
    /// Under `--phs-only`: PHS rows that changed, and bits added and removed.
    pub phs_repair: Option<PhsRepair>,
    /// `--farplane` distance, when given.
    pub farplane: Option<f64>,
    /// Cluster pairs (unordered) the far plane hid.
    pub farplane_hidden_pairs: Option<u64>,
    /// Bytes of the visibility lump written.
    pub visibility_bytes: usize,
    /// Total seconds.
    pub total_seconds: f64,
}

/// What the drop-in vis of a Quake 3 `.bsp` reports.
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
