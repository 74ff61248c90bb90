//! Triangle meshes (an `.obj`, a generated scene) traced against the GVS set of the eye's view
//! cell: the cells are a grid of cubes over the mesh's bounds ([`sightline_gvs::cells::Grid`], as
//! `sightline gvs --cell SIZE` makes them), the eye's cell is the cube containing the eye, and its
//! set is computed by [`sightline_gvs`] when the camera first enters the cell (a fresh run, or the
//! incremental update of [`sightline_gvs::update`] from the cell the camera came from) and cached.
//!
//! GVS is sampled, so a cell set may miss a triangle the eye sees (it is aggressive): the gate
//! ([`compare_mesh`]) counts and lists those pixels; on a mesh they are GVS's sampling error, not a
//! bug of the tracer.
//!
//! # Conventions
//! - A mesh's faces are its triangles (face `t` is triangle `t`), seen from both sides (an `.obj`
//!   need not be wound consistently), as GVS sees them.
//! - A set's triangles keep the scene's numbering, ascending; its BVH is built over them in that
//!   order.

use std::collections::HashMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

use glam::{DVec3, Vec3};
use sightline_gvs::cells::Grid;
use sightline_gvs::{Cell, Components, Neighbours, Params, Pvs, SceneIndex, TargetGroups, Variant};
use sightline_job::rng::SplitMix64;
use sightline_raycast::Bvh;

use super::frame::{Frame, Rays, cast};
use super::gate::{GateReport, MeshMismatch, compare_mesh};
use super::{Camera, Surfaces, TraceError};

/// A mesh ready to trace: its triangles with the whole-scene BVH and what GVS needs (the
/// [`SceneIndex`]), the grid of view cells and the GVS parameters.
#[derive(Debug)]
pub struct MeshScene<'a> {
    index: SceneIndex<'a>,
    grid: Grid,
    params: Params,
    bvh_build: Duration,
    index_build: Duration,
}

impl<'a> MeshScene<'a> {
    /// Build the BVH of `triangles` (timed apart), the rest of their GVS index, and the grid of
    /// cubes of side `cell` over `bounds`; cell sets are sampled with the default variant of
    /// `sightline gvs` ([`Variant::ProbeFirstTarget`] on `base`).
    pub fn new(
        triangles: &'a [[Vec3; 3]],
        bounds: &Cell,
        cell: f32,
        base: Params,
    ) -> Result<Self, TraceError> {
        let grid = Grid::new(bounds, cell)?;
        let params = Variant::ProbeFirstTarget.params(base);
        params.check()?;
        if triangles.is_empty() {
            return Err(crate::ValidateError::Mesh { source: crate::mesh::MeshError::NoFaces }.into());
        }
        let start = Instant::now();
        let bvh = Bvh::build(triangles);
        let bvh_build = start.elapsed();
        let start = Instant::now();
        let neighbours = Neighbours::build(triangles, &bvh);
        let components = Components::build(triangles);
        let targets = TargetGroups::build(&bvh, &components);
        let index = SceneIndex { tris: triangles, bvh, neighbours, components, targets };
        Ok(MeshScene { index, grid, params, bvh_build, index_build: start.elapsed() })
    }

    /// The whole-scene BVH.
    pub fn bvh(&self) -> &Bvh {
        &self.index.bvh
    }

    /// How long the whole-scene BVH took to build.
    pub fn build_time(&self) -> Duration {
        self.bvh_build
    }

    /// How long the rest of the GVS index (neighbour table, components, target groups) took.
    pub fn index_time(&self) -> Duration {
        self.index_build
    }

    /// The grid of view cells.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// The cell containing `eye` (`None` outside the grid).
    pub fn cell_of(&self, eye: DVec3) -> Option<usize> {
        self.grid.cell_of(eye.as_vec3())
    }

    /// True when `p` is open: in the grid, and not inside a closed object (the nearest triangle
    /// met along each axis, both ways, is not seen from behind).
    pub fn is_open(&self, p: DVec3) -> bool {
        if self.cell_of(p).is_none() {
            return false;
        }
        let o = p.as_vec3();
        [Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z].into_iter().all(|d| {
            self.index
                .bvh
                .intersect(o, d, f32::INFINITY)
                .is_none_or(|h| self.normal(h.triangle).dot(d.as_dvec3()) <= 0.0)
        })
    }

