//! `sightline bench`: time every runtime backend on deterministic random camera poses.
//!
//! Poses come from [`sightline_runtime::poses::random_cameras`] (SplitMix64 seeded by `--seed`):
//! a random open leaf, a random point in it, random yaw, pitch within ±60°, Quake's 90° horizontal
//! field of view at 4:3. Every pose is a new eye position, so the PVS backend decodes and marks a
//! row nearly every frame (its worst case; a real camera stays in one cluster for many frames).
//! Each backend runs all poses once to warm up, then once timed, one `Instant` pair per frame.
//! A second, *coherent* measurement turns the camera in place: after each of the first
//! `frames / 8` poses, seven more frames at the same eye, 5° further in yaw each (only those seven
//! are timed), as a real camera that stays in one spot for a while.
//! The GVS backend is measured when the level carries GVS cells (`sightline gvs ... -o`). The
//! ray-casting backend is aggressive (it may hide visible leaves): the table says so, and its
//! JSON report has `"conservative": false`.
//!
//! With `--poses-file` (or `--save-poses`, which picks and writes the poses first) the command runs
//! the culling thesis' protocol on saved poses instead ([`protocol`]; the file format is in
//! [`poses_file`]).

mod poses_file;
mod protocol;

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use clap::builder::RangedU64ValueParser;
use serde_json::json;
use sightline_runtime::backend::{self, Backend, pvs::Pvs, raycast::RayCast};
use sightline_runtime::walk;
use sightline_runtime::{Camera, Scratch, Visible, World, load, poses};

use crate::outcome::Outcome;

/// What `sightline bench` does: its line in `sightline --help` and the first line of its own help.
pub const ABOUT: &str = "Benchmark the runtime backends on random or saved camera poses";

/// Arguments of `sightline bench`.
#[derive(Debug, clap::Args)]
#[command(about = ABOUT)]
pub struct Args {
    /// Level (`.slvl`) or Quake map (`.bsp`; a PRT1 portal file beside it, found as `vis` finds
    /// it: `NAME.prt`, or for `NAME.vis.bsp` `NAME.vis.prt` then `NAME.prt`, gives the portal
    /// backend its portals).
    pub input: PathBuf,
    /// Camera poses (frames) per backend, 1 to 100000000; their timings are kept (about 500 bytes
    /// a frame), which must fit in memory.
    #[arg(long, default_value_t = 10_000, value_parser = RangedU64ValueParser::<usize>::new().range(1..=MAX_FRAMES))]
    pub frames: usize,
    /// Seed of the pose generator.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Only this backend (repeatable); default: every backend the level supports.
    #[arg(long = "backend")]
    pub backends: Vec<String>,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Drop the per-cluster PVS trees after loading, so the PVS backend decodes and marks a row
    /// per cluster change (what levels over the memory budget do).
    #[arg(long)]
    pub no_pvs_trees: bool,
    /// Ray-casting backend: pixels between two rays along each axis of its 640 × 480 viewport.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=640))]
    pub ray_spacing: u32,
    /// Ray-casting backend: cast rays every frame, never falling back to the PVS walk.
    #[arg(long)]
    pub ray_always: bool,
    /// Leave out back faces in the walk (`View::cull_back_faces`), as an engine drawing faces
    /// would.
    #[arg(long)]
    pub cull_back_faces: bool,
    /// Run the saved-poses protocol on the poses of FILE (lines `X Y Z YAW PITCH`, `#` comments)
    /// instead of random poses: per pose and backend, fastest and median culling time, faces
    /// submitted, and visible faces (hit by a 640 × 480 ray cast) submitted and missed; the
    /// ray-casting backend casts every frame and is also timed at spacings 5, 10, 15, 20.
    #[arg(long, value_name = "FILE", conflicts_with = "save_poses")]
    pub poses_file: Option<PathBuf>,
    /// Pick from `--frames` random poses (`--seed`) the one with the fewest PVS leaves (occluded)
    /// and the one with the most (open), write them to FILE as `--poses-file` reads it, then run
    /// the saved-poses protocol on them.
    #[arg(long, value_name = "FILE")]
    pub save_poses: Option<PathBuf>,
    /// Saved-poses protocol: timed culls per backend and pose (the fastest and the median are
    /// reported), 1 to 100000.
    #[arg(long, default_value_t = 101, value_parser = RangedU64ValueParser::<usize>::new().range(1..=100_000))]
    pub repeats: usize,
}

