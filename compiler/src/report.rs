//! What a compile reports: the [`Compiled`] level with its [`Stats`], and any [`LeakReport`].

use glam::DVec3;
use sightline_formats::Level;
use sightline_formats::prt::PortalFile;

use crate::vis;

/// Spacing of pointfile points along a leak path, in units.
pub const POINTFILE_STEP: f64 = 8.0;

/// Time spent in one phase.
#[derive(Debug, Clone, serde::Serialize)]
pub struct PhaseTime {
    /// Phase name.
    pub name: String,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// Counts and times of a compile.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct Stats {
    /// Brushes compiled: every entity's, but those of TrenchBroom layers omitted from export.
    pub brushes: usize,
    /// Structural world brushes that built the tree.
    pub world_brushes: usize,
    /// `func_detail*` brushes: split the tree after the structural ones (clusters); illusionary
    /// ones are drawn only.
    pub detail_brushes: usize,
    /// Brush entities with their own model.
    pub submodels: usize,
    /// Faces after CSG (all models).
    pub csg_faces: usize,
    /// Faces in the level.
    pub faces: usize,
    /// Planes (pairs counted twice).
    pub planes: usize,
    /// Interior nodes in the level.
    pub nodes: usize,
    /// Leaves in the level.
    pub leaves: usize,
    /// Non-solid world leaves (vis leaves).
    pub vis_leaves: usize,
    /// World portals between vis leaves.
    pub portals: usize,
    /// Clusters.
    pub clusters: usize,
    /// Leaves the outside fill turned solid.
    pub filled_leaves: usize,
    /// Triangle-against-portal tests of the check that a mesh's solid cells are enclosed (0 for
    /// a map): the work of that check, which grows near-linearly with the triangles.
    pub cover_tests: u64,
    /// Per `func_viscluster` entity, in map order: its line and the vis leaves it merged.
    pub visclusters: Vec<crate::viscluster::VisClusterStat>,
    /// Phase times in order.
    pub phases: Vec<PhaseTime>,
    /// Things worth knowing that did not stop the compile.
    pub warnings: Vec<String>,
}

/// A leak: an entity reaches the void.
#[derive(Debug, Clone, PartialEq)]
pub struct LeakReport {
    /// Source file.
    pub file: String,
    /// Class of the leaking entity.
    pub classname: String,
    /// Its origin.
    pub origin: DVec3,
    /// Line of the entity in the source.
    pub line: u32,
    /// Points every [`POINTFILE_STEP`] units from the entity to outside the world.
    pub path: Vec<DVec3>,
}

impl LeakReport {
    /// What a leak is and how to find it, in one sentence.
    pub const EXPLANATION: &'static str = "A leak is a hole in the world's outer shell through which \
        an entity can reach the void, so the inside and outside cannot be told apart; load the \
        pointfile in your editor and follow the line from the entity to the gap to seal.";

    /// The Quake pointfile text: one `x y z` line per point.
    pub fn pointfile(&self) -> String {
        let mut s = String::with_capacity(self.path.len() * 24);
        for p in &self.path {
            s.push_str(&format!("{} {} {}\n", p.x, p.y, p.z));
        }
        s
    }
}

impl std::fmt::Display for LeakReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}:{}: leak: entity `{}` at ({} {} {}) reaches the outside of the world through {} path points",
            self.file,
            self.line,
            self.classname,
            self.origin.x,
            self.origin.y,
            self.origin.z,
            self.path.len()
        )
    }
}

/// The result of a compile.
#[derive(Debug, Clone)]
pub struct Compiled {
    /// The level (no PVS yet: vis fills `pvs_offsets`/`pvs_data`).
    pub level: Level,
    /// The world's portals for vis (PRT1, vis leaves = clusters).
    pub prt: PortalFile,
    /// Counts and times.
    pub stats: Stats,
    /// The leak, when `allow_leak` let a leaking map through.
    pub leak: Option<LeakReport>,
    /// Vis statistics when vis ran.
    pub vis: Option<vis::VisStats>,
}
