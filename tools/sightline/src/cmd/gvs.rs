//! `sightline gvs`: guided visibility sampling per view cell, with the thesis' error metric.
//!
//! Scenes: `gen:<city|spheres|mixed|mesh>:<size>` (see [`sightline_gvs::scenegen`]), a `.obj`
//! mesh, or a compiled level (`.slvl`, or a `.bsp` of any Quake-family game). Cells: `auto` (the generator's suggestion), a grid cell
//! size, `leaves` (a level's open leaves), or `x0,y0,z0,x1,y1,z1`; `--cell` can be repeated.
//!
//! With `--compare`, every variant ([`Variant::ALL`]) runs on the same cells and is
//! measured against the same ID buffers, and the incremental update is compared with a fresh run on
//! the cell moved by `--move`.
//!
//! The work is [`sightline_gvs`]'s (scene loading, cells, the runs, the error metric); this file
//! parses the arguments, draws the progress bars, times the phases and prints.

use std::ops::Bound::{Excluded, Included, Unbounded};
use std::path::Path;
use std::time::Instant;

use anyhow::{Context, bail};
use clap::builder::RangedU64ValueParser;
use glam::Vec3;
use serde::Serialize;
use sightline_gvs::error::{self, ErrorStats};
use sightline_gvs::metric::{MeasuredView, Metric, PIXEL_BUDGET, ViewOptions};
use sightline_gvs::scene::{self, TriScene};
use sightline_gvs::{
    self as gvs, Cell, Components, Neighbours, Params, Pvs, SceneIndex, Stats, TargetGroups, Twins, Variant,
    cells, update,
};
use sightline_raycast::Bvh;

use crate::limits::{self, MAX_RAYS};
use crate::outcome::Outcome;
use crate::progress::Bars;

/// What `sightline gvs` does: its line in `sightline --help` and the first line of its own help.
pub const ABOUT: &str = "Guided visibility sampling for triangle meshes";

