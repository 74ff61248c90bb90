//! The compile itself: the phases in order, on the worker pool the options ask for.

use std::time::Instant;

use glam::DVec3;
use sightline_formats::{Aabb, Contents};
use sightline_job::cancel::Cancel;
use sightline_job::progress::{Progress, phase};

use crate::brush::Brush;
use crate::error::CompileError;
use crate::options::CompileOptions;
use crate::phase_memory::{
    BSP_PER_SIDE, CSG_PER_SIDE, EMIT_PER_FACE, EMIT_PER_PORTAL, MESH_PER_TRIANGLE, OUTSIDE_PER_ENTRY,
    PORTALS_PER_ENTRY, PhaseMemory, per,
};
use crate::prepared::OUTSIDE_MARGIN;
use crate::report::{Compiled, LeakReport, POINTFILE_STEP, PhaseTime};
use crate::source::Source;
use crate::vis::VisOptions;
use crate::viscluster::{self, VisClusterStat};
use crate::visdata::store_pvs;
use crate::{bsp, emit, load, mesh, outside, portals, vis};

/// Compile `source`. `progress` gets one phase per step (`csg`, `bsp`, `portals`, `outside`,
/// `emit`, then vis's); [`CompileOptions::cancel`] stops the compile at its next safe point.
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

    /// Phase `name` is over: its time is kept, and the compile stops here when cancelled.
    fn lap(&mut self, name: &'static str, cancel: &Cancel) -> Result<(), CompileError> {
        let now = Instant::now();
        self.phases.push(PhaseTime { name: name.to_string(), seconds: (now - self.start).as_secs_f64() });
        self.start = now;
        if cancel.is_cancelled() {
            return Err(CompileError::Cancelled { phase: name });
        }
        Ok(())
    }
}

fn compile_here(
    source: &Source,
    opts: &CompileOptions,
    progress: &dyn Progress,
) -> Result<Compiled, CompileError> {
    let cancel = &opts.cancel;
    let mut clock = Clock::new();
    let memory = PhaseMemory::new(source.file(), opts.max_memory, rayon::current_num_threads());
    // Brush sides of a map (what CSG and the tree grow with); 0 for a mesh.
    let sides = match source {
        Source::Map { map, .. } => map.brushes().map(|b| b.sides.len()).sum(),
        Source::Mesh { .. } => 0,
    };
    // A mesh comes with its world tree prebuilt; a map builds its tree from brushes below.
    let (file, mut prep, mesh_tree) = match source {
        Source::Map { map, file } => {
            memory.check("csg", per(CSG_PER_SIDE, sides), || format!("{sides} brush sides"))?;
            (file.as_str(), load::load_map(map, file, progress, cancel)?, None)
        }
        Source::Mesh { mesh, file } => {
            let triangles = mesh.triangles.len();
            memory.check("csg", per(MESH_PER_TRIANGLE, triangles), || format!("{triangles} triangles"))?;
            let (prep, tree) = mesh::prepare(mesh, file, progress, cancel)?;
            (file.as_str(), prep, Some(tree))
        }
    };
    clock.lap("csg", cancel)?;
    memory.check("bsp", per(BSP_PER_SIDE, sides), || format!("{sides} brush sides"))?;

    let bsp_phase = phase(progress, "bsp", 1 + prep.submodels.len() as u64);
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
            (bsp::build(&prep.planes, brushes, volume, cancel), bounds, world, None)
        }
    };
    bsp_phase.advance(1);
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
            let tree = bsp::build(&prep.planes, brushes, volume, cancel);
            bsp_phase.advance(1);
            emit::Submodel { tree, faces, bounds }
        })
        .collect();
    drop(bsp_phase);
    clock.lap("bsp", cancel)?;
    let entries = tree.nodes.len();
    memory.check("portals", per(PORTALS_PER_ENTRY, entries), || {
        format!("a tree of {entries} nodes and leaves")
    })?;

    let graph = {
        let p = phase(progress, "portals", 1);
        let graph = portals::build(&tree, &prep.planes, &bounds);
        p.advance(1);
        graph
    };
    clock.lap("portals", cancel)?;
    memory.check("outside", per(OUTSIDE_PER_ENTRY, entries), || {
        format!("a tree of {entries} nodes and leaves")
    })?;

    let outside_phase = phase(progress, "outside", 1);
    if let Some(cover) = &cover {
        let opened = cover
            .open_unenclosed(&mut tree, &prep.planes, &graph, cancel)
            .map_err(|_| CompileError::Cancelled { phase: "outside" })?;
        prep.stats.cover_tests = opened.tests;
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
    outside_phase.advance(1);
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
    drop(outside_phase);
    clock.lap("outside", cancel)?;
    let (faces, portal_count) = (prep.world_faces.len(), graph.portals.len());
    let emit_needs = per(EMIT_PER_FACE, faces).saturating_add(per(EMIT_PER_PORTAL, portal_count));
    memory.check("emit", emit_needs, || format!("{faces} faces and {portal_count} portals"))?;

    let emit_phase = phase(progress, "emit", 1);
    let collapsed = tree.has_detail().then(|| {
        let (ctree, origin) = tree.collapse_detail(&fill.contents);
        (portals::build(&ctree, &prep.planes, &bounds), origin)
    });
    let vis_groups = viscluster::leaf_groups(&tree, &fill.contents, &prep.visclusters);
    let world = emit::World {
        tree: &tree,
        contents: &fill.contents,
        portals: &graph,
        faces: &prep.world_faces,
        bounds: world_bounds,
        cluster_portals: collapsed.as_ref().map(|(g, o)| (g, o.as_slice())),
        vis_groups: &vis_groups,
    };
    let out = emit::emit(&prep.planes, &world, &submodels, prep.entities, prep.textures, &prep.surfaces);
    emit_phase.advance(1);
    drop(emit_phase);
    clock.lap("emit", cancel)?;

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
    stats.visclusters = prep
        .visclusters
        .iter()
        .enumerate()
        .map(|(g, v)| VisClusterStat {
            line: v.line,
            leaves: out.viscluster_leaves.get(g).copied().unwrap_or(0),
        })
        .collect();
    let mut level = level;
    let mut vis_stats = None;
    if let (Some(vis_opts), None) = (&opts.vis, &leak) {
        let mut vis_opts = VisOptions { cancel: cancel.clone(), ..vis_opts.clone() };
        if let Some(t) = opts.threads {
            vis_opts.threads = t.max(1);
        }
        vis_opts.max_memory = match (vis_opts.max_memory, opts.max_memory) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
        let result = vis::run(&out.prt, &vis_opts, progress)?;
        if result.num_clusters() != level.num_clusters as usize {
            return Err(CompileError::VisClusters {
                got: result.num_clusters(),
                want: level.num_clusters as usize,
            });
        }
        store_pvs(&mut level, &result);
        vis_stats = Some(result.stats.clone());
        clock.lap("vis", cancel)?;
    }
    stats.phases = clock.phases;
    Ok(Compiled { level, prt: out.prt, stats, leak, vis: vis_stats })
}
