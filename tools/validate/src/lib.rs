//! Checking a level's PVS without trusting the code that computed it: PVS validation by ray
//! sampling, and pictures of levels. This is a library: it reports
//! progress through [`Progress`] and fails with error values ([`ValidateError`],
//! [`load::LoadError`], [`render::RenderError`], [`render::image::PngError`]); the `sightline`
//! command line draws the bars and prints the errors.
//!
//! # Validation
//! Ray sampling finds a lower bound of the true visible set and compares it with the PVS.
//! From points inside every open leaf's convex cell, bundles of parallel rays (see `sample`) are
//! cast in uniform directions against one of two oracles:
//! - **tree**: rays walk the level's BSP tree and stop in the first solid leaf;
//! - **mesh**: rays stop at the first world face (triangles in a BVH; liquid faces, texture names
//!   starting with `*`, let sight through), and the open leaves on the free part of the ray are
//!   found by walking the tree *through* solid slivers (slabs thinner than half a unit); any
//!   other solid stops the ray as in the tree oracle, faces or not (a brush textured `skip` on
//!   every side is solid without faces). The oracles agree on what is solid, and a PVS that
//!   relies on a sliver of the tree that no face closes is still caught.
//!
//! Every cluster pair a bundle agrees on is visible; a visible pair missing from the PVS is a
//! **miss**, reported with a segment between points of the two leaves.
//!
//! # Pictures
//! [`render`] draws first-person views (pixels outside the eye's PVS in red), plans with PVS,
//! frustum, portals and leak paths, and PVS matrices, as PNG. (The generated test maps, `mapgen`
//! and `shapes`, live in the test-support crate `sightline-tests`.)
//!
//! # Independence
//! Nothing here calls the vis code it validates (this crate does not depend on the compiler): the
//! tree walks ([`bsp`]), the PVS decoding ([`pvs`]) and the sampling are written here, so that a
//! bug in vis or in the runtime cannot hide a bug in a PVS.

pub(crate) mod atomic;
pub mod bsp;
pub(crate) mod cell;
pub mod load;
pub(crate) mod mesh;
pub mod pvs;
pub mod render;
pub mod report;
pub mod rng;
pub(crate) mod sample;
pub mod trace;

pub use sightline_job::cancel::Cancel;
use sightline_job::progress;
pub use sightline_job::progress::{NoProgress, Progress};

use std::collections::BTreeMap;
use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;
use sightline_formats::Level;
use sightline_formats::rle::RleError;

use self::atomic::AtomicBitMatrix;
use self::bsp::BspTree;
use self::cell::Cell;
use self::mesh::{MeshError, MeshOracle};
use self::pvs::BitMatrix;
use self::report::{OracleReport, Report};
use self::sample::{LeafSampler, Miss, RayOracle, SampleParams, Scratch, TreeOracle};

/// Default bundle offset in world units: 5 lines per bundle, a plus sign 0.5 units wide.
pub const DEFAULT_OFFSET: f64 = 0.25;
/// Default ray budget per oracle (both oracles on E1M1 well under a minute on 2 cores).
pub const DEFAULT_RAYS: u64 = 16_000_000;

/// Why a level's tree or PVS cannot be validated (or drawn).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ValidateError {
    /// The run was cancelled ([`Options::cancel`]) before it finished: no report.
    #[error("stopped before the sampling finished")]
    Cancelled,
    /// The level has no models, so no world tree.
    #[error("the models lump is empty: the level has no world model (model 0) and so no tree")]
    NoWorldTree,
    /// A tree child names a leaf past the end of the leaves.
    #[error("tree refers to leaf {leaf} but the level has {leaves} leaves")]
    MissingLeaf {
        /// The leaf named.
        leaf: usize,
        /// Leaves in the level.
        leaves: usize,
    },
    /// A tree child names a node past the end of the nodes.
    #[error("tree refers to missing node {node}")]
    MissingNode {
        /// The node named.
        node: usize,
    },
    /// A node is the child of two nodes (or of itself).
    #[error("node {node} is reached twice: the tree is not a tree")]
    NodeReachedTwice {
        /// The node.
        node: usize,
    },
    /// A node's plane index is past the end of the planes.
    #[error("node {node} refers to missing plane {plane}")]
    MissingPlane {
        /// The node.
        node: usize,
        /// Its plane index.
        plane: u32,
    },
    /// The level's PVS has a row count other than its cluster count.
    #[error("level has {rows} PVS rows for {clusters} clusters")]
    PvsRowCount {
        /// PVS rows.
        rows: usize,
        /// Clusters.
        clusters: usize,
    },
    /// A PVS row starts past the end of the PVS data.
    #[error("cluster {cluster}: PVS offset {offset} is past the data")]
    PvsOffset {
        /// The cluster whose row it is.
        cluster: usize,
        /// Its byte offset.
        offset: u32,
    },
    /// A PVS row does not decode.
    #[error("cluster {cluster}: PVS row at byte {offset}")]
    PvsRow {
        /// The cluster whose row it is.
        cluster: usize,
        /// Its byte offset.
        offset: u32,
        /// What is wrong with it.
        #[source]
        source: RleError,
    },
    /// The PVS given to [`validate`] is not the level's size.
    #[error("PVS has {pvs} clusters, the level {level}")]
    ClusterCount {
        /// Clusters of the PVS matrix.
        pvs: usize,
        /// Clusters of the level.
        level: u32,
    },
    /// The mesh oracle could not be built.
    #[error("building the face mesh")]
    Mesh {
        /// Why.
        #[source]
        source: MeshError,
    },
}

