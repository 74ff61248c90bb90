//! What loading a source (a `.map` in `load`, a mesh in `mesh`, which also hands over its
//! prebuilt world tree) hands the later phases.

use sightline_formats::PlaneSet;

use crate::brush::Brush;
use crate::csg;
use crate::outside::Seed;
use crate::report::Stats;

/// The tree's box lies this many units beyond every brush, so the void around the world is made
/// of empty leaves the outside flood starts from.
pub const OUTSIDE_MARGIN: f64 = 16.0;

/// Everything the phases after loading need, for a map or a mesh.
pub(crate) struct Prepared {
    pub planes: PlaneSet,
    pub structural: Vec<Brush>,
    pub world_faces: Vec<csg::CsgFace>,
    pub submodels: Vec<(Vec<Brush>, Vec<csg::CsgFace>)>,
    pub seeds: Vec<Seed>,
    pub entities: String,
    pub textures: Vec<String>,
    /// What faces are drawn with; [`csg::CsgFace::surface`] indexes it.
    pub surfaces: Vec<csg::Surface>,
    pub stats: Stats,
    /// The `func_viscluster` entities, in map order.
    pub visclusters: Vec<crate::viscluster::VisCluster>,
    /// Fill unreachable space (maps) or keep every non-solid leaf (meshes, no entities).
    pub fill: bool,
}
