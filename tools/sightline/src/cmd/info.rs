//! `sightline info <file> [--json]`: counts and bounds of any file Sightline reads.
//!
//! The kind of file comes from [`FileKind::detect`]: its extension (`.map`, `.obj`, `.prt`, `.bsp`,
//! `.slvl`) and, when the extension is missing or unknown, its first bytes. [`report`] builds the
//! [`InfoReport`] that both the text and the JSON outputs print; its JSON keys are stable and
//! documented in README ("sightline info").

use std::path::Path;

use anyhow::{Context, bail};
use serde::Serialize;
use sightline_formats::bsp::{CompiledMap, Parsed};
use sightline_formats::geom::Aabb;
use sightline_formats::{FileKind, Level, bsp, map, obj, prt, slvl};

use crate::outcome::Outcome;

/// What `sightline info` does: its line in `sightline --help` and the first line of its own help.
pub const ABOUT: &str = "Print counts and bounds of any file Sightline reads";

/// Arguments of `sightline info`.
#[derive(Debug, clap::Args)]
#[command(about = ABOUT)]
pub struct Args {
    /// Input file: `.map`, `.obj`, `.prt`, `.bsp` or `.slvl`.
    pub input: std::path::PathBuf,
    /// Print the report as JSON (keys documented in README).
    #[arg(long)]
    pub json: bool,
}

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<Outcome> {
    let report = report(&args.input)?;
    crate::out::report(args.json, &report, || report.to_text())?;
    Ok(Outcome::Clean)
}

/// What `info` prints: the file as given and what was found in it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct InfoReport {
    /// The path as given.
    pub file: String,
    /// The kind-specific counts; serialized flat with a `"kind"` key.
    #[serde(flatten)]
    pub details: Details,
}

/// An axis-aligned box in world units.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Bounds {
    /// Smallest corner.
    pub mins: [f64; 3],
    /// Largest corner.
    pub maxs: [f64; 3],
}

impl Bounds {
    /// Rounded to 0.001 units, which hides the round-off of clipped windings.
    fn from_aabb(b: &Aabb) -> Option<Self> {
        let round = |v: [f64; 3]| v.map(|x| (x * 1000.0).round() / 1000.0);
        (!b.is_empty()).then(|| Self { mins: round(b.mins.to_array()), maxs: round(b.maxs.to_array()) })
    }

    fn from_f32(mins: [f32; 3], maxs: [f32; 3]) -> Self {
        Self { mins: mins.map(f64::from), maxs: maxs.map(f64::from) }
    }
}

/// Visible-leaf statistics decoded from PVS rows.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PvsSummary {
    /// Mean number of visible leaves per non-solid (vis) leaf.
    pub avg_visible_leaves: f64,
    /// Largest number of visible leaves of one leaf.
    pub max_visible_leaves: usize,
}