impl Default for Options {
    fn default() -> Self {
        Self {
            rays: DEFAULT_RAYS,
            seed: 1,
            offset: DEFAULT_OFFSET,
            oracle: OracleChoice::Both,
            cancel: Cancel::new(),
        }
    }
}

/// Which oracles to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum OracleChoice {
    /// The BSP tree only.
    Tree,
    /// The face mesh only.
    Mesh,
    /// Both, and their disagreement.
    Both,
}

/// Validation settings.
#[derive(Debug, Clone)]
pub struct Options {
    /// Total ray budget per oracle (each bundle is 5 lines of 2 rays, or 1 line with offset 0).
    pub rays: u64,
    /// Seed of every random stream.
    pub seed: u64,
    /// Bundle offset in world units (0: single rays).
    pub offset: f64,
    /// Oracles to run.
    pub oracle: OracleChoice,
    /// Stops the run between leaves once cancelled, with [`ValidateError::Cancelled`].
    pub cancel: Cancel,
}

/// Everything a run found: the printable report and the sampled matrices (per oracle, one per
/// coverage step: 1/8, 1/4, 1/2 and all of the budget).
#[derive(Debug)]
pub struct Validation {
    /// The report.
    pub report: Report,
    /// Sampled cluster matrices per oracle, per coverage step.
    pub sampled: Vec<Vec<BitMatrix>>,
}

/// Fractions of the budget at which coverage is measured.
pub const COVERAGE_STEPS: [(u32, u32); 4] = [(1, 8), (1, 4), (1, 2), (1, 1)];

/// Validate `pvs` (a cluster matrix, normally [`pvs::level_pvs`]) against ray samples of `level`.
/// `progress` gets one phase per oracle (`"tree"`, `"mesh"`) with a step per sampled leaf and
/// coverage step, advanced from worker threads.
pub fn validate(
    level: &Level,
    pvs: &BitMatrix,
    opts: &Options,
    progress: &dyn Progress,
) -> Result<Validation, ValidateError> {
    let tree = BspTree::new(level)?;
    if pvs.len() != level.num_clusters as usize {
        return Err(ValidateError::ClusterCount { pvs: pvs.len(), level: level.num_clusters });
    }
    let samplers = leaf_samplers(&tree);
    let rays_per_bundle = u64::from(sample::rays_per_bundle(opts.offset));
    let bundles =
        (opts.rays / (rays_per_bundle * samplers.len().max(1) as u64)).clamp(1, u64::from(u32::MAX)) as u32;
    let length = world_length(level);
    let params = SampleParams { seed: opts.seed, offset: opts.offset };
    let open_leaves = level.leaves.iter().filter(|l| bsp::sight_passes(l.contents)).count();
    let mut report = Report::new(level, open_leaves, samplers.len(), bundles, opts, pvs);
    let mut sampled = Vec::new();
    if opts.oracle != OracleChoice::Mesh {
        let oracle = TreeOracle { tree: &tree, length };
        let (r, m) = run_oracle(
            "tree",
            &oracle,
            &tree,
            samplers.clone(),
            bundles,
            params,
            pvs,
            &opts.cancel,
            progress,
        )?;
        report.oracles.push(r);
        sampled.push(m);
    }
    if opts.oracle != OracleChoice::Tree {
        let oracle = MeshOracle::new(&tree, length).map_err(|source| ValidateError::Mesh { source })?;
        let (r, m) =
            run_oracle("mesh", &oracle, &tree, samplers, bundles, params, pvs, &opts.cancel, progress)?;
        report.oracles.push(r);
        sampled.push(m);
    }
    if let [a, b] = sampled.as_slice()
        && let (Some(a), Some(b)) = (a.last(), b.last())
    {
        report.disagreement = Some(report::Disagreement {
            pairs_only_tree: a.count_not_in(b),
            pairs_only_mesh: b.count_not_in(a),
        });
    }
    Ok(Validation { report, sampled })
}