/// Arguments of `sightline gvs`.
#[derive(Debug, clap::Args)]
#[command(about = ABOUT)]
pub struct Args {
    /// Scene: `gen:<city|spheres|mixed|mesh>:<size>`, a `.obj` mesh, a `.slvl` level or a compiled `.bsp` of any Quake-family game.
    pub input: String,
    /// View cells: `auto`, a grid cell size, `leaves`, or `x0,y0,z0,x1,y1,z1` (repeatable).
    #[arg(long, default_value = "auto")]
    pub cell: Vec<String>,
    /// Use at most this many cells (evenly spaced through the list), 1 to 1048576.
    #[arg(long, value_parser = RangedU64ValueParser::<usize>::new().range(1..=cells::MAX_GRID))]
    pub max_cells: Option<usize>,
    /// Variant to run: gvs (stock), d4, adt, edgepoint, first, edgepoint+sil, edgepoint+probe,
    /// edgepoint+probe+first, edgepoint+probe+first+target (the default: the most accurate per
    /// ray).
    #[arg(long, default_value = "edgepoint+probe+first+target")]
    pub variant: String,
    /// Run every variant and the incremental update side by side and print a table.
    #[arg(long)]
    pub compare: bool,
    /// Cell translation for the incremental-update comparison, `dx,dy,dz` (default: a quarter of
    /// the first cell's width along x).
    #[arg(long = "move", requires = "compare")]
    pub move_by: Option<String>,
    /// Views per measured cell for the error metric, 0 to 10000 (0 disables it).
    #[arg(long, default_value_t = 10, value_parser = RangedU64ValueParser::<usize>::new().range(0..=MAX_VIEWS))]
    pub views: usize,
    /// ID buffer width and height in pixels, 0 to 8192 (0 disables the error metric).
    #[arg(long, default_value_t = 1000, value_parser = RangedU64ValueParser::<usize>::new().range(0..=MAX_RES))]
    pub res: usize,
    /// ID buffer field of view in degrees, in (0, 180).
    #[arg(long, default_value_t = 60.0, value_parser = limits::float_in::<f32>((Excluded(0.0), Excluded(180.0)), "a field of view in degrees"))]
    pub fov: f32,
    /// Cells whose error is measured (evenly spaced), 0 to 1048576.
    #[arg(long, default_value_t = 4, value_parser = RangedU64ValueParser::<usize>::new().range(0..=cells::MAX_GRID))]
    pub error_cells: usize,
    /// Enlarged-outline angular offset (radians), in (0, 1].
    #[arg(long, value_parser = limits::float_in::<f32>((Excluded(0.0), Included(1.0)), "an angle in radians"))]
    pub eps: Option<f32>,
    /// Deepest edge bisection, 1 to 64.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub max_depth: Option<u32>,
    /// Relative depth-discontinuity threshold, in [0, 1).
    #[arg(long, value_parser = limits::float_in::<f32>(0.0..1.0, "a fraction of the depth"))]
    pub disc: Option<f32>,
    /// Angular threshold of the `adt` variant (radians), positive.
    #[arg(long, value_parser = limits::float_in::<f32>((Excluded(0.0), Unbounded), "an angle in radians"))]
    pub adt: Option<f32>,
    /// Termination window in rays, 1 to 10^12.
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=MAX_RAYS))]
    pub window: Option<u64>,
    /// Fewest new triangles per window to go on (0: the window never stops a run).
    #[arg(long)]
    pub min_new: Option<u32>,
    /// Cap on all rays per cell, 1 to 10^12.
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=MAX_RAYS))]
    pub max_rays: Option<u64>,
    /// Cap on random rays per cell, 0 to 10^12.
    #[arg(long, value_parser = clap::value_parser!(u64).range(0..=MAX_RAYS))]
    pub max_random: Option<u64>,
    /// Initial random rays of the "first" variants (default 100000), 0 to 10^12; each thread
    /// holds those of its cell at once (48 bytes a ray), which must fit in memory.
    #[arg(long, value_parser = clap::value_parser!(u64).range(0..=MAX_RAYS))]
    pub first: Option<u64>,
    /// Triangles aimed at per unreached triangle group of the "target" variant (default 3), 0 to
    /// 65536.
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=MAX_PER_TARGET))]
    pub targets: Option<u32>,
    /// Most rays aimed at one target triangle, from points spread over the cell (default 16), 0
    /// to 65536.
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=MAX_PER_TARGET))]
    pub target_rays: Option<u32>,
    /// Rays neighbour probing casts, from random points of the cell, at a probed triangle its
    /// fixed rays missed (default 8), 0 to 65536.
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=MAX_PER_TARGET))]
    pub probe_rays: Option<u32>,
    /// Edge-point walk without the forced midpoint ray.
    #[arg(long)]
    pub no_midpoint: bool,
    /// Disable reverse sampling.
    #[arg(long)]
    pub no_reverse: bool,
    /// Seed of the random rays and the error views.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Seed of generated scenes.
    #[arg(long, default_value_t = 1)]
    pub scene_seed: u64,
    /// Worker threads, 1 to 1024 (default: all cores).
    #[arg(long, value_parser = limits::threads())]
    pub threads: Option<usize>,
    /// Write the level with the per-cell face sets to this `.slvl`.
    #[arg(short = 'o', long)]
    pub output: Option<std::path::PathBuf>,
    /// List the N triangles with most wrong pixels in every measured view of the first variant
    /// run (pixels, distance from the eye, |cos| between its normal and the view ray), to find
    /// where the error comes from. Text output only. At most 1000000.
    #[arg(long, default_value_t = 0, value_parser = RangedU64ValueParser::<usize>::new().range(0..=1_000_000))]
    pub missed: usize,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