/// Per-kind counts.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Details {
    /// A Quake `.map`.
    Map {
        /// `"standard"` or `"valve220"`.
        format: &'static str,
        /// Entities including worldspawn.
        entities: usize,
        /// Entities with brushes other than worldspawn (func_door, func_detail, ...).
        brush_entities: usize,
        /// Brushes of all entities.
        brushes: usize,
        /// Brush sides of all entities.
        sides: usize,
        /// Box around every brush corner; `null` without brushes.
        bounds: Option<Bounds>,
    },
    /// A Wavefront `.obj` with at least one triangle (one without is an error).
    Obj {
        /// Vertices after indexing (one per distinct `v/vt/vn` triple).
        vertices: usize,
        /// Triangles after triangulation.
        triangles: usize,
        /// Faces of one or two vertices, skipped (they have no area).
        skipped_faces: usize,
        /// Box around every vertex; `null` for an empty mesh.
        bounds: Option<Bounds>,
    },
    /// A `.prt` portal file.
    Prt {
        /// `"prt1"`, `"prt2"`, `"prt1_am"`, `"q3map2"`, `"vhlt"` or `"vhlt_fixed"`.
        format: &'static str,
        /// Vis leaves.
        leaves: u32,
        /// Clusters (equal to `leaves` for PRT1).
        clusters: u32,
        /// Portals (each one line, i.e. two one-way portals for vis).
        portals: usize,
        /// Box around every portal winding; `null` without portals.
        bounds: Option<Bounds>,
    },
    /// A Quake-family BSP.
    Bsp {
        /// `"quake"`, `"half-life"` or `"quake2"`.
        game: &'static str,
        /// `"BSP29"`, `"BSP2"`, `"BSP2-RMQ"`, `"BSP30"` or `"IBSP38"`.
        version: &'static str,
        /// Leaves including the shared solid leaf 0.
        leaves: usize,
        /// Leaves with PVS rows (world model's `visleafs`); Quake 2: leaves with a cluster.
        visleafs: usize,
        /// Quake 2 only: clusters (PVS row length in bits).
        clusters: Option<usize>,
        /// Brush models including the world.
        models: usize,
        /// Size of the visibility lump.
        visdata_bytes: usize,
        /// Whether the file carries vis data.
        has_vis: bool,
        /// Decoded from the rows (a leaf without a row sees every vis leaf); `null` without vis leaves.
        pvs: Option<PvsSummary>,
        /// Ordered visible pairs, self included, of vis leaves (Quake 2: of clusters); `null`
        /// without vis leaves (Quake 2: without vis).
        pvs_pairs: Option<u64>,
        /// Quake 2 only, when vised: ordered cluster pairs of the PHS.
        phs_pairs: Option<u64>,
        /// World model bounds; `null` without models.
        bounds: Option<Bounds>,
    },
    /// A Quake 3 BSP (`IBSP` 46, or 47 for Quake Live).
    Q3Bsp {
        /// 46 or 47.
        version: i32,
        /// Leaves, opaque ones (cluster -1) included.
        leaves: usize,
        /// Leaves in no cluster (opaque).
        opaque_leaves: usize,
        /// Clusters: the visibility lump's count, else the clusters the leaves name.
        clusters: usize,
        /// Models including the world.
        models: usize,
        /// Size of the visibility lump.
        visdata_bytes: usize,
        /// Whether the file carries vis data.
        has_vis: bool,
        /// Ordered visible cluster pairs, self included; `null` without vis.
        pvs_pairs: Option<u64>,
        /// Counted in clusters; `null` without vis or clusters.
        pvs: Option<PvsSummary>,
        /// World model bounds; `null` without models.
        bounds: Option<Bounds>,
    },
    /// A Sightline level.
    Slvl {
        /// Leaves including solid ones.
        leaves: usize,
        /// Leaves that belong to a cluster (the world's non-solid leaves).
        vis_leaves: usize,
        /// Clusters (PVS row length in bits).
        clusters: u32,
        /// Portals between non-solid leaves.
        portals: usize,
        /// Interior nodes.
        nodes: usize,
        /// Faces.
        faces: usize,
        /// Brush models including the world.
        models: usize,
        /// Bytes of compressed PVS rows.
        visdata_bytes: usize,
        /// Whether the level carries a PVS.
        has_vis: bool,
        /// Decoded from the cluster rows, counted in leaves; `null` without vis leaves.
        pvs: Option<PvsSummary>,
        /// World model bounds; `null` without models.
        bounds: Option<Bounds>,
        /// Whether the `.prt` beside the level is the one written with it.
        portal_file: PortalFileStatus,
    },
}

/// How the `.prt` beside a level relates to it ([`sightline_formats::level::Level::portal_file`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PortalFileStatus {
    /// The level records no portal file (a leaking map, or a level from before the record).
    NotRecorded,
    /// The level records one, and no `.prt` is beside it.
    Missing,
    /// The `.prt` beside it is the one written with it.
    Matches,
    /// The `.prt` beside it is another one (a later or interrupted compile, or another tool's).
    Differs,
}

impl PortalFileStatus {
    /// The status of the `.prt` beside the level at `path` that records `recorded` (read as every
    /// input is: something there that is no regular file is not the one written with it).
    fn of(path: &Path, recorded: Option<u64>) -> Self {
        let Some(recorded) = recorded else { return Self::NotRecorded };
        match sightline_job::input::read_input(&path.with_extension("prt")) {
            Err(e) if e.is_not_found() => Self::Missing,
            Err(_) => Self::Differs,
            Ok(bytes) if prt::fingerprint(&bytes) == recorded => Self::Matches,
            Ok(_) => Self::Differs,
        }
    }