/// A ray length beyond anything in the world.
fn world_length(level: &Level) -> f64 {
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for l in level.leaves.iter().filter(|l| l.contents.is_open()) {
        lo = lo.min(DVec3::from(l.mins.map(f64::from)));
        hi = hi.max(DVec3::from(l.maxs.map(f64::from)));
    }
    if lo.x > hi.x { 1.0 } else { 2.0 * (hi - lo).length() + 1.0 }
}

/// One sampler per open leaf of the world tree whose cell holds a point.
fn leaf_samplers(tree: &BspTree<'_>) -> Vec<LeafSampler> {
    let level = tree.level();
    let halves = tree.leaf_half_spaces();
    halves
        .into_iter()
        .enumerate()
        .filter(|&(i, _)| tree.is_open(i) && tree.cluster(i).is_some())
        .filter_map(|(i, path)| {
            let l = &level.leaves[i];
            let (mins, maxs) = (DVec3::from(l.mins.map(f64::from)), DVec3::from(l.maxs.map(f64::from)));
            let cell = Cell::new(path?, mins, maxs);
            let point = cell.interior_point(0.5 * (mins + maxs))?;
            (tree.leaf_at(point) == i).then_some(LeafSampler { leaf: i as u32, cell, point })
        })
        .collect()
}

