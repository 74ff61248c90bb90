//! Guided visibility sampling (GVS): per box view cell, the set of triangles visible from it, found
//! by guided ray sampling over a BVH ([`sightline_raycast::Bvh`]).
//!
//! - `geom`: cells ([`Cell`]) and their ray sampler, Halton numbers, the enlarged outline,
//!   `edgepoint`.
//! - [`sampler`]: the algorithm for one cell ([`sampler::run`]) with its [`Params`], one file per
//!   strategy under `sampler/`.
//! - [`update`]: the incremental update of a PVS when its cell moves.
//! - `neighbours`: the per-scene neighbour table of neighbour probing ([`Neighbours`]).
//! - `components`, `targets`, `sheets`, `twins`: the per-scene surface components
//!   ([`Components`]), target groups ([`TargetGroups`]), sheets and coplanar twins ([`Twins`]).
//! - [`error`]: the thesis' wrong-pixel metric from ID buffers.
//! - [`metric`]: that metric over many cells and variants at once, in batches of bounded memory.
//! - [`scene`]: triangle scenes from generators, `.obj` and levels, and [`scene::load`].
//! - [`scenegen`]: the generated benchmark scenes of `sightline gvs gen:<kind>:<size>`.
//! - [`cells`]: view cells on a grid, and even selections of cells.
//!
//! Long runs ([`run_variant`], [`metric::Metric::measure`]) report progress through [`Progress`].
//!
//! The PVS is aggressive (a subset of the exact visible set up to numerical effects): it can miss
//! triangles that only tiny ray bundles reach. Results are deterministic for any thread count:
//! each cell is sampled sequentially, cells run in parallel.

pub mod cells;
pub(crate) mod components;
pub mod error;
pub(crate) mod geom;
pub mod metric;
pub(crate) mod neighbours;
pub mod sampler;
pub mod scene;
pub mod scenegen;
pub(crate) mod sheets;
pub(crate) mod targets;
pub(crate) mod twins;
mod union_find;
pub mod update;

pub use sightline_job::cancel::{Cancel, Cancelled};
use sightline_job::progress;
pub use sightline_job::progress::{NoProgress, Progress};

use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;
use sightline_formats::{Face, GvsCell, Level, LevelPlane};
use sightline_raycast::Bvh;

pub use components::Components;
pub use geom::Cell;
pub use neighbours::Neighbours;
pub use sampler::{EdgeMode, ParamError, Params, Pvs, Stats};
pub use targets::TargetGroups;
pub use twins::Twins;

/// A triangle soup prepared for sampling, once per scene (like the BVH, outside the cells'
/// timing): its BVH, its neighbour table, its surface components and its target groups.
#[derive(Debug, Clone)]
pub struct SceneIndex<'a> {
    /// The triangles.
    pub tris: &'a [[Vec3; 3]],
    /// Their BVH.
    pub bvh: Bvh,
    /// Their neighbour table (for probing).
    pub neighbours: Neighbours,
    /// Their connected surface components (for target sampling).
    pub components: Components,
    /// Its groups of nearby triangles with their components (for target sampling; without them
    /// target sampling casts nothing).
    pub targets: TargetGroups,
}

impl<'a> SceneIndex<'a> {
    /// Build the BVH, the neighbour table, the components and the target groups of `tris`.
    pub fn build(tris: &'a [[Vec3; 3]]) -> SceneIndex<'a> {
        let bvh = Bvh::build(tris);
        let neighbours = Neighbours::build(tris, &bvh);
        let components = Components::build(tris);
        let targets = TargetGroups::build(&bvh, &components);
        SceneIndex { tris, bvh, neighbours, components, targets }
    }
}

/// The configurations compared by `sightline gvs --compare`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Variant {
    /// Stock GVS: bisection to depth 14.
    Stock,
    /// Bisection capped at depth 4 (the thesis' `d4`).
    Depth4,
    /// Bisection with the distance-scaled threshold (the thesis' `adt`).
    Adt,
    /// The edge-point walk (the thesis' `brzegowy`).
    EdgePoint,
    /// The edge-point walk with silhouette re-seeding (this project's extension).
    Silhouette,
    /// Stock GVS with the thesis' "first" random-ray strategy.
    First,
    /// The edge-point walk with neighbour probing (this project's extension).
    Probe,
    /// The edge-point walk with neighbour probing and the "first" strategy.
    ProbeFirst,
    /// `ProbeFirst` with target sampling (this project's extension).
    ProbeFirstTarget,
}

/// Initial random rays of the "first" variants when [`Params::first`] is 0. The thesis found
/// "first" better than "last" from 100 k random rays on. Measured with target sampling: 25 k
/// (with 1 target ray) saves 40 % of the rays on the city at the same error, but missed a whole
/// sphere (17 wrong pixels per view on average) in one of ten sphere cells; 100 k did not.
pub const FIRST_DEFAULT: u64 = 100_000;

impl Variant {
    /// All variants, stock first.
    pub const ALL: [Variant; 9] = [
        Variant::Stock,
        Variant::Depth4,
        Variant::Adt,
        Variant::EdgePoint,
        Variant::First,
        Variant::Silhouette,
        Variant::Probe,
        Variant::ProbeFirst,
        Variant::ProbeFirstTarget,
    ];