    /// `n` random open eyes with a yaw (degrees) and a pitch (in -10..20 degrees) from `seed`: each
    /// eye is drawn in a box of `open` picked at random (the grid's bounds when `open` is empty)
    /// and kept when [`MeshScene::is_open`]; at most `100 n` draws.
    pub fn random_eyes(&self, open: &[Cell], n: usize, seed: u64) -> Vec<(DVec3, f64, f64)> {
        let mut rng = SplitMix64::new(seed);
        let whole = [self.grid_bounds()];
        let boxes = if open.is_empty() { &whole[..] } else { open };
        let mut out = Vec::with_capacity(n);
        for _ in 0..n.saturating_mul(100) {
            if out.len() == n {
                break;
            }
            let b = boxes[rng.below(boxes.len())];
            let f = DVec3::new(rng.range_f64(0.0, 1.0), rng.range_f64(0.0, 1.0), rng.range_f64(0.0, 1.0));
            let eye = b.min.as_dvec3() + (b.max - b.min).as_dvec3() * f;
            let (yaw, pitch) = (rng.range_f64(0.0, 360.0), rng.range_f64(-10.0, 20.0));
            if self.is_open(eye) {
                out.push((eye, yaw, pitch));
            }
        }
        out
    }

    /// The box the grid covers.
    fn grid_bounds(&self) -> Cell {
        let n = Vec3::new(self.grid.n[0] as f32, self.grid.n[1] as f32, self.grid.n[2] as f32);
        Cell::new(self.grid.min, self.grid.min + n * self.grid.size)
    }
}

impl Surfaces for MeshScene<'_> {
    fn triangles(&self) -> &[[Vec3; 3]] {
        self.index.tris
    }

    fn face_of(&self, t: u32) -> Option<u32> {
        ((t as usize) < self.index.tris.len()).then_some(t)
    }

    fn one_sided(&self) -> bool {
        false
    }
}

/// How a cell set was made.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SetSource {
    /// A fresh GVS run on the cell.
    Fresh,
    /// The incremental update of the set of the cell the camera came from.
    Updated,
    /// Given by the caller ([`MeshCellSet::from_pvs`]).
    Given,
}

impl SetSource {
    /// Short name (`gvs`, `update`, `given`).
    pub fn name(self) -> &'static str {
        match self {
            SetSource::Fresh => "gvs",
            SetSource::Updated => "update",
            SetSource::Given => "given",
        }
    }
}

/// The GVS set of one view cell as a BVH.
#[derive(Debug)]
pub struct MeshCellSet {
    /// The cell's number in the grid.
    pub cell: usize,
    /// The GVS result (its entries keep the rays the incremental update re-casts).
    pub pvs: Pvs,
    /// Scene triangle of each of the set's triangles, ascending (the BVH's build order).
    pub triangles: Vec<u32>,
    /// The BVH over the set's triangles.
    pub bvh: Bvh,
    /// How the set was made.
    pub source: SetSource,
    /// Time GVS (or its update) took.
    pub gvs_time: Duration,
    /// Time to build the BVH.
    pub bvh_build: Duration,
}

impl MeshCellSet {
    /// The set of `pvs` (made by `source` in `gvs_time`) for cell `cell`: its triangles and their
    /// BVH (triangles the scene lacks are left out).
    pub fn from_pvs(
        scene: &MeshScene<'_>,
        cell: usize,
        pvs: Pvs,
        source: SetSource,
        gvs_time: Duration,
    ) -> Self {
        let tris = scene.triangles();
        let mut triangles: Vec<u32> =
            pvs.sorted().into_iter().filter(|&t| (t as usize) < tris.len()).collect();
        triangles.dedup();
        let start = Instant::now();
        let soup: Vec<_> = triangles.iter().map(|&t| tris[t as usize]).collect();
        let bvh = Bvh::build(&soup);
        MeshCellSet { cell, pvs, triangles, bvh, source, gvs_time, bvh_build: start.elapsed() }
    }