/// Run one oracle over the coverage steps.
#[allow(clippy::too_many_arguments)]
fn run_oracle<O: RayOracle>(
    name: &str,
    oracle: &O,
    tree: &BspTree<'_>,
    mut samplers: Vec<LeafSampler>,
    bundles: u32,
    params: SampleParams,
    pvs: &BitMatrix,
    cancel: &Cancel,
    progress: &dyn Progress,
) -> Result<(OracleReport, Vec<BitMatrix>), ValidateError> {
    let sampled = AtomicBitMatrix::new(pvs.len());
    let phase = progress::phase(progress, name, samplers.len() as u64 * COVERAGE_STEPS.len() as u64);
    let start = Instant::now();
    let mut rays = 0u64;
    let mut misses: BTreeMap<(u32, u32), Miss> = BTreeMap::new();
    let mut steps = Vec::new();
    let mut matrices = Vec::new();
    let mut done = 0u32;
    for (num, den) in COVERAGE_STEPS {
        let upto = (u64::from(bundles) * u64::from(num) / u64::from(den)) as u32;
        let first = done;
        let results: Vec<_> = samplers
            .par_iter_mut()
            .map_init(Scratch::default, |scratch, sampler| {
                // Once cancelled, the leaves left are skipped and the run ends below.
                let r = (!cancel.is_cancelled()).then(|| {
                    sample::run_batch(oracle, tree, sampler, first, upto, params, pvs, &sampled, scratch)
                });
                phase.advance(1);
                r
            })
            .collect();
        if cancel.is_cancelled() {
            return Err(ValidateError::Cancelled);
        }
        for r in results.into_iter().flatten() {
            rays += r.rays;
            for (k, m) in r.misses {
                misses.entry(k).or_insert(m);
            }
        }
        done = upto;
        let m = sampled.snapshot();
        steps.push(report::Coverage { fraction: format!("{num}/{den}"), rays, pairs: m.count() });
        matrices.push(m);
    }
    drop(phase);
    let seconds = start.elapsed().as_secs_f64();
    let last = matrices.last().cloned().unwrap_or_else(|| BitMatrix::new(pvs.len()));
    let r = OracleReport::new(name, rays, seconds, steps, &last, pvs, misses.into_values().collect());
    Ok((r, matrices))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsp::tests::corridor;
    use sightline_formats::Face;

    /// The corridor with its wall thinned to a 0.01-unit solid sliver at x = 128 that no face
    /// bounds (a tree artifact: the geometry is open there), and the corridor's six outer faces.
    fn corridor_with_sliver() -> Level {
        corridor_with_unfaced_wall(0.01)
    }

    /// The corridor with its wall, `thickness` units from x = 128, bounded by no face (a sliver,
    /// or a brush textured `skip` on every side), and the corridor's six outer faces.
    fn corridor_with_unfaced_wall(thickness: f32) -> Level {
        let mut level = corridor();
        level.planes[3].dist = 128.0 + thickness;
        let (x0, x1, y0, y1, z0, z1) = (0.0f32, 200.0, -32.0, 32.0, 0.0, 64.0);
        // Each face is seen from the inside; winding order does not matter to the BVH.
        let quads: [(u32, [[f32; 3]; 4]); 6] = [
            (0, [[x0, y0, z0], [x0, y1, z0], [x0, y1, z1], [x0, y0, z1]]),
            (4, [[x1, y0, z0], [x1, y1, z0], [x1, y1, z1], [x1, y0, z1]]),
            (5, [[x0, y1, z0], [x1, y1, z0], [x1, y1, z1], [x0, y1, z1]]),
            (6, [[x0, y0, z0], [x1, y0, z0], [x1, y0, z1], [x0, y0, z1]]),
            (7, [[x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]]),
            (8, [[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0]]),
        ];
        for (plane, corners) in quads {
            let first_vertex = level.vertices.len() as u32;
            level.vertices.extend(corners);
            level.faces.push(Face { plane, first_vertex, num_vertices: 4, texture: 0 });
        }
        level.models[0].num_faces = 6;
        level
    }

    #[test]
    fn mesh_oracle_sees_through_a_solid_sliver_the_tree_oracle_trusts() {
        let level = corridor_with_sliver();
        // A PVS that trusts the sliver: cluster 2 sees only itself.
        let mut pvs = BitMatrix::new(3);
        for (a, b) in [(0, 0), (0, 1), (1, 0), (1, 1), (2, 2)] {
            pvs.set(a, b);
        }
        let opts = Options { rays: 300_000, ..Options::default() };
        let v = validate(&level, &pvs, &opts, &NoProgress).unwrap();
        let [tree, mesh] = &v.report.oracles[..] else { panic!("two oracles") };
        assert!(tree.misses.is_empty(), "the tree oracle stops at the sliver");
        let found: Vec<(u32, u32)> = mesh.misses.iter().map(|m| (m.from_cluster, m.to_cluster)).collect();
        assert_eq!(found, vec![(0, 2), (1, 2), (2, 0), (2, 1)]);
        let d = v.report.disagreement.unwrap();
        assert_eq!((d.pairs_only_tree, d.pairs_only_mesh), (0, 4));
    }

    /// What is solid is the tree's for both oracles: a wall with no face on it blocks the mesh
    /// oracle as it blocks the tree oracle, down to a slab thinner than [`mesh::SLIVER`], which the
    /// mesh oracle alone sees through.
    #[test]
    fn mesh_oracle_takes_unfaced_solid_for_solid_unless_it_is_a_sliver() {
        // A PVS that trusts the wall: cluster 2 sees only itself.
        let mut pvs = BitMatrix::new(3);
        for (a, b) in [(0, 0), (0, 1), (1, 0), (1, 1), (2, 2)] {
            pvs.set(a, b);
        }
        let opts = Options { rays: 200_000, ..Options::default() };
        let sliver = mesh::SLIVER as f32;
        for (thickness, seen_through) in [(8.0, false), (1.2 * sliver, false), (0.8 * sliver, true)] {
            let v = validate(&corridor_with_unfaced_wall(thickness), &pvs, &opts, &NoProgress).unwrap();
            let [tree, mesh] = &v.report.oracles[..] else { panic!("two oracles") };
            assert!(tree.misses.is_empty(), "{thickness}: the tree oracle stops at the wall");
            assert_eq!(mesh.misses.len(), if seen_through { 4 } else { 0 }, "{thickness}");
            let d = v.report.disagreement.unwrap();
            assert_eq!((d.pairs_only_tree, d.pairs_only_mesh), (0, if seen_through { 4 } else { 0 }));
        }
    }

    #[test]
    fn errors_read_as_the_cli_prints_them() {
        use std::error::Error as _;
        let mut level = corridor_with_sliver();
        level.models[0].num_faces = 99;
        let opts = Options { rays: 1000, oracle: OracleChoice::Mesh, ..Options::default() };
        let e = validate(&level, &BitMatrix::new(3), &opts, &NoProgress).unwrap_err();
        assert_eq!(e.to_string(), "building the face mesh");
        assert_eq!(
            e.source().map(|s| s.to_string()).as_deref(),
            Some("world model's faces are out of range")
        );
        let e = validate(&level, &BitMatrix::new(2), &opts, &NoProgress).unwrap_err();
        assert_eq!(e.to_string(), "PVS has 2 clusters, the level 3");
    }

    #[test]
    fn same_answers_for_any_thread_count() {
        let level = corridor_with_sliver();
        let pvs = BitMatrix::new(3);
        let opts = Options { rays: 50_000, ..Options::default() };
        let run = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| validate(&level, &pvs, &opts, &NoProgress).unwrap())
        };
        let (a, b) = (run(1), run(3));
        assert_eq!(a.sampled, b.sampled);
        assert_eq!(a.report.oracles[1].misses, b.report.oracles[1].misses);
    }
}
