//! Guided visibility sampling (GVS): per box view cell, the set of triangles visible from it, found
//! by guided ray sampling over a BVH ([`sightline_runtime::bvh`]).
//!
//! - [`geom`]: cells and their ray sampler, Halton numbers, the enlarged outline, `edgepoint`.
//! - [`sampler`]: the algorithm for one cell ([`sampler::run`]) with its [`Params`].
//! - [`update`]: the incremental update of a PVS when its cell moves.
//! - [`error`]: the thesis' wrong-pixel metric from ID buffers.
//! - [`scene`]: triangle scenes from generators, `.obj` and levels.
//!
//! The PVS is aggressive (a subset of the exact visible set up to numerical effects): it can miss
//! triangles that only tiny ray bundles reach. Results are deterministic for any thread count:
//! each cell is sampled sequentially, cells run in parallel.

pub mod error;
pub mod geom;
pub mod sampler;
pub mod scene;
pub mod update;

use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;
use sightline_formats::{Face, GvsCell, Level, LevelPlane};
use sightline_runtime::bvh::Bvh;

pub use geom::Cell;
pub use sampler::{EdgeMode, Params, Pvs, Stats};

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
}

impl Variant {
    /// All variants, stock first.
    pub const ALL: [Variant; 5] =
        [Variant::Stock, Variant::Depth4, Variant::Adt, Variant::EdgePoint, Variant::Silhouette];

    /// Short name.
    pub fn name(self) -> &'static str {
        match self {
            Variant::Stock => "gvs",
            Variant::Depth4 => "d4",
            Variant::Adt => "adt",
            Variant::EdgePoint => "edgepoint",
            Variant::Silhouette => "edgepoint+sil",
        }
    }

    /// The parameters of this variant, starting from `base`.
    pub fn params(self, base: Params) -> Params {
        match self {
            Variant::Stock => base,
            Variant::Depth4 => Params { max_depth: 4, ..base },
            Variant::Adt => Params { adt: Some(base.adt.unwrap_or(1e-4)), ..base },
            Variant::EdgePoint => Params { edge: EdgeMode::EdgePoint, ..base },
            Variant::Silhouette => Params { edge: EdgeMode::EdgePoint, silhouette: true, ..base },
        }
    }
}

/// Run GVS on every cell, in parallel over cells; `progress` is called once per finished cell.
pub fn run_cells(
    tris: &[[Vec3; 3]],
    bvh: &Bvh,
    cells: &[Cell],
    params: Params,
    progress: &(dyn Fn() + Sync),
) -> Vec<Pvs> {
    cells
        .par_iter()
        .enumerate()
        .map(|(i, &cell)| {
            let p = Params { seed: params.seed.wrapping_add(i as u64 * 7919), ..params };
            let pvs = sampler::run(tris, bvh, cell, p);
            progress();
            pvs
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