/// Most frames (`--frames`).
const MAX_FRAMES: u64 = 100_000_000;

/// Bytes held per frame while a backend is measured: its camera and view, its time, time per leaf
/// and the coherent camera's times (3 × 8), portals crossed (4), and the PVS backend's mark and
/// walk times and walk time per leaf (3 × 8).
const BYTES_PER_FRAME: u64 =
    (size_of::<Camera>() + size_of::<sightline_runtime::View>() + 3 * 8 + 4 + 3 * 8) as u64;

/// Timings and counts of one backend.
#[derive(Debug, Clone, serde::Serialize)]
struct Report {
    backend: &'static str,
    frames: usize,
    ns_per_frame_min: u64,
    ns_per_frame_median: u64,
    ns_per_frame_p99: u64,
    ns_per_frame_mean: f64,
    /// Leaves marked before the frustum: the PVS (or the leaves the portal search reached).
    pvs_leaves_avg: f64,
    /// Leaves output after the frustum.
    visible_leaves_avg: f64,
    visible_faces_avg: f64,
    /// Tree nodes and leaves popped by the frustum walk, per frame.
    nodes_visited_avg: f64,
    /// Box–frustum tests per frame (the plane mask skips planes a parent box is fully inside).
    box_tests_avg: f64,
    /// Median over frames of (frame time / that frame's PVS leaves).
    ns_per_pvs_leaf: f64,
    /// PVS backend only: median time of locating the eye and choosing its PVS (a lookup when the
    /// world keeps its per-cluster PVS trees, else decoding the row and marking up the tree).
    mark_ns_median: Option<u64>,
    /// PVS backend only: median time of the frustum walk alone.
    walk_ns_median: Option<u64>,
    /// PVS backend only: median over frames of (walk time / PVS leaves), comparable to the C
    /// reference's 68 ns (its traversal time over its PVS leaves).
    walk_ns_per_pvs_leaf: Option<f64>,
    /// Frames where the portal search hit its budget.
    truncated_frames: usize,
    /// Portal backend: portals crossed per frame, mean and 99th percentile (deterministic).
    portals_crossed_avg: f64,
    portals_crossed_p99: u32,
    /// Median ns per frame of the coherent camera (turning in place; see the module docs).
    coherent_ns_median: u64,
    /// False for a backend that may hide visible leaves (the ray-casting one): its counts are
    /// not comparable with a conservative backend's as a measure of culling quality.
    conservative: bool,
    /// Ray-casting backend: frames that cast rays (the others fell back to the PVS walk), and
    /// rays per such frame.
    ray_frames: usize,
    rays_per_frame: f64,
}

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<Outcome> {
    let need = args.frames as u64 * BYTES_PER_FRAME;
    crate::limits::fits_memory(&format!("--frames {}", args.frames), need, 1)?;
    // The poses file is read (and its errors reported) before the level is loaded.
    let saved = args.poses_file.as_deref().map(poses_file::read).transpose()?;
    if let Some(out) = &args.save_poses {
        crate::output::check(&[args.input.as_path()], &[out.as_path()])?;
    }
    // `load_path`'s errors name the file (and the portal file beside a `.bsp`).
    let mut world = load::load_path_with(&args.input, &crate::progress::Bars::new(true))?;
    if !world.has_vis() {
        eprintln!(
            "warning: {}: the level has no PVS (not vised): every cluster sees every other, so PVS culling hides nothing (run `sightline vis` on it)",
            args.input.display()
        );
    }
    if args.no_pvs_trees {
        world.drop_pvs_trees();
    }
    let cams = match &saved {
        Some(_) => Vec::new(),
        None => poses::random_cameras(&world, args.seed, args.frames),
    };
    anyhow::ensure!(
        saved.is_some() || !cams.is_empty(),
        "{}: no open leaf to put a camera in",
        args.input.display()
    );
    let unsupported: Vec<(&str, &str)> = backend::all()
        .iter()
        .filter(|b| !b.supports(&world))
        .map(|b| (b.name(), why_not(b.name())))
        .collect();
    let chosen: Vec<&dyn Backend> = if args.backends.is_empty() {
        backend::all().iter().copied().filter(|b| b.supports(&world)).collect()
    } else {
        args.backends
            .iter()
            .map(|name| {
                let b = backend::by_name(name).with_context(|| format!("unknown backend `{name}`"))?;
                anyhow::ensure!(
                    b.supports(&world),
                    "backend `{name}` cannot run on this level: {}",
                    why_not(name)
                );
                Ok(b)
            })
            .collect::<anyhow::Result<_>>()?
    };
    let protocol = saved.is_some() || args.save_poses.is_some();
    // The protocol measures ray casting itself: no falling back to the PVS walk.
    let rays =
        RayCast { spacing: args.ray_spacing, adaptive: !args.ray_always && !protocol, ..RayCast::DEFAULT };
    let chosen: Vec<&dyn Backend> =
        chosen.into_iter().map(|b| if b.name() == rays.name() { &rays as &dyn Backend } else { b }).collect();
    if protocol {
        let poses = match saved {
            Some(p) => p,
            None => save_poses(args, &world, &cams)?,
        };
        let setup = protocol::Setup {
            input: &args.input,
            world: &world,
            backends: &chosen,
            repeats: args.repeats,
            rays,
            cull_back_faces: args.cull_back_faces,
            json: args.json,
        };
        return protocol::run(&setup, &poses);
    }
    let reports: Vec<Report> =
        chosen.iter().map(|b| measure(&world, *b, &cams, args.cull_back_faces)).collect();
    if args.json {
        let out = json!({
            "input": args.input.display().to_string(),
            "frames": cams.len(),
            "seed": args.seed,
            "leaves": world.num_leaves(),
            "open_leaves": world.open_leaves().len(),
            "clusters": world.num_clusters(),
            "portals": world.num_portals(),
            "pvs_trees_in_memory": world.pvs_trees_in_memory(),
            "cull_back_faces": args.cull_back_faces,
            "gvs_cells": world.gvs_cells().map_or(0, |g| g.num_cells()),
            "not_run": unsupported.iter().map(|(b, why)| json!({ "backend": b, "reason": why })).collect::<Vec<_>>(),
            "camera": { "fov_y": cams[0].fov_y, "aspect": cams[0].aspect, "pitch_range": 60 },
            "backends": reports,
        });
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        print_table(&args.input, &world, cams.len(), args.seed, &reports);
        if args.backends.is_empty() {
            for (name, why) in &unsupported {
                println!("{name:<8} not run: {why}");
            }
        }
    }
    Ok(Outcome::Clean)
}