    fn describe(self) -> &'static str {
        match self {
            Self::NotRecorded => "none recorded",
            Self::Missing => "recorded, but no .prt beside the level",
            Self::Matches => "the .prt beside the level belongs to it",
            Self::Differs => "the .prt beside the level is NOT the one written with it (compile again)",
        }
    }
}

/// Read `path` and build its report.
pub fn report(path: &Path) -> anyhow::Result<InfoReport> {
    let name = path.display().to_string();
    let bytes = sightline_job::input::read_input(path)?;
    let kind = FileKind::detect(path, &bytes)
        .with_context(|| format!("{name}: unknown file kind (expected .map, .obj, .prt, .bsp or .slvl)"))?;
    let details = match kind {
        // A `.map` may hold bytes that are not UTF-8 (Quake's high-bit characters in strings).
        FileKind::Map => map_details(&map::decode(&bytes), &name)?,
        FileKind::Obj => {
            let mesh = obj::load_from_bytes(&bytes, &name)?;
            if mesh.triangles.is_empty() {
                bail!(
                    "{name}: no usable triangle ({} faces skipped: fewer than three vertices)",
                    mesh.skipped_faces
                );
            }
            Details::Obj {
                vertices: mesh.positions.len(),
                triangles: mesh.triangles.len(),
                skipped_faces: mesh.skipped_faces,
                bounds: Bounds::from_aabb(&mesh.bounds()),
            }
        }
        FileKind::Prt => prt_details(&prt::read_bytes(&bytes, &name)?),
        FileKind::Bsp => {
            let map = CompiledMap::read(bytes).with_context(|| format!("{name}: invalid BSP"))?;
            // The world model's bounds are printed as the level has them: repaired when the file
            // stores them unusable, which is said.
            let (level, repairs) = map.to_level_with_repairs();
            for r in &repairs {
                eprintln!("warning: {name}: {r}");
            }
            let bounds = level.models.first().map(|m| Bounds::from_f32(m.mins, m.maxs));
            match map.parsed() {
                Parsed::Quake(b) => bsp_details(b, bounds).with_context(|| format!("{name}: bad PVS row"))?,
                Parsed::Quake2(f) => {
                    q2_details(f, &level, bounds).with_context(|| format!("{name}: bad PVS row"))?
                }
                Parsed::Quake3(f) => q3_details(f, bounds),
            }
        }
        FileKind::Slvl => slvl_details(&bytes, path).with_context(|| format!("{name}: invalid level"))?,
    };
    Ok(InfoReport { file: name, details })
}

fn map_details(text: &str, name: &str) -> anyhow::Result<Details> {
    let map = map::parse(text, name)?;
    Ok(Details::Map {
        format: match map.format {
            map::MapFormat::Standard => "standard",
            map::MapFormat::Valve220 => "valve220",
        },
        entities: map.entities.len(),
        brush_entities: map.entities.iter().skip(1).filter(|e| !e.brushes.is_empty()).count(),
        brushes: map.brushes().count(),
        sides: map.brushes().map(|b| b.sides.len()).sum(),
        bounds: Bounds::from_aabb(&map.bounds()),
    })
}

fn prt_details(p: &prt::PortalFile) -> Details {
    let bounds = p.portals.iter().fold(Aabb::EMPTY, |b, portal| b.union(&portal.winding.bounds()));
    Details::Prt {
        format: match p.format {
            prt::PrtFormat::Prt1 => "prt1",
            prt::PrtFormat::Prt2 => "prt2",
            prt::PrtFormat::Prt1Am => "prt1_am",
            prt::PrtFormat::Q3map2 => "q3map2",
            prt::PrtFormat::Vhlt => "vhlt",
            prt::PrtFormat::VhltFixed => "vhlt_fixed",
        },
        leaves: p.num_leaves,
        clusters: p.num_clusters,
        portals: p.portals.len(),
        bounds: Bounds::from_aabb(&bounds),
    }
}

fn bsp_details(b: &bsp::Bsp, bounds: Option<Bounds>) -> anyhow::Result<Details> {
    let stats = b.pvs_stats()?;
    Ok(Details::Bsp {
        game: if b.version == bsp::BspVersion::Bsp30 { "half-life" } else { "quake" },
        version: b.version.name(),
        leaves: b.leaves.len(),
        visleafs: b.visleafs(),
        clusters: None,
        models: b.models.len(),
        visdata_bytes: b.visdata.len(),
        has_vis: !b.visdata.is_empty(),
        pvs: stats
            .map(|s| PvsSummary { avg_visible_leaves: s.avg_visible, max_visible_leaves: s.max_visible }),
        pvs_pairs: stats.map(|s| s.pairs),
        phs_pairs: None,
        bounds,
    })
}