    /// Short name.
    pub fn name(self) -> &'static str {
        match self {
            Variant::Stock => "gvs",
            Variant::Depth4 => "d4",
            Variant::Adt => "adt",
            Variant::EdgePoint => "edgepoint",
            Variant::Silhouette => "edgepoint+sil",
            Variant::First => "first",
            Variant::Probe => "edgepoint+probe",
            Variant::ProbeFirst => "edgepoint+probe+first",
            Variant::ProbeFirstTarget => "edgepoint+probe+first+target",
        }
    }

    /// The parameters of this variant, starting from `base`. `base.first` and `base.targets`
    /// only set the amounts of the variants that use them (0 picks [`FIRST_DEFAULT`] and
    /// [`TARGETS_DEFAULT`]); the other variants run without them.
    pub fn params(self, base: Params) -> Params {
        let first = if base.first == 0 { FIRST_DEFAULT } else { base.first };
        let targets = if base.targets == 0 { TARGETS_DEFAULT } else { base.targets };
        let plain = Params { first: 0, targets: 0, ..base };
        let edgepoint = Params { edge: EdgeMode::EdgePoint, ..plain };
        match self {
            Variant::Stock => plain,
            Variant::Depth4 => Params { max_depth: 4, ..plain },
            Variant::Adt => Params { adt: Some(base.adt.unwrap_or(1e-4)), ..plain },
            Variant::EdgePoint => edgepoint,
            Variant::Silhouette => Params { silhouette: true, ..edgepoint },
            Variant::First => Params { first, ..plain },
            Variant::Probe => Params { probe: true, ..edgepoint },
            Variant::ProbeFirst => Params { probe: true, first, ..edgepoint },
            Variant::ProbeFirstTarget => Params { probe: true, first, targets, ..edgepoint },
        }
    }
}

/// Triangles aimed at per unreached group of the "target" variant when [`Params::targets`] is 0
/// (each by up to [`sampler::TARGET_RAYS`] rays). Measured on `gen:mixed:2000` (lone triangles
/// among spheres; 5 cells, 50 views) with 16 rays per target: 2 targets 3.2 wrong pixels per
/// view for 766 target rays per cell, 3 targets 3.0 for 985, 4 targets 3.1 for 1,158 (with 4
/// rays per target, the earlier rule: 7.1 for 354); the city and `spheres:1000` do not change.
/// Every group the cell does not reach costs up to 3 × 16 rays: at the thesis' sphere density
/// (`spheres:10116`, 2 cells) 338 k target rays per cell instead of 116 k (+2.8 % rays), and the
/// error counted per object 3.4 → 1.9 pixels per view.
pub const TARGETS_DEFAULT: u32 = 3;

/// Run `variant` (its parameters from `base`, see [`Variant::params`]) on every cell with
/// [`run_cells`]; `progress` gets a phase named after the variant with a step per cell.
pub fn run_variant(
    index: &SceneIndex,
    cells: &[Cell],
    variant: Variant,
    base: Params,
    progress: &dyn Progress,
    cancel: &Cancel,
) -> Result<Vec<Pvs>, Cancelled> {
    let _phase = progress::phase(progress, variant.name(), cells.len() as u64);
    run_cells(index, cells, variant.params(base), progress, cancel)
}

/// All rays of the cells' runs over `seconds` (`None` when the time is unknown or not positive).
pub fn rays_per_second(pvs: &[Pvs], seconds: Option<f64>) -> Option<f64> {
    let rays: u64 = pvs.iter().map(|p| p.stats.rays).sum();
    seconds.filter(|&c| c > 0.0).map(|c| rays as f64 / c)
}

/// Run GVS on every cell, in parallel over cells: `progress` advances a step per finished cell
/// (in the caller's phase); once `cancel` is cancelled the cells not started are skipped and the
/// run returns [`Cancelled`].
pub fn run_cells(
    index: &SceneIndex,
    cells: &[Cell],
    params: Params,
    progress: &dyn Progress,
    cancel: &Cancel,
) -> Result<Vec<Pvs>, Cancelled> {
    cells
        .par_iter()
        .enumerate()
        .map(|(i, &cell)| {
            cancel.check()?;
            let p = Params { seed: params.seed.wrapping_add(i as u64 * 7919), ..params };
            let pvs = sampler::run(index, cell, p);
            progress.advance(1);
            Ok(pvs)
        })
        .collect()
}

/// Store per-cell face sets in `level.gvs_cells` / `level.gvs_faces`. Triangle indices map to
/// faces through `face_of` (a level's fanned faces) or are face indices themselves.
pub fn store(level: &mut Level, pvs: &[Pvs], face_of: Option<&[u32]>) {
    level.gvs_cells.clear();
    level.gvs_faces.clear();
    for p in pvs {
        let mut faces: Vec<u32> = p
            .entries
            .iter()
            .filter_map(|e| match face_of {
                Some(map) => map.get(e.tri as usize).copied(),
                None => Some(e.tri),
            })
            .collect();
        faces.sort_unstable();
        faces.dedup();
        level.gvs_cells.push(GvsCell {
            mins: p.cell.min.to_array(),
            maxs: p.cell.max.to_array(),
            first_face: level.gvs_faces.len() as u32,
            num_faces: faces.len() as u32,
        });
        level.gvs_faces.extend(faces);
    }
}

/// A level holding just a triangle soup: one face (and plane) per triangle, texture `"gvs"`.
/// Degenerate triangles get a zero plane normal. Used to store GVS results for meshes.
pub fn soup_level(tris: &[[Vec3; 3]]) -> Level {
    let mut level = Level { textures: vec!["gvs".to_string()], ..Level::default() };
    for (i, t) in tris.iter().enumerate() {
        // Faces are clockwise seen from the front: the front is where (b - a) x (c - a) points away.
        let n = (t[2] - t[0]).cross(t[1] - t[0]).normalize_or_zero();
        level.planes.push(LevelPlane { normal: n.to_array(), dist: n.dot(t[0]) });
        level.faces.push(Face { plane: i as u32, first_vertex: 3 * i as u32, num_vertices: 3, texture: 0 });
        level.vertices.extend(t.map(|p| p.to_array()));
    }
    level
}