/// `--save-poses`: pick the occluded and the open pose of `cams` and write them.
fn save_poses(args: &Args, world: &World, cams: &[Camera]) -> anyhow::Result<Vec<poses_file::Pose>> {
    let path = args.save_poses.as_deref().context("--save-poses names no file")?;
    anyhow::ensure!(!cams.is_empty(), "{}: no open leaf to put a camera in", args.input.display());
    let poses = protocol::pick(world, cams);
    sightline_job::atomic::write_file_atomic(path, poses_file::write(&poses).as_bytes())
        .with_context(|| format!("{}: cannot write the poses file", path.display()))?;
    Ok(poses)
}

/// Why a backend does not support a level.
fn why_not(name: &str) -> &'static str {
    match name {
        "portal" => {
            "the level has no portals (a .bsp takes them from the .prt beside it; a .slvl has them when compiled \
             from a map that does not leak)"
        }
        "gvs" => "the level has no GVS cells (write them with `sightline gvs LEVEL.slvl -o OUT.slvl`)",
        _ => "not supported by this level",
    }
}

fn measure(world: &World, backend: &dyn Backend, cams: &[Camera], cull: bool) -> Report {
    let mut scratch = Scratch::new(world);
    let mut out = Visible::for_world(world);
    let views: Vec<_> = cams.iter().map(|c| c.view().with_back_face_culling(cull)).collect();
    for view in &views {
        backend.cull(world, view, &mut scratch, &mut out);
    }
    let mut times = Vec::with_capacity(views.len());
    let mut per_leaf = Vec::with_capacity(views.len());
    let (mut marked, mut leaves, mut faces, mut truncated) = (0u64, 0u64, 0u64, 0usize);
    let (mut visited, mut tests) = (0u64, 0u64);
    let mut crossed = Vec::with_capacity(views.len());
    let (mut ray_frames, mut rays) = (0usize, 0u64);
    for view in &views {
        let start = Instant::now();
        backend.cull(world, view, &mut scratch, &mut out);
        let ns = start.elapsed().as_nanos() as u64;
        times.push(ns);
        per_leaf.push(ns as f64 / f64::from(scratch.stats.marked_leaves.max(1)));
        marked += u64::from(scratch.stats.marked_leaves);
        leaves += out.leaves.len() as u64;
        faces += out.faces.len() as u64;
        truncated += usize::from(scratch.stats.truncated);
        visited += u64::from(scratch.stats.nodes_visited);
        tests += u64::from(scratch.stats.box_tests);
        crossed.push(scratch.stats.portals_crossed);
        ray_frames += usize::from(scratch.stats.rays > 0);
        rays += u64::from(scratch.stats.rays);
    }
    let portals_crossed_avg = crossed.iter().map(|&c| f64::from(c)).sum::<f64>() / views.len().max(1) as f64;
    crossed.sort_unstable();
    let portals_crossed_p99 =
        crossed.get(((crossed.len().saturating_sub(1)) as f64 * 0.99).round() as usize).copied().unwrap_or(0);
    let n = views.len() as f64;
    let mean = times.iter().sum::<u64>() as f64 / n;
    times.sort_unstable();
    let pick = |q: f64| times.get(((times.len() - 1) as f64 * q).round() as usize).copied().unwrap_or(0);
    let pvs_avg = marked as f64 / n;
    let (mark_ns, walk_ns, walk_per_leaf) =
        if backend.name() == "pvs" { phases(world, &views) } else { (None, None, None) };
    let coherent_ns_median = coherent(world, backend, cams, cull);
    Report {
        backend: backend.name(),
        frames: views.len(),
        ns_per_frame_min: pick(0.0),
        ns_per_frame_median: pick(0.5),
        ns_per_frame_p99: pick(0.99),
        ns_per_frame_mean: mean,
        pvs_leaves_avg: pvs_avg,
        visible_leaves_avg: leaves as f64 / n,
        visible_faces_avg: faces as f64 / n,
        nodes_visited_avg: visited as f64 / n,
        box_tests_avg: tests as f64 / n,
        ns_per_pvs_leaf: median(&mut per_leaf),
        mark_ns_median: mark_ns,
        walk_ns_median: walk_ns,
        walk_ns_per_pvs_leaf: walk_per_leaf,
        truncated_frames: truncated,
        coherent_ns_median,
        portals_crossed_avg,
        portals_crossed_p99,
        conservative: backend.conservative(),
        ray_frames,
        rays_per_frame: rays as f64 / ray_frames.max(1) as f64,
    }
}