/// One line of the result: a variant on the measured cells.
#[derive(Debug, Serialize)]
struct Row {
    variant: String,
    cells: usize,
    rays: u64,
    random: u64,
    point: u64,
    edge: u64,
    reverse: u64,
    reuse: u64,
    silhouette: u64,
    probe: u64,
    target: u64,
    discontinuities: u64,
    seconds: f64,
    pvs: usize,
    error_mean: Option<f64>,
    error_max: Option<u64>,
    /// The error counted per object (surface component) as the thesis counts it: a pixel is
    /// wrong only when no triangle of its object is in the PVS (absent without a component table).
    error_objects_mean: Option<f64>,
    error_objects_max: Option<u64>,
    /// All the variant's rays over the process CPU seconds of its run (GVS bookkeeping
    /// included, so a lower bound of the ray-casting rate).
    gvs_rays_per_cpu_second: Option<f64>,
    /// Cells whose run stopped at the ray cap (`--max-rays`): their PVS may be incomplete.
    capped_cells: usize,
}

/// The JSON report.
#[derive(Debug, Serialize)]
struct Report {
    scene: String,
    triangles: usize,
    cells: usize,
    bvh_build_seconds: f64,
    bvh_nodes: usize,
    neighbours_build_seconds: f64,
    neighbours_bytes: usize,
    /// Seconds building the surface components and the target groups.
    components_build_seconds: f64,
    components: usize,
    target_groups: usize,
    /// Triangles with a coplanar twin (see `gvs::twins`; 0 without error measurement).
    twins: usize,
    params: Params,
    rows: Vec<Row>,
    error_views: usize,
    error_res: usize,
    error_fov: f32,
    error_rays: u64,
    error_seconds: f64,
    threads: usize,
    rays_per_second_per_core: f64,
    rays_per_cpu_second: Option<f64>,
}

/// The variant the incremental update is compared with (and starts from).
const BEST: Variant = Variant::ProbeFirstTarget;

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<Outcome> {
    if let Some(out) = &args.output {
        crate::output::check(&[Path::new(&args.input)], &[out])?;
    }
    let checked = check(args)?;
    let threads = args.threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    // The "first" random rays of a cell are held at once, by every thread running a cell.
    let first = checked.variants.iter().map(|v| v.params(checked.params).first).max().unwrap_or(0);
    let first = first.min(checked.params.max_random).min(checked.params.max_rays);
    let batch = threads as u64 * first * FIRST_RAY_BYTES;
    limits::fits_memory(
        &format!("--first {first} random rays on each of {threads} threads"),
        batch,
        threads,
    )?;
    let pool = limits::pool(threads)?;
    pool.install(|| run_in_pool(args, checked, threads))
}

/// Widest ID buffer (`--res`): one buffer of 8192² pixels takes 256 MiB of triangle ids (and at
/// most twice as many tie entries, see `gvs::twins`).
const MAX_RES: u64 = 8192;

/// Most error views per measured cell (`--views`; each cell's views are drawn at once).
const MAX_VIEWS: u64 = 10_000;

/// Most targets per group and rays per target or probed triangle (`--targets`,
/// `--target-rays`, `--probe-rays`).
const MAX_PER_TARGET: i64 = 65_536;

/// Bytes of one "first" random ray while its batch is sorted: the ray (origin and direction, 24
/// bytes) in the batch and again in the sorted copy.
const FIRST_RAY_BYTES: u64 = 48;

/// What `run` takes from the arguments besides the scene and the cells, checked before any work.
#[derive(Debug)]
struct Checked {
    params: Params,
    variants: Vec<Variant>,
    /// `--move`, parsed.
    shift: Option<Vec3>,
    /// `--cell`, parsed.
    cells: Vec<CellSpec>,
}

fn check(args: &Args) -> anyhow::Result<Checked> {
    let params = params(args);
    params.check()?;
    let variants = if args.compare { Variant::ALL.to_vec() } else { vec![parse_variant(&args.variant)?] };
    let shift = args.move_by.as_deref().map(|s| parse_vec(s).context("--move")).transpose()?;
    let cells = args.cell.iter().map(|s| parse_cell_spec(s)).collect::<anyhow::Result<_>>()?;
    Ok(Checked { params, variants, shift, cells })
}