fn q3_details(b: &bsp::q3::Q3Bsp, bounds: Option<Bounds>) -> Details {
    let vis = b.vis.as_ref();
    let counts: Vec<usize> =
        vis.map(|v| (0..v.num_clusters).map(|c| v.visible_from(c)).collect()).unwrap_or_default();
    Details::Q3Bsp {
        version: b.version,
        leaves: b.leaves.len(),
        opaque_leaves: b.leaves.iter().filter(|l| l.cluster < 0).count(),
        clusters: vis.map_or(b.leaf_cluster_count(), |v| v.num_clusters),
        models: b.models.len(),
        visdata_bytes: b.lumps[bsp::q3::lump::VISIBILITY].length,
        has_vis: vis.is_some(),
        pvs_pairs: vis.map(|v| v.pairs()),
        pvs: (!counts.is_empty()).then(|| PvsSummary {
            avg_visible_leaves: counts.iter().sum::<usize>() as f64 / counts.len() as f64,
            max_visible_leaves: counts.iter().copied().max().unwrap_or(0),
        }),
        bounds,
    }
}

/// A Quake 2 BSP: the whole file as a level ([`bsp::q2::to_level`]) for leaf counts and the PVS
/// summary, the visibility lump for the cluster pairs of the PVS and the PHS.
fn q2_details(file: &bsp::q2::Q2Bsp, level: &Level, bounds: Option<Bounds>) -> anyhow::Result<Details> {
    use bsp::q2::{self, Q2Row};
    let vis = file.vis.as_ref();
    Ok(Details::Bsp {
        game: "quake2",
        version: "IBSP38",
        leaves: level.leaves.len(),
        visleafs: level.vis_leaves(),
        clusters: Some(level.num_clusters as usize),
        models: level.models.len(),
        visdata_bytes: file.lumps[q2::lump::VISIBILITY].length,
        has_vis: vis.is_some(),
        pvs: level
            .pvs_stats()?
            .map(|s| PvsSummary { avg_visible_leaves: s.avg_visible, max_visible_leaves: s.max_visible }),
        pvs_pairs: vis.map(|v| v.pairs(Q2Row::Pvs)).transpose()?,
        phs_pairs: vis.map(|v| v.pairs(Q2Row::Phs)).transpose()?,
        bounds,
    })
}

fn slvl_details(bytes: &[u8], path: &Path) -> anyhow::Result<Details> {
    let level = slvl::read(bytes)?;
    let vis_leaves = level.vis_leaves();
    Ok(Details::Slvl {
        leaves: level.leaves.len(),
        vis_leaves,
        clusters: level.num_clusters,
        portals: level.portals.len(),
        nodes: level.nodes.len(),
        faces: level.faces.len(),
        models: level.models.len(),
        visdata_bytes: level.pvs_data.len(),
        has_vis: level.has_vis(),
        pvs: level
            .pvs_stats()?
            .map(|s| PvsSummary { avg_visible_leaves: s.avg_visible, max_visible_leaves: s.max_visible }),
        bounds: level.models.first().map(|m| Bounds::from_f32(m.mins, m.maxs)),
        portal_file: PortalFileStatus::of(path, level.portal_file),
    })
}