/// Median ns per frame of a camera turning in place (see the module docs).
fn coherent(world: &World, backend: &dyn Backend, cams: &[Camera], cull: bool) -> u64 {
    let mut scratch = Scratch::new(world);
    let mut out = Visible::for_world(world);
    let mut times = Vec::new();
    for cam in cams.iter().take(cams.len().div_ceil(8)) {
        backend.cull(world, &cam.view().with_back_face_culling(cull), &mut scratch, &mut out);
        for k in 1..8 {
            let view = Camera { yaw: cam.yaw + 5.0 * k as f32, ..*cam }.view().with_back_face_culling(cull);
            let start = Instant::now();
            backend.cull(world, &view, &mut scratch, &mut out);
            times.push(start.elapsed().as_nanos() as f64);
        }
    }
    median(&mut times) as u64
}

/// Median of a sample (0 for none).
fn median(values: &mut [f64]) -> f64 {
    values.sort_unstable_by(f64::total_cmp);
    values.get(values.len() / 2).copied().unwrap_or(0.0)
}

/// Medians of the PVS backend's two phases (locate + decode + mark, then the walk) and of the
/// walk time per PVS leaf.
fn phases(world: &World, views: &[sightline_runtime::View]) -> (Option<u64>, Option<u64>, Option<f64>) {
    let mut scratch = Scratch::new(world);
    let mut out = Visible::for_world(world);
    let (mut mark, mut walk, mut per_leaf) = (Vec::new(), Vec::new(), Vec::new());
    for view in views {
        let t0 = Instant::now();
        let leaf = world.leaf_at(view.eye);
        let marks = Pvs::mark(world, leaf, &mut scratch);
        let marked = scratch.stats.marked_leaves;
        let t1 = Instant::now();
        walk::walk(world, view, marks, &mut scratch, &mut out);
        let t2 = Instant::now();
        mark.push((t1 - t0).as_nanos() as f64);
        walk.push((t2 - t1).as_nanos() as f64);
        per_leaf.push((t2 - t1).as_nanos() as f64 / f64::from(marked.max(1)));
    }
    (Some(median(&mut mark) as u64), Some(median(&mut walk) as u64), Some(median(&mut per_leaf)))
}

