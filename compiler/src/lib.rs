//! Map → level: CSG, leafy BSP, portals, outside fill and leaks, and the emitted [`Level`].
//!
//! [`compile`] runs the phases in order: `csg` (brush windings, contents, face clipping), `bsp`
//! (brush BSP of the world, detail last; one per submodel), `portals`, `outside` (flood from the
//! void, leak check, fill), `emit` (level and `.prt`), and `vis` when asked ([`vis`], then the
//! rows are stored Quake-RLE per cluster by [`store_pvs`]; [`visdata`] also stores them in Quake
//! `.bsp` and `.vis` files). Output is identical for any thread count:
//! parallel steps collect in input order and tree building uses `rayon::join` only.

pub mod brush;
pub mod bsp;
pub mod bsp_portals;
pub mod contents;
pub mod csg;
pub mod dropin;
pub mod emit;
mod load;
pub mod memory;
pub mod mesh;
pub mod outside;
pub mod phs;
pub mod portals;
pub mod vis;
pub mod visdata;

#[cfg(test)]
mod limit_tests;

pub use sightline_job::progress::{NoProgress, Progress};

pub use visdata::store_pvs;

use std::time::Instant;

use glam::DVec3;
use sightline_formats::map::MapFile;
use sightline_formats::prt::PortalFile;
use sightline_formats::{Aabb, Contents, Level, PlaneSet};

use crate::brush::Brush;
use crate::outside::Seed;

/// The tree's box lies this many units beyond every brush, so the void around the world is made
/// of empty leaves the outside flood starts from.
pub const OUTSIDE_MARGIN: f64 = 16.0;

/// Spacing of pointfile points along a leak path, in units.
pub const POINTFILE_STEP: f64 = 8.0;

/// What to compile.
#[derive(Debug, Clone)]
pub enum Source {
    /// A parsed `.map`.
    Map {
        /// The map.
        map: MapFile,
        /// File name for messages.
        file: String,
    },
    /// A triangle mesh (from `.obj`): its triangles build a polygon BSP.
    Mesh {
        /// The mesh.
        mesh: mesh::Mesh,
        /// File name for messages.
        file: String,
    },
}