fn run_in_pool(args: &Args, checked: Checked, threads: usize) -> anyhow::Result<Outcome> {
    let Checked { params, variants, shift, cells: specs } = checked;
    let (scene, level) = scene::load(&args.input, args.scene_seed, &crate::progress::Bars::new(true))?;
    if scene.triangles.is_empty() {
        bail!("{}: no triangles in the whole file", args.input);
    }
    let mut cells = Vec::new();
    for spec in &specs {
        cells.extend(cells_of(spec, &scene, level.as_ref()).with_context(|| args.input.clone())?);
    }
    if let Some(k) = args.max_cells
        && k < cells.len()
    {
        cells = cells::evenly(&cells, k);
    }
    if cells.is_empty() {
        bail!("{}: no view cells", args.input);
    }
    let t0 = Instant::now();
    let bvh = Bvh::build(&scene.triangles);
    let bvh_seconds = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    // Only probing reads the table (without it, `Neighbours::of` answers `None` and probing
    // would query the BVH).
    let neighbours = if variants.iter().any(|v| v.params(params).probe) {
        Neighbours::build(&scene.triangles, &bvh)
    } else {
        Neighbours::default()
    };
    let neighbours_seconds = t0.elapsed().as_secs_f64();
    // Target sampling reads the components and the target groups (without components it falls
    // back to whole groups), and the error per object counts with the components.
    let t0 = Instant::now();
    let measure_on = args.views > 0 && args.res > 0;
    let targets_on = variants.iter().any(|v| v.params(params).targets > 0);
    let components =
        if measure_on || targets_on { Components::build(&scene.triangles) } else { Components::default() };
    let targets = if targets_on { TargetGroups::build(&bvh, &components) } else { TargetGroups::default() };
    let components_seconds = t0.elapsed().as_secs_f64();
    if !args.json {
        eprintln!(
            "{}: {} triangles, {} cells, BVH {} nodes in {:.2} s, neighbour table {:.1} MB in {:.2} s, {} surface components and {} target groups in {:.2} s",
            args.input,
            scene.triangles.len(),
            cells.len(),
            bvh.node_count(),
            bvh_seconds,
            neighbours.bytes() as f64 / 1e6,
            neighbours_seconds,
            components.count(),
            targets.len(),
            components_seconds
        );
    }
    let index = SceneIndex { tris: &scene.triangles, bvh, neighbours, components, targets };

    let bars = &Bars::new(args.json);
    let cancel = &crate::interrupt::cancel();
    let stopped = |_| {
        crate::interrupt::announce_stop();
        anyhow::anyhow!("{}: stopped on request; nothing was written", args.input)
    };
    let mut rows = Vec::new();
    // Per variant: the cells' results and the process CPU seconds their run took.
    let mut results: Vec<(Variant, Vec<Pvs>, Option<f64>)> = Vec::new();
    for &v in &variants {
        let cpu0 = cpu_seconds();
        let pvs = gvs::run_variant(&index, &cells, v, params, bars, cancel).map_err(stopped)?;
        let cpu = cpu_seconds().zip(cpu0).map(|(b, a)| b - a);
        results.push((v, pvs, cpu));
    }

    // Error measurement: the same ID buffers for every variant, cast in batches and dropped once
    // compared (see `Metric::measure`).
    let measured: Vec<usize> =
        cells::evenly(&(0..cells.len()).collect::<Vec<_>>(), args.error_cells.min(cells.len()));
    // The error metric's ties (see `gvs::twins`), built with the ID buffers.
    let twins = if measure_on { Twins::build(&scene.triangles, &index.bvh) } else { Twins::default() };
    let view_options = ViewOptions { views: args.views, res: args.res, fov: args.fov };
    let mut metric =
        Metric::new(&index, &twins, view_options, &measured, PIXEL_BUDGET).with_cpu_clock(cpu_seconds);
    let pvs_of: Vec<&[Pvs]> = results.iter().map(|(_, p, _)| p.as_slice()).collect();
    let missed = (args.missed > 0 && !args.json).then(|| results.first().map(|(v, _, _)| v.name())).flatten();
    let tris = &scene.triangles[..];
    let mut list_missed = missed
        .map(|name| move |m: MeasuredView<'_>| bars.suspend(|| print_missed(args.missed, name, tris, &m)));
    let on_view = list_missed.as_mut().map(|f| f as &mut dyn FnMut(MeasuredView<'_>));
    let errors = metric.measure(&cells, args.seed, &pvs_of, (bars, cancel), on_view).map_err(stopped)?;
    for ((v, pvs, cpu), e) in results.iter().zip(errors) {
        let mut r = row(v.name(), pvs, e);
        r.gvs_rays_per_cpu_second = gvs::rays_per_second(pvs, *cpu);
        rows.push(r);
    }

    if args.compare {
        // Incremental update against a fresh run on the moved cell, best variant's parameters.
        let base = BEST.params(params);
        let shift = shift.unwrap_or(Vec3::X * ((cells[0].max.x - cells[0].min.x) * 0.25));
        let prev = results.iter().find(|(v, _, _)| *v == BEST).map(|(_, p, _)| p);
        if let Some(prev) = prev {
            let moved: Vec<Cell> = cells.iter().map(|c| c.translated(shift)).collect();
            let cpu0 = cpu_seconds();
            let fresh = gvs::run_cells(&index, &moved, base, &gvs::NoProgress, cancel).map_err(stopped)?;
            let cpu1 = cpu_seconds();
            let updated = update::update_cells(&index, prev, shift, base);
            let (cpu_fresh, cpu_update) =
                (cpu1.zip(cpu0).map(|(b, a)| b - a), cpu_seconds().zip(cpu1).map(|(b, a)| b - a));
            let errors = metric
                .measure(&moved, args.seed.wrapping_add(1000), &[&fresh, &updated], (bars, cancel), None)
                .map_err(stopped)?;
            for ((name, pvs, cpu), e) in [
                (format!("{}@moved", BEST.name()), &fresh, cpu_fresh),
                ("incremental@moved".into(), &updated, cpu_update),
            ]
            .into_iter()
            .zip(errors)
            {
                let mut r = row(&name, pvs, e);
                r.gvs_rays_per_cpu_second = gvs::rays_per_second(pvs, cpu);
                rows.push(r);
            }
        }
    }

    let (error_rays, error_seconds) = (metric.rays(), metric.seconds());
    let per_core = if error_seconds > 0.0 { error_rays as f64 / error_seconds / threads as f64 } else { 0.0 };
    let per_cpu = metric.cpu_seconds().filter(|&c| c > 0.0).map(|c| error_rays as f64 / c);
    let report = Report {
        scene: args.input.clone(),
        triangles: scene.triangles.len(),
        cells: cells.len(),
        bvh_build_seconds: bvh_seconds,
        bvh_nodes: index.bvh.node_count(),
        neighbours_build_seconds: neighbours_seconds,
        neighbours_bytes: index.neighbours.bytes(),
        components_build_seconds: components_seconds,
        components: index.components.count(),
        target_groups: index.targets.len(),
        twins: twins.count(),
        params,
        rows,
        error_views: if measure_on { args.views * measured.len() } else { 0 },
        error_res: args.res,
        error_fov: args.fov,
        error_rays,
        error_seconds,
        threads,
        rays_per_second_per_core: per_core,
        rays_per_cpu_second: per_cpu,
    };

    if let Some(out) = &args.output {
        let (v, pvs, _) = &results[0];
        let mut level = match level {
            Some(l) => l,
            None => gvs::soup_level(&scene.triangles),
        };
        gvs::store(&mut level, pvs, scene.face_of.as_deref());
        write_level(out, &level).with_context(|| format!("writing {}", out.display()))?;
        if !args.json {
            eprintln!("wrote {} ({} cells, variant {})", out.display(), level.gvs_cells.len(), v.name());
        }
    }

    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print_table(&report);
    }
    Ok(Outcome::Clean)
}

fn params(args: &Args) -> Params {
    let d = Params::default();
    Params {
        eps: args.eps.unwrap_or(d.eps),
        max_depth: args.max_depth.unwrap_or(d.max_depth),
        disc: args.disc.unwrap_or(d.disc),
        adt: args.adt.or(d.adt),
        window: args.window.unwrap_or(d.window),
        min_new: args.min_new.unwrap_or(d.min_new),
        max_rays: args.max_rays.unwrap_or(d.max_rays),
        max_random: args.max_random.unwrap_or(d.max_random),
        first: args.first.unwrap_or(d.first),
        targets: args.targets.unwrap_or(d.targets),
        target_rays: args.target_rays.unwrap_or(d.target_rays),
        probe_rays: args.probe_rays.unwrap_or(d.probe_rays),
        midpoint: !args.no_midpoint,
        reverse: !args.no_reverse,
        seed: args.seed,
        ..d
    }
}

fn parse_variant(s: &str) -> anyhow::Result<Variant> {
    Variant::ALL.into_iter().find(|v| v.name() == s || (s == "stock" && *v == Variant::Stock)).with_context(
        || {
            let names: Vec<&str> = Variant::ALL.iter().map(|v| v.name()).collect();
            format!("unknown variant `{s}` ({})", names.join(", "))
        },
    )
}

/// The table row of one variant: its cells' statistics, and its wrong pixels per view per
/// triangle and per object (`errors`, see [`Metric::measure`]).
fn row(name: &str, pvs: &[Pvs], errors: [ErrorStats; 2]) -> Row {
    let mut s = Stats::default();
    for p in pvs {
        s.rays += p.stats.rays;
        s.random += p.stats.random;
        s.point += p.stats.point;
        s.edge += p.stats.edge;
        s.reverse += p.stats.reverse;
        s.reuse += p.stats.reuse;
        s.silhouette += p.stats.silhouette;
        s.probe += p.stats.probe;
        s.target += p.stats.target;
        s.discontinuities += p.stats.discontinuities;
        s.seconds += p.stats.seconds;
    }
    let pvs_total: usize = pvs.iter().map(|p| p.entries.len()).sum();
    let [tri_err, obj_err] = errors.map(|e| e.get());
    let cells = pvs.len().max(1);
    Row {
        variant: name.to_string(),
        cells: pvs.len(),
        rays: s.rays / cells as u64,
        random: s.random / cells as u64,
        point: s.point / cells as u64,
        edge: s.edge / cells as u64,
        reverse: s.reverse / cells as u64,
        reuse: s.reuse / cells as u64,
        silhouette: s.silhouette / cells as u64,
        probe: s.probe / cells as u64,
        target: s.target / cells as u64,
        discontinuities: s.discontinuities / cells as u64,
        seconds: s.seconds / cells as f64,
        pvs: pvs_total / cells,
        error_mean: tri_err.map(|e| e.0),
        error_max: tri_err.map(|e| e.1),
        error_objects_mean: obj_err.map(|e| e.0),
        error_objects_max: obj_err.map(|e| e.1),
        gvs_rays_per_cpu_second: None,
        capped_cells: pvs.iter().filter(|p| p.stats.capped).count(),
    }
}

/// The `--missed` listing of one view of the first row, `name`: its wrong pixels, and the `top`
/// triangles with most of them.
fn print_missed(top: usize, name: &str, tris: &[[Vec3; 3]], at: &MeasuredView<'_>) {
    let view = at.view;
    let m = error::missed(at.buffer, at.first_pvs);
    let total: u64 = m.iter().map(|x| x.1).sum();
    println!("{name} cell {} view {}: {total} wrong pixels on {} triangles", at.cell, at.view_index, m.len());
    for &(t, px) in m.iter().take(top) {
        let Some(tri) = tris.get(t as usize) else {
            continue;
        };
        let centre = (tri[0] + tri[1] + tri[2]) / 3.0;
        let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize_or_zero();
        let to_eye = (view.eye - centre).normalize_or_zero();
        println!(
            "  triangle {t}: {px} px, {:.2} from the eye, |cos| {:.3}",
            (centre - view.eye).length(),
            n.dot(to_eye).abs()
        );
    }
}

fn print_table(r: &Report) {
    println!(
        "{}: {} triangles, {} cells, BVH {:.2} s, neighbour table {:.2} s, components and target groups {:.2} s; per cell averages; error over {} views of {}x{} at {}° ({} triangles have a coplanar twin; a pixel showing either is right when one of them is in the PVS)",
        r.scene,
        r.triangles,
        r.cells,
        r.bvh_build_seconds,
        r.neighbours_build_seconds,
        r.components_build_seconds,
        r.error_views,
        r.error_res,
        r.error_res,
        r.error_fov,
        r.twins
    );
    println!(
        "{:<34} {:>10} {:>9} {:>9} {:>10} {:>9} {:>9} {:>9} {:>9} {:>9} {:>8} {:>8} {:>9} {:>8} {:>11} {:>8}",
        "variant",
        "rays",
        "random",
        "point",
        "edge",
        "reverse",
        "silhou.",
        "probe",
        "target",
        "reuse",
        "seconds",
        "pvs",
        "err mean",
        "err max",
        "obj err",
        "Mray/cpu"
    );
    for row in &r.rows {
        let mean = row.error_mean.map_or("-".to_string(), |m| format!("{m:.1}"));
        let max = row.error_max.map_or("-".to_string(), |m| m.to_string());
        let obj = row
            .error_objects_mean
            .zip(row.error_objects_max)
            .map_or("-".to_string(), |(m, x)| format!("{m:.1}/{x}"));
        let rate = row.gvs_rays_per_cpu_second.map_or("-".to_string(), |r| format!("{:.2}", r / 1e6));
        println!(
            "{:<34} {:>10} {:>9} {:>9} {:>10} {:>9} {:>9} {:>9} {:>9} {:>9} {:>8.3} {:>8} {:>9} {:>8} {:>11} {:>8}",
            row.variant,
            row.rays,
            row.random,
            row.point,
            row.edge,
            row.reverse,
            row.silhouette,
            row.probe,
            row.target,
            row.reuse,
            row.seconds,
            row.pvs,
            mean,
            max,
            obj,
            rate
        );
    }
    for row in r.rows.iter().filter(|row| row.capped_cells > 0) {
        println!(
            "note: {}: {} of {} cells stopped at the ray cap ({} rays, --max-rays); their PVS may miss triangles",
            row.variant, row.capped_cells, row.cells, r.params.max_rays
        );
    }
    if r.error_rays > 0 {
        println!(
            "error rays: {} in {:.2} s on {} threads = {:.2} M rays/s per core",
            r.error_rays,
            r.error_seconds,
            r.threads,
            r.rays_per_second_per_core / 1e6
        );
        if let Some(c) = r.rays_per_cpu_second {
            println!(
                "error rays per CPU second (process CPU time, fair on a shared machine): {:.2} M",
                c / 1e6
            );
        }
    }
}

fn parse_vec(s: &str) -> anyhow::Result<Vec3> {
    let v = parse_floats(s)?;
    match v[..] {
        [x, y, z] => Ok(Vec3::new(x, y, z)),
        _ => bail!("`{s}`: expected dx,dy,dz"),
    }
}

fn parse_floats(s: &str) -> anyhow::Result<Vec<f32>> {
    s.split(',')
        .map(|t| {
            let x: f32 = t.trim().parse().with_context(|| format!("`{t}` in `{s}` is not a number"))?;
            if !x.is_finite() {
                bail!("`{t}` in `{s}` is not finite");
            }
            Ok(x)
        })
        .collect()
}

/// One `--cell` argument, parsed.
#[derive(Debug, Clone, Copy, PartialEq)]
enum CellSpec {
    /// `auto`: the generated scene's suggestion.
    Auto,
    /// `leaves`: a level's open leaves.
    Leaves,
    /// A grid of cubes of this side (positive).
    Grid(f32),
    /// One box `x0,y0,z0,x1,y1,z1`.
    Box(Vec3, Vec3),
}

/// Parses one `--cell` argument (errors name the flag).
fn parse_cell_spec(spec: &str) -> anyhow::Result<CellSpec> {
    Ok(match spec {
        "auto" => CellSpec::Auto,
        "leaves" => CellSpec::Leaves,
        _ => {
            let v = parse_floats(spec).with_context(|| format!("--cell {spec}"))?;
            match v[..] {
                [size] if size > 0.0 => CellSpec::Grid(size),
                [x0, y0, z0, x1, y1, z1] => CellSpec::Box(Vec3::new(x0, y0, z0), Vec3::new(x1, y1, z1)),
                _ => bail!("--cell {spec}: expected auto, leaves, a positive size or x0,y0,z0,x1,y1,z1"),
            }
        }
    })
}

/// The cells of one `--cell` argument.
fn cells_of(
    spec: &CellSpec,
    scene: &TriScene,
    level: Option<&sightline_formats::Level>,
) -> anyhow::Result<Vec<Cell>> {
    match *spec {
        CellSpec::Auto => {
            if scene.suggested.is_empty() {
                bail!("`--cell auto` needs a generated scene (gen:...); give a size, `leaves` or a box");
            }
            Ok(scene.suggested.clone())
        }
        CellSpec::Leaves => {
            let Some(level) = level else {
                bail!("`--cell leaves` needs a level input (.slvl or .bsp)");
            };
            Ok(scene::leaf_cells(level, 1.0))
        }
        CellSpec::Grid(size) => Ok(cells::grid(&scene.bounds(), size).context("--cell")?),
        CellSpec::Box(min, max) => Ok(vec![Cell::new(min, max)]),
    }
}

fn write_level(path: &Path, level: &sightline_formats::Level) -> anyhow::Result<()> {
    sightline_formats::slvl::validate(level)?;
    let bytes =
        sightline_formats::slvl::write(level, &sightline_formats::slvl::WriteOptions { compress: true });
    sightline_job::atomic::write_file_atomic(path, &bytes)?;
    Ok(())
}

/// CPU seconds this process has used (user + system), from `/proc/self/stat`; `None` elsewhere.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let rest = stat.rsplit_once(')')?.1;
    let f: Vec<&str> = rest.split_whitespace().collect();
    let utime: f64 = f.get(11)?.parse().ok()?;
    let stime: f64 = f.get(12)?.parse().ok()?;
    // Linux reports clock ticks; USER_HZ is 100 on every mainstream configuration.
    Some((utime + stime) / 100.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: Args,
    }

    fn args(line: &[&str]) -> Args {
        Cli::parse_from(std::iter::once("gvs").chain(line.iter().copied())).args
    }

    #[test]
    fn arguments_that_would_switch_part_of_the_work_off_are_errors() {
        for bad in [
            &["--fov", "0"][..],
            &["--fov", "180"],
            &["--fov", "NaN"],
            &["--res", "9000"],
            &["--eps", "NaN"],
            &["--eps", "0"],
            &["--disc", "1"],
            &["--adt", "inf"],
            &["--variant", "nope"],
            &["--compare", "--move", "1,NaN,0"],
            &["--max-depth", "0"],
            &["--cell", "0"],
            &["--cell", "1,2"],
            &["--cell", "1,inf,0,1,1,1"],
            &["--probe-rays", "4294967295"],
        ] {
            // Refused when parsed (the range of the flag) or when checked (what clap cannot say).
            let line = [&["gvs", "gen:spheres:10"][..], bad].concat();
            let refused = Cli::try_parse_from(line).map_or(true, |c| check(&c.args).is_err());
            assert!(refused, "{bad:?} accepted");
        }
        let ok = check(&args(&["gen:spheres:10", "--compare", "--move", "1,0,0", "--eps", "0.01"]));
        assert!(ok.is_ok_and(|c| c.variants.len() == Variant::ALL.len() && c.shift == Some(Vec3::X)));
    }
}