    /// Bytes the set's BVH and triangle map hold on the heap.
    pub fn heap_bytes(&self) -> usize {
        self.bvh.heap_bytes() + size_of_val(self.triangles.as_slice())
    }
}

/// Cell sets made so far, by cell; new ones by a fresh GVS run, or (when `incremental`) by the
/// incremental update of the set of the cell the camera came from.
#[derive(Debug, Default)]
pub struct MeshCells {
    sets: HashMap<usize, Arc<MeshCellSet>>,
    /// Make a new cell's set by updating the previous cell's (when there is one).
    pub incremental: bool,
}

impl MeshCells {
    /// An empty cache; `incremental`: see [`MeshCells::incremental`].
    pub fn new(incremental: bool) -> Self {
        MeshCells { sets: HashMap::new(), incremental }
    }

    /// The set of `cell` (`from`: the set of the cell the camera comes from), and whether it came
    /// from the cache. `None` when `cell` is not in the grid.
    pub fn get(
        &mut self,
        scene: &MeshScene<'_>,
        cell: usize,
        from: Option<&MeshCellSet>,
    ) -> Option<(Arc<MeshCellSet>, bool)> {
        if let Some(s) = self.sets.get(&cell) {
            return Some((s.clone(), true));
        }
        let box_ = scene.grid.cell(cell)?;
        let start = Instant::now();
        let (pvs, source) = match from.filter(|_| self.incremental) {
            Some(prev) => {
                let mut pvs = sightline_gvs::update::update(
                    &scene.index,
                    &prev.pvs,
                    box_.min - prev.pvs.cell.min,
                    scene.params,
                );
                pvs.cell = box_;
                (pvs, SetSource::Updated)
            }
            None => {
                // Seeded per cell as `sightline gvs` seeds its cells.
                let p = Params { seed: scene.params.seed.wrapping_add(cell as u64 * 7919), ..scene.params };
                (sightline_gvs::sampler::run(&scene.index, box_, p), SetSource::Fresh)
            }
        };
        let set = Arc::new(MeshCellSet::from_pvs(scene, cell, pvs, source, start.elapsed()));
        self.sets.insert(cell, set.clone());
        Some((set, false))
    }

    /// Put `set` in the cache (replacing the set of its cell).
    pub fn insert(&mut self, set: MeshCellSet) {
        self.sets.insert(set.cell, Arc::new(set));
    }

    /// Sets held.
    pub fn len(&self) -> usize {
        self.sets.len()
    }

    /// True when no set has been made.
    pub fn is_empty(&self) -> bool {
        self.sets.is_empty()
    }
}

/// One mesh camera traced in both modes and gated.
#[derive(Debug, Clone)]
pub struct MeshTraced {
    /// The rays (shared by both modes).
    pub rays: Rays,
    /// The eye's cell.
    pub cell: usize,
    /// The whole scene's frame.
    pub full: Frame,
    /// The eye cell's set.
    pub set: Arc<MeshCellSet>,
    /// True when the set came from the cache.
    pub cached: bool,
    /// The cell set's frame.
    pub reduced: Frame,
    /// The gate's verdict.
    pub gate: GateReport<MeshMismatch>,
}

/// Trace `camera` against the whole mesh and against its cell's GVS set (from `cache`, made there
/// on first use, from `from` when the cache updates incrementally), and gate the two.
pub fn trace_mesh_camera(
    scene: &MeshScene<'_>,
    cache: &mut MeshCells,
    camera: &Camera,
    from: Option<&MeshCellSet>,
) -> Result<MeshTraced, TraceError> {
    let rays = Rays::new(camera)?;
    let outside = || TraceError::EyeOutsideGrid { eye: camera.eye.to_array() };
    let cell = scene.cell_of(camera.eye).ok_or_else(outside)?;
    let (set, cached) = cache.get(scene, cell, from).ok_or_else(outside)?;
    let full = cast(scene, scene.bvh(), None, &rays);
    let reduced = cast(scene, &set.bvh, Some(&set.triangles), &rays);
    let gate = compare_mesh(&rays, &full, &reduced);
    Ok(MeshTraced { rays, cell, full, set, cached, reduced, gate })
}