impl InfoReport {
    /// The human-readable form: one `key: value` line per count.
    pub fn to_text(&self) -> String {
        let mut out = format!("file: {}\n", self.file);
        let mut line = |k: &str, v: String| out.push_str(&format!("{k}: {v}\n"));
        let bounds = |b: &Option<Bounds>| {
            b.map_or("none".to_string(), |b| {
                format!(
                    "({} {} {}) to ({} {} {})",
                    b.mins[0], b.mins[1], b.mins[2], b.maxs[0], b.maxs[1], b.maxs[2]
                )
            })
        };
        let pvs = |p: &Option<PvsSummary>| {
            p.map_or("none".to_string(), |p| {
                format!("average {:.1} visible leaves, max {}", p.avg_visible_leaves, p.max_visible_leaves)
            })
        };
        match &self.details {
            Details::Map { format, entities, brush_entities, brushes, sides, bounds: b } => {
                line("kind", format!("map ({format})"));
                line("entities", format!("{entities} ({brush_entities} brush entities)"));
                line("brushes", brushes.to_string());
                line("sides", sides.to_string());
                line("bounds", bounds(b));
            }
            Details::Obj { vertices, triangles, skipped_faces, bounds: b } => {
                line("kind", "obj".into());
                line("vertices", vertices.to_string());
                line("triangles", triangles.to_string());
                if *skipped_faces > 0 {
                    line("skipped faces", format!("{skipped_faces} (fewer than three vertices: no area)"));
                }
                line("bounds", bounds(b));
            }
            Details::Prt { format, leaves, clusters, portals, bounds: b } => {
                line("kind", format!("prt ({format})"));
                line("leaves", leaves.to_string());
                line("clusters", clusters.to_string());
                line("portals", portals.to_string());
                line("bounds", bounds(b));
            }
            Details::Bsp {
                game,
                version,
                leaves,
                visleafs,
                clusters,
                models,
                visdata_bytes,
                has_vis,
                pvs: p,
                pvs_pairs,
                phs_pairs,
                bounds: b,
            } => {
                line("kind", format!("bsp ({version}, {game})"));
                let clusters = clusters.map_or(String::new(), |c| format!(", {c} clusters"));
                line("leaves", format!("{leaves} ({visleafs} vis leaves{clusters})"));
                line("models", models.to_string());
                line("visdata", format!("{visdata_bytes} bytes{}", if *has_vis { "" } else { " (no vis)" }));
                line("pvs", pvs(p));
                if let Some(n) = pvs_pairs {
                    line("pvs pairs", n.to_string());
                }
                if let Some(n) = phs_pairs {
                    line("phs pairs", n.to_string());
                }
                line("bounds", bounds(b));
            }
            Details::Q3Bsp {
                version,
                leaves,
                opaque_leaves,
                clusters,
                models,
                visdata_bytes,
                has_vis,
                pvs_pairs,
                pvs: p,
                bounds: b,
            } => {
                line("kind", format!("bsp (Quake 3, IBSP {version})"));
                line("leaves", format!("{leaves} ({opaque_leaves} opaque, {clusters} clusters)"));
                line("models", models.to_string());
                line("visdata", format!("{visdata_bytes} bytes{}", if *has_vis { "" } else { " (no vis)" }));
                let pairs = pvs_pairs.map_or(String::new(), |n| format!(", {n} cluster pairs"));
                line(
                    "pvs",
                    p.map_or("none".to_string(), |p| {
                        format!(
                            "average {:.1} visible clusters, max {}{pairs}",
                            p.avg_visible_leaves, p.max_visible_leaves
                        )
                    }),
                );
                line("bounds", bounds(b));
            }
            Details::Slvl {
                leaves,
                vis_leaves,
                clusters,
                portals,
                nodes,
                faces,
                models,
                visdata_bytes,
                has_vis,
                pvs: p,
                bounds: b,
                portal_file,
            } => {
                line("kind", "slvl".into());
                line("leaves", format!("{leaves} ({vis_leaves} vis leaves, {clusters} clusters)"));
                line("portals", portals.to_string());
                line("nodes", nodes.to_string());
                line("faces", faces.to_string());
                line("models", models.to_string());
                line("visdata", format!("{visdata_bytes} bytes{}", if *has_vis { "" } else { " (no vis)" }));
                line("pvs", pvs(p));
                line("bounds", bounds(b));
                line("portal file", portal_file.describe().into());
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_report_lists_counts() {
        let report = InfoReport {
            file: "x.obj".into(),
            details: Details::Obj {
                vertices: 3,
                triangles: 1,
                skipped_faces: 0,
                bounds: Some(Bounds { mins: [0.0; 3], maxs: [1.0, 2.0, 3.0] }),
            },
        };
        assert_eq!(
            report.to_text(),
            "file: x.obj\nkind: obj\nvertices: 3\ntriangles: 1\nbounds: (0 0 0) to (1 2 3)\n"
        );
        let json = serde_json::to_value(&report).expect("serializes");
        assert_eq!(json["kind"], "obj");
        assert_eq!(json["bounds"]["maxs"][2], 3.0);
    }
}
