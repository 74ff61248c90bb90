//! The compile itself: the phases in order, on the worker pool the options ask for.

use std::time::Instant;

use glam::DVec3;
use sightline_formats::{Aabb, Contents};
use sightline_job::progress::Progress;

use crate::brush::Brush;
use crate::error::CompileError;
use crate::options::CompileOptions;
use crate::prepared::OUTSIDE_MARGIN;
use crate::report::{Compiled, LeakReport, POINTFILE_STEP, PhaseTime};
use crate::source::Source;
use crate::visdata::store_pvs;
use crate::{bsp, emit, load, mesh, outside, portals, vis};

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

fn compile_here(
    source: &Source,
    opts: &CompileOptions,
    progress: &dyn Progress,
) -> Result<Compiled, CompileError> {
    let mut clock = Clock::new();
    // A mesh comes with its world tree prebuilt; a map builds its tree from brushes below.
    let (file, mut prep, mesh_tree) = match source {
        Source::Map { map, file } => (file.as_str(), load::load_map(map, file, progress)?, None),
        Source::Mesh { mesh, file } => {
            let (prep, tree) = mesh::prepare(mesh, file, progress)?;
            (file.as_str(), prep, Some(tree))
        }
    };
    clock.lap("csg", progress);

    progress.begin("bsp", 1 + prep.submodels.len() as u64);
    let (mut tree, bounds, world_bounds, cover) = match mesh_tree {
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