fn print_table(input: &std::path::Path, world: &World, frames: usize, seed: u64, reports: &[Report]) {
    println!(
        "{}: {} leaves ({} open), {} clusters, {} portals; {frames} random poses, seed {seed}",
        input.display(),
        world.num_leaves(),
        world.open_leaves().len(),
        world.num_clusters(),
        world.num_portals()
    );
    println!(
        "{:<8} {:>9} {:>9} {:>9} {:>10} {:>11} {:>10} {:>10} {:>10}",
        "backend",
        "min ns",
        "median ns",
        "p99 ns",
        "PVS leaves",
        "after frus.",
        "faces",
        "ns/PVS lf",
        "walk ns/lf"
    );
    for r in reports {
        let walk = r.walk_ns_per_pvs_leaf.map_or_else(|| "-".to_string(), |w| format!("{w:.1}"));
        // GVS cells are not leaves: no PVS leaves to divide by.
        let per_leaf =
            if r.pvs_leaves_avg > 0.0 { format!("{:.1}", r.ns_per_pvs_leaf) } else { "-".to_string() };
        println!(
            "{:<8} {:>9} {:>9} {:>9} {:>10.1} {:>11.1} {:>10.1} {:>10} {:>10}",
            r.backend,
            r.ns_per_frame_min,
            r.ns_per_frame_median,
            r.ns_per_frame_p99,
            r.pvs_leaves_avg,
            r.visible_leaves_avg,
            r.visible_faces_avg,
            per_leaf,
            walk
        );
        if let (Some(m), Some(w)) = (r.mark_ns_median, r.walk_ns_median) {
            let how = if world.pvs_trees_in_memory() {
                "locate + PVS tree lookup"
            } else {
                "locate + decode + mark"
            };
            println!("         phases (medians): {how} {m} ns, walk {w} ns");
        }
        println!("         coherent camera (turning in place): median {} ns", r.coherent_ns_median);
        println!(
            "         walk: {:.1} nodes and leaves visited, {:.1} box tests per frame",
            r.nodes_visited_avg, r.box_tests_avg
        );
        if r.backend == "portal" {
            println!(
                "         portals crossed per frame: mean {:.1}, p99 {}",
                r.portals_crossed_avg, r.portals_crossed_p99
            );
        }
        if r.truncated_frames > 0 {
            println!("         {} frames hit the portal search budget", r.truncated_frames);
        }
        if !r.conservative {
            println!(
                "         AGGRESSIVE, not conservative: may hide visible leaves; {} of {} frames cast {:.0} rays, the others fell back to the PVS walk",
                r.ray_frames, r.frames, r.rays_per_frame
            );
        }
    }
}