/// Why [`Source::read`] failed; every variant names the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SourceError {
    /// The `.map` could not be read.
    #[error("reading {file}")]
    Read {
        /// The file.
        file: String,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// The `.map` does not parse.
    #[error(transparent)]
    Map(#[from] sightline_formats::map::MapError),
    /// The `.obj` could not be loaded.
    #[error(transparent)]
    Obj(#[from] sightline_formats::obj::ObjError),
}

impl Source {
    /// Reads `path`: an `.obj` ([`sightline_formats::FileKind::from_extension`]) as a mesh, any
    /// other file as a `.map`. The file name kept for messages is `path` as given.
    ///
    /// A `.map` is read as bytes ([`sightline_formats::map::parse_bytes`]): UTF-8 text as it is,
    /// any other file as Latin-1, so Quake's high-bit characters in strings are accepted and kept
    /// (as the characters `U+0080..=U+00FF` in the level's entity text). An `.obj`'s faces of one
    /// or two vertices are skipped; [`compile`] reports their count as a warning.
    pub fn read(path: &std::path::Path) -> Result<Self, SourceError> {
        let file = path.display().to_string();
        if sightline_formats::FileKind::from_extension(path) == Some(sightline_formats::FileKind::Obj) {
            let mesh = mesh::Mesh::from(&sightline_formats::obj::load(path)?);
            return Ok(Source::Mesh { mesh, file });
        }
        let bytes = std::fs::read(path).map_err(|source| SourceError::Read { file: file.clone(), source })?;
        let map = sightline_formats::map::parse_bytes(&bytes, &file)?;
        Ok(Source::Map { map, file })
    }
}

/// Options of [`compile`].
#[derive(Debug, Clone, Default)]
pub struct CompileOptions {
    /// Worker threads (`None`: rayon's default).
    pub threads: Option<usize>,
    /// Return a level even when the map leaks (without filling the outside, and without vis).
    pub allow_leak: bool,
    /// Run vis on the portals and store the PVS in the level (`None`: stop after portals).
    pub vis: Option<vis::VisOptions>,
    /// Refuse (with [`CompileError::Vis`] holding [`vis::VisError::Memory`]) a vis whose
    /// [`vis::memory_estimate`] is above this many bytes, before allocating it (the smaller of
    /// this and [`vis::VisOptions::max_memory`] applies; the memory the machine has available is
    /// always a limit too).
    pub max_memory: Option<u64>,
}

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
    /// Brushes in the source (all entities).
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

/// Why a compile failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CompileError {
    /// The map has no entities.
    #[error("{file}: the map has no entities (a map starts with a worldspawn entity)")]
    NoEntities {
        /// Source file.
        file: String,
    },
    /// The first entity is not worldspawn.
    #[error("{file}:{line}: the first entity is `{classname}`, expected `worldspawn`")]
    NoWorldspawn {
        /// Source file.
        file: String,
        /// Line of the entity.
        line: u32,
        /// Its class.
        classname: String,
    },
    /// A brush whose planes enclose nothing, or do not close.
    #[error("{file}:{line}: entity {entity} (`{classname}`) brush {brush}: {problem}")]
    BadBrush {
        /// Source file.
        file: String,
        /// Line of the brush.
        line: u32,
        /// Entity index.
        entity: usize,
        /// Entity class.
        classname: String,
        /// Brush index in the entity.
        brush: usize,
        /// What is wrong.
        problem: String,
    },
    /// A coordinate beyond the world limit.
    #[error("{file}:{line}: {what} lies beyond ±{limit} units", limit = sightline_formats::geom::WORLD_LIMIT)]
    HugeCoordinate {
        /// Source file.
        file: String,
        /// Line.
        line: u32,
        /// What it is.
        what: String,
    },
    /// An entity's `origin` is not three finite numbers.
    #[error("{file}:{line}: the origin of `{classname}` is \"{value}\", not three finite numbers")]
    BadOrigin {
        /// Source file.
        file: String,
        /// Line of the entity.
        line: u32,
        /// Its class.
        classname: String,
        /// The `origin` value as written.
        value: String,
    },
    /// Nothing to build a tree from.
    #[error("{file}: the world has no solid brushes to build a tree from")]
    EmptyWorld {
        /// Source file.
        file: String,
    },
    /// The mesh has no usable triangle.
    #[error("{file}: no triangle in the whole file has an area ({triangles} triangles read)")]
    EmptyMesh {
        /// Triangles the mesh has (all of them degenerate).
        triangles: usize,
        /// Source file.
        file: String,
    },
    /// The map leaks (and leaks were not allowed).
    #[error("{0}")]
    Leak(Box<LeakReport>),
    /// Vis failed, or stopped on request ([`vis::VisError::Interrupted`]: with a state file, the
    /// same compile resumes from it).
    #[error("vis")]
    Vis(#[from] vis::VisError),
    /// Vis returned rows for another number of clusters than the level has.
    #[error("vis returned {got} clusters for {want}")]
    VisClusters {
        /// Clusters in the vis result.
        got: usize,
        /// Clusters in the level.
        want: usize,
    },
    /// The worker pool could not start.
    #[error("could not start {threads} worker threads: {message}")]
    Threads {
        /// Requested count.
        threads: usize,
        /// Why.
        message: String,
    },
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

/// Adapts vis progress reports (phase, done, total) to a [`Progress`].
struct VisProgressBridge<'a> {
    progress: &'a dyn Progress,
    state: std::sync::Mutex<Option<(vis::VisPhase, usize)>>,
}

impl VisProgressBridge<'_> {
    fn report(&self, p: vis::VisProgress) {
        let Ok(mut state) = self.state.lock() else { return };
        match *state {
            Some((phase, done)) if phase == p.phase => {
                // Reports from several threads may arrive out of order: only move forward.
                if p.done > done {
                    self.progress.advance((p.done - done) as u64);
                    *state = Some((phase, p.done));
                }
            }
            Some(_) | None => {
                if state.is_some() {
                    self.progress.end();
                }
                let name = match p.phase {
                    vis::VisPhase::Coarsen => "vis clusters merged (--coarsen)",
                    vis::VisPhase::Base => "vis base",
                    vis::VisPhase::Flow => "vis flow",
                };
                self.progress.begin(name, p.total as u64);
                self.progress.advance(p.done as u64);
                *state = Some((p.phase, p.done));
            }
        }
    }
}

/// Compile `source`.
pub fn compile(
    source: &Source,
    opts: &CompileOptions,
    progress: &dyn Progress,
) -> Result<Compiled, CompileError> {
    match opts.threads {
        Some(threads) => {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads.max(1))
                .stack_size(64 << 20)
                .build()
                .map_err(|e| CompileError::Threads { threads, message: e.to_string() })?;
            pool.install(|| compile_here(source, opts, progress))
        }
        None => compile_here(source, opts, progress),
    }
}

struct Clock {
    start: Instant,
    phases: Vec<PhaseTime>,
}

impl Clock {
    fn new() -> Self {
        Self { start: Instant::now(), phases: Vec::new() }
    }

    fn lap(&mut self, name: &str, progress: &dyn Progress) {
        let now = Instant::now();
        self.phases.push(PhaseTime { name: name.to_string(), seconds: (now - self.start).as_secs_f64() });
        self.start = now;
        progress.end();
    }
}

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
    /// A mesh's prebuilt world tree (maps build theirs from brushes after loading).
    pub mesh: Option<mesh::MeshTree>,
    /// Fill unreachable space (maps) or keep every non-solid leaf (meshes, no entities).
    pub fill: bool,
}

fn compile_here(
    source: &Source,
    opts: &CompileOptions,
    progress: &dyn Progress,
) -> Result<Compiled, CompileError> {
    let mut clock = Clock::new();
    let (file, mut prep) = match source {
        Source::Map { map, file } => (file.as_str(), load::load_map(map, file, progress)?),
        Source::Mesh { mesh, file } => (file.as_str(), mesh::prepare(mesh, file, progress)?),
    };
    clock.lap("csg", progress);

    progress.begin("bsp", 1 + prep.submodels.len() as u64);
    let (mut tree, bounds, world_bounds, cover) = match prep.mesh.take() {
        Some(m) => (m.tree, m.volume, m.world, Some(m.cover)),
        None => {
            let world =
                Aabb::from_points(prep.structural.iter().flat_map(|b| [b.bounds.mins, b.bounds.maxs]));
            if world.is_empty() {
                return Err(CompileError::EmptyWorld { file: file.to_string() });
            }
            let bounds = world.expanded(OUTSIDE_MARGIN);
            let volume = Brush::from_box(&mut prep.planes, &bounds, Contents::Empty);
            let brushes = std::mem::take(&mut prep.structural);
            (bsp::build(&prep.planes, brushes, volume), bounds, world, None)
        }
    };
    progress.advance(1);
    let mut sub_inputs = Vec::with_capacity(prep.submodels.len());
    for (brushes, faces) in std::mem::take(&mut prep.submodels) {
        let mb = Aabb::from_points(brushes.iter().flat_map(|b| [b.bounds.mins, b.bounds.maxs]));
        let mb = if mb.is_empty() { Aabb::new(DVec3::ZERO, DVec3::ZERO) } else { mb };
        let volume = Brush::from_box(&mut prep.planes, &mb.expanded(OUTSIDE_MARGIN), Contents::Empty);
        sub_inputs.push((brushes, faces, mb, volume));
    }
    let submodels: Vec<emit::Submodel> = sub_inputs
        .into_iter()
        .map(|(brushes, faces, bounds, volume)| {
            let tree = bsp::build(&prep.planes, brushes, volume);
            progress.advance(1);
            emit::Submodel { tree, faces, bounds }
        })
        .collect();
    clock.lap("bsp", progress);

    progress.begin("portals", 1);
    let graph = portals::build(&tree, &prep.planes, &bounds);
    progress.advance(1);
    clock.lap("portals", progress);

    progress.begin("outside", 1);
    if let Some(cover) = &cover {
        let opened = cover.open_unenclosed(&mut tree, &prep.planes, &graph);
        if opened.cells > 0 {
            prep.stats.warnings.push(format!(
                "{file}: {} cells behind triangles are not enclosed by the mesh and were left open \
                 (sight passes through them), within {} to {}",
                opened.cells,
                mesh::point(opened.bounds.mins),
                mesh::point(opened.bounds.maxs)
            ));
        }
    }
    let fill = outside::flood(&tree, &prep.planes, &graph, &prep.seeds, prep.fill);
    progress.advance(1);
    let mut leak = None;
    if let Some((seed, points)) = &fill.leak {
        let (classname, line) = load::entity_info(source, seed.entity);
        let report = LeakReport {
            file: file.to_string(),
            classname,
            origin: seed.point,
            line,
            path: outside::sample_path(points, POINTFILE_STEP),
        };
        if !opts.allow_leak {
            return Err(CompileError::Leak(Box::new(report)));
        }
        leak = Some(report);
    }
    if fill.no_seed && prep.fill {
        prep.stats
            .warnings
            .push("no entity with an origin lies in open space: only the outside was filled".to_string());
    }
    clock.lap("outside", progress);

    progress.begin("emit", 1);
    let collapsed = tree.has_detail().then(|| {
        let (ctree, origin) = tree.collapse_detail(&fill.contents);
        (portals::build(&ctree, &prep.planes, &bounds), origin)
    });
    let world = emit::World {
        tree: &tree,
        contents: &fill.contents,
        portals: &graph,
        faces: &prep.world_faces,
        bounds: world_bounds,
        cluster_portals: collapsed.as_ref().map(|(g, o)| (g, o.as_slice())),
    };
    let out = emit::emit(&prep.planes, &world, &submodels, prep.entities, prep.textures, &prep.surfaces);
    progress.advance(1);
    clock.lap("emit", progress);

    let mut stats = prep.stats;
    let level = out.level;
    stats.planes = level.planes.len();
    stats.nodes = level.nodes.len();
    stats.leaves = level.leaves.len();
    stats.vis_leaves = out.prt.num_leaves as usize;
    stats.clusters = level.num_clusters as usize;
    stats.portals = level.portals.len();
    stats.faces = level.faces.len();
    stats.filled_leaves = fill.filled;
    let mut level = level;
    let mut vis_stats = None;
    if let (Some(vis_opts), None) = (&opts.vis, &leak) {
        let bridge = VisProgressBridge { progress, state: std::sync::Mutex::new(None) };
        let mut vis_opts = vis_opts.clone();
        if let Some(t) = opts.threads {
            vis_opts.threads = t.max(1);
        }
        vis_opts.max_memory = match (vis_opts.max_memory, opts.max_memory) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
        let result = vis::run(&out.prt, &vis_opts, &|p| bridge.report(p))?;
        if result.num_clusters() != level.num_clusters as usize {
            return Err(CompileError::VisClusters {
                got: result.num_clusters(),
                want: level.num_clusters as usize,
            });
        }
        store_pvs(&mut level, &result);
        vis_stats = Some(result.stats.clone());
        clock.lap("vis", progress);
    }
    stats.phases = clock.phases;
    Ok(Compiled { level, prt: out.prt, stats, leak, vis: vis_stats })
}
