//! `sightline trace`: primary rays through a level, against the whole world's BVH and against a
//! BVH over only the eye cluster's PVS set, gated pixel by pixel (see
//! [`sightline_validate::trace`]). Exit 1 when a pixel differs other than by a tie: the PVS hides
//! a visible surface.
//!
//! Cameras: `--view X,Y,Z` with `--look YAW,PITCH`, or `--pose player_start` (the first
//! `info_player_start`, 22 units up as Quake's eye, its `angle` as yaw), or `--poses N` random
//! poses from the runtime's [`sightline_runtime::poses`] (seeded by `--seed`; several poses in one
//! cluster reuse its cached set; a pose whose eye the trace's tree puts in a sky or solid leaf, such
//! as a sky leaf, open to the runtime but opaque to sight, is skipped with a note).

use std::ops::Bound::Excluded;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, bail};
use clap::builder::RangedU64ValueParser;
use glam::DVec3;
use serde_json::json;

use sightline_validate::bsp::BspTree;
use sightline_validate::trace::cells::CellCache;
use sightline_validate::trace::frame::{Frame, picture};
use sightline_validate::trace::scene::LevelScene;
use sightline_validate::trace::{Camera, TraceError, trace_camera};
use sightline_validate::{load, pvs};

use super::render::{pair, size, vec3};
use crate::limits;
use crate::outcome::Outcome;

/// What `sightline trace` does: its line in `sightline --help` and the first line of its own help.
pub const ABOUT: &str =
    "Ray-trace a level against the whole world and against the eye's PVS set; exit 1 if they differ";

/// Arguments of `sightline trace`.
#[derive(Debug, clap::Args)]
#[command(about = ABOUT)]
pub struct Args {
    /// A Quake-family `.bsp` or a Sightline `.slvl`.
    pub input: PathBuf,
    /// Output PNG of the (whole-scene) picture; with several poses `NAME-<i>.png` each.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Eye position `x,y,z`.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub view: Option<String>,
    /// View angles `yaw,pitch` in degrees (yaw from +x towards +y, pitch positive up), with `--view`.
    #[arg(long, value_name = "YAW,PITCH", allow_hyphen_values = true)]
    pub look: Option<String>,
    /// A named pose: `player_start` (the first `info_player_start`, 22 units up, its `angle`).
    #[arg(long, value_name = "NAME")]
    pub pose: Option<String>,
    /// This many random poses (the runtime's `poses`, as `sightline bench`), 1 to 100000.
    #[arg(long, value_parser = RangedU64ValueParser::<usize>::new().range(1..=100_000))]
    pub poses: Option<usize>,
    /// Seed of the random poses.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Horizontal field of view in degrees, in (0, 179).
    #[arg(long, default_value_t = 90.0, value_parser = limits::float_in::<f64>((Excluded(0.0), Excluded(179.0)), "a field of view in degrees"))]
    pub fov: f64,
    /// Image size `WxH`, each side 1 to 8192.
    #[arg(long, value_name = "WxH", default_value = "320x240", value_parser = size)]
    pub size: (u32, u32),
    /// Also cull each pose with the runtime's PVS backend and its ray-casting backend (one ray per
    /// N × N pixels of this picture, never falling back) and count the pixels whose face each
    /// leaves out: 0 for the PVS walk (conservative), the ray-casting backend's misses otherwise.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=8192))]
    pub raycast_spacing: Option<u32>,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

/// Bytes per pixel while a camera is traced: its ray (12), two frames' hits (2 × 12) and their
/// unmapped hits (2 × 8), the picture (3) and the PNG's rows (at most 8).
const BYTES_PER_PIXEL: u64 = 64;

/// Quake's eye height above the player's origin.
const EYE_HEIGHT: f64 = 22.0;

/// The cameras the arguments name.
fn cameras(
    args: &Args,
    view: Option<DVec3>,
    look: (f64, f64),
    entities: &str,
) -> anyhow::Result<Vec<Camera>> {
    let (width, height) = args.size;
    let cam = |eye: DVec3, yaw: f64, pitch: f64| Camera { eye, yaw, pitch, fov: args.fov, width, height };
    let file = args.input.display();
    match (view, &args.pose, args.poses) {
        (Some(eye), None, None) => Ok(vec![cam(eye, look.0, look.1)]),
        (None, Some(name), None) => {
            if name != "player_start" {
                bail!("--pose `{name}`: the only named pose is `player_start`");
            }
            let ents =
                sightline_formats::entities::parse(entities).with_context(|| format!("{file}: entities"))?;
            let start = ents
                .iter()
                .find(|e| e.classname() == "info_player_start")
                .with_context(|| format!("{file}: no info_player_start"))?;
            let o = start
                .origin()
                .with_context(|| format!("{file}: info_player_start has no origin"))?
                .with_context(|| format!("{file}: info_player_start"))?;
            let yaw = start.get("angle").and_then(|a| a.trim().parse::<f64>().ok()).filter(|a| a.is_finite());
            Ok(vec![cam(DVec3::from(o.map(f64::from)) + DVec3::Z * EYE_HEIGHT, yaw.unwrap_or(0.0), 0.0)])
        }
        (None, None, Some(n)) => {
            let world = sightline_runtime::load::load_path(&args.input)?;
            let cams = sightline_runtime::poses::random_cameras(&world, args.seed, n);
            anyhow::ensure!(!cams.is_empty(), "{file}: no open leaf to put a camera in");
            Ok(cams
                .iter()
                .map(|c| cam(c.position.as_dvec3(), f64::from(c.yaw), f64::from(c.pitch)))
                .collect())
        }
        _ => bail!("{file}: give exactly one of --view, --pose, --poses"),
    }
}

/// The PNG of pose `i` of `n`.
fn png_path(out: &Path, i: usize, n: usize) -> PathBuf {
    if n == 1 {
        return out.to_path_buf();
    }
    let stem = out.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    out.with_file_name(format!("{stem}-{i}.png"))
}

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<Outcome> {
    let (w, h) = args.size;
    // Every number first, then the memory, then the files: all before any work.
    let view = args.view.as_deref().map(|s| vec3(s, "--view")).transpose()?;
    let look = args.look.as_deref().map(|s| pair(s, ",", "--look")).transpose()?.unwrap_or((0.0, 0.0));
    limits::fits_memory(
        &format!("a trace of --size {w}x{h}"),
        u64::from(w) * u64::from(h) * BYTES_PER_PIXEL,
        1,
    )?;
    if let Some(out) = &args.output {
        crate::output::check(&[args.input.as_path()], &[out.as_path()])?;
    }
    let level = load::load_level(&args.input, &crate::progress::Bars::new(true))?;
    let file = || args.input.display().to_string();
    let cams = cameras(args, view, look, &level.entities)?;
    let tree = BspTree::new(&level).with_context(file)?;
    let matrix = pvs::level_pvs(&level).with_context(file)?;
    let scene = LevelScene::new(&tree).with_context(file)?;
    let mut cache = CellCache::default();
    let mut outcome = Outcome::Clean;
    let (mut rays, mut full_s, mut pvs_s) = (0usize, 0f64, 0f64);
    let (mut poses, mut skipped) = (Vec::new(), 0usize);
    let world = match args.raycast_spacing {
        Some(_) => Some(sightline_runtime::load::load_path(&args.input)?),
        None => None,
    };
    // Start the worker threads before the first timed cast, so that it does not pay for them.
    rayon::broadcast(|_| ());
    for (i, cam) in cams.iter().enumerate() {
        let t = match trace_camera(&scene, &matrix, &mut cache, cam) {
            Ok(t) => t,
            // A random pose in a sky leaf (open to the runtime, opaque to sight) or on a boundary the
            // two trees round differently is skipped.
            Err(e @ TraceError::Camera(_)) if args.poses.is_some() => {
                eprintln!("{}: pose {i} skipped: {e}", file());
                skipped += 1;
                continue;
            }
            Err(e) => return Err(e).with_context(|| format!("{}: pose {i}", file())),
        };
        rays += t.rays.len();
        full_s += t.full.time.as_secs_f64();
        pvs_s += t.pvs.time.as_secs_f64();
        if !t.gate.passed() {
            outcome = Outcome::Finding;
        }
        if let Some(out) = &args.output {
            let path = png_path(out, i, cams.len());
            picture(&scene, &t.rays, &t.full).save(&path)?;
        }
        let speedup = t.full.time.as_secs_f64() / t.pvs.time.as_secs_f64().max(1e-9);
        if !args.json {
            println!(
                "pose {i}: eye cluster {}, PVS set {} of {} triangles ({} faces), full {:.2} Mrays/s, PVS {:.2} Mrays/s, speed-up {speedup:.2}x, set {} ({:.2} ms, {} KiB); {} same, {} ties, {} grazes, {} differ",
                t.eye_cluster,
                t.set.triangles.len(),
                scene.triangles().len(),
                t.set.faces,
                t.full.mrays_per_s(),
                t.pvs.mrays_per_s(),
                if t.cached { "cached" } else { "built" },
                t.set.build.as_secs_f64() * 1e3,
                t.set.heap_bytes() / 1024,
                t.gate.same,
                t.gate.ties,
                t.gate.grazes,
                t.gate.mismatches,
            );
        }
        for m in &t.gate.listed {
            eprintln!("{}: pose {i}, eye cluster {}: {m}", file(), t.eye_cluster);
        }
        let culled = match (&world, args.raycast_spacing) {
            (Some(world), Some(spacing)) => Some(culling(world, cam, spacing, &t.full)),
            _ => None,
        };
        if let Some(c) = &culled {
            if c.pvs_missed > 0 {
                outcome = Outcome::Finding;
            }
            if !args.json {
                println!(
                    "pose {i}: PVS walk {} faces in {:.3} ms, {} pixels missed; ray-cast culling (spacing {}, aggressive) {} faces in {:.3} ms, {} pixels missed",
                    c.pvs_faces,
                    c.pvs_ms,
                    c.pvs_missed,
                    args.raycast_spacing.unwrap_or(0),
                    c.ray_faces,
                    c.ray_ms,
                    c.ray_missed
                );
            }
        }
        poses.push(json!({
            "culling": culled.as_ref().map(|c| json!({
                "pvs_faces": c.pvs_faces,
                "pvs_ms": c.pvs_ms,
                "pvs_missed_pixels": c.pvs_missed,
                "raycast_faces": c.ray_faces,
                "raycast_ms": c.ray_ms,
                "raycast_missed_pixels": c.ray_missed,
            })),
            "eye": t.rays.camera.eye.to_array(),
            "yaw": cam.yaw,
            "pitch": cam.pitch,
            "eye_leaf": t.eye_leaf,
            "eye_cluster": t.eye_cluster,
            "full_mrays_per_s": t.full.mrays_per_s(),
            "pvs_mrays_per_s": t.pvs.mrays_per_s(),
            "speedup": speedup,
            "set_triangles": t.set.triangles.len(),
            "set_faces": t.set.faces,
            "set_build_ms": t.set.build.as_secs_f64() * 1e3,
            "set_bytes": t.set.heap_bytes(),
            "set_cached": t.cached,
            "same": t.gate.same,
            "ties": t.gate.ties,
            "grazes": t.gate.grazes,
            "mismatches": t.gate.mismatches,
            "listed": t.gate.listed.iter().map(|m| m.to_string()).collect::<Vec<_>>(),
        }));
    }
    let (full, reduced) = (rays as f64 / full_s.max(1e-9) / 1e6, rays as f64 / pvs_s.max(1e-9) / 1e6);
    if args.json {
        let report = json!({
            "input": file(),
            "width": w,
            "height": h,
            "threads": rayon::current_num_threads(),
            "scene_triangles": scene.triangles().len(),
            "scene_build_ms": scene.build_time().as_secs_f64() * 1e3,
            "scene_bytes": scene.bvh().heap_bytes(),
            "clusters_built": cache.len(),
            "full_mrays_per_s": full,
            "pvs_mrays_per_s": reduced,
            "speedup": full_s / pvs_s.max(1e-9),
            "passed": outcome == Outcome::Clean,
            "poses_skipped": skipped,
            "poses": poses,
        });
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!(
            "{} poses ({skipped} skipped), {} clusters built; whole scene {} triangles (BVH {:.1} ms, {} KiB): full {full:.2} Mrays/s, PVS {reduced:.2} Mrays/s, speed-up {:.2}x; gate {}",
            cams.len() - skipped,
            cache.len(),
            scene.triangles().len(),
            scene.build_time().as_secs_f64() * 1e3,
            scene.bvh().heap_bytes() / 1024,
            full_s / pvs_s.max(1e-9),
            if outcome == Outcome::Clean { "passed" } else { "FAILED: the PVS hides visible surfaces" },
        );
    }
    Ok(outcome)
}

/// The runtime's PVS backend and ray-casting backend on one pose, against the traced picture.
struct Culled {
    pvs_faces: usize,
    pvs_ms: f64,
    pvs_missed: usize,
    ray_faces: usize,
    ray_ms: f64,
    ray_missed: usize,
}

/// Cull `cam` (its picture's optics, near plane 0.01) with both backends and count the pixels of
/// `full` whose face each output leaves out.
fn culling(world: &sightline_runtime::World, cam: &Camera, spacing: u32, full: &Frame) -> Culled {
    use sightline_runtime::backend::raycast::RayCast;
    use sightline_runtime::backend::{Backend, pvs::Pvs};
    let aspect = f64::from(cam.width) / f64::from(cam.height);
    let fov_y = 2.0 * ((cam.fov.to_radians() * 0.5).tan() / aspect).atan();
    let rc = sightline_runtime::Camera {
        position: cam.eye.as_vec3(),
        yaw: cam.yaw as f32,
        pitch: cam.pitch as f32,
        roll: 0.0,
        fov_y: fov_y.to_degrees() as f32,
        aspect: aspect as f32,
        near: 0.01,
        far: 65536.0,
    };
    let view = rc.view();
    let rays = RayCast { spacing, width: cam.width, height: cam.height, adaptive: false, ..RayCast::DEFAULT };
    let mut scratch = sightline_runtime::Scratch::new(world);
    let mut out = sightline_runtime::Visible::for_world(world);
    let mut run = |b: &dyn Backend| {
        b.cull(world, &view, &mut scratch, &mut out);
        let start = Instant::now();
        b.cull(world, &view, &mut scratch, &mut out);
        let ms = start.elapsed().as_secs_f64() * 1e3;
        let mut shown = vec![false; world.num_faces()];
        for &f in &out.faces {
            if let Some(s) = shown.get_mut(f as usize) {
                *s = true;
            }
        }
        let missed = full
            .hits
            .iter()
            .flatten()
            .filter(|h| !shown.get(h.face as usize).copied().unwrap_or(false))
            .count();
        (out.faces.len(), ms, missed)
    };
    let (pvs_faces, pvs_ms, pvs_missed) = run(&Pvs);
    let (ray_faces, ray_ms, ray_missed) = run(&rays);
    Culled { pvs_faces, pvs_ms, pvs_missed, ray_faces, ray_ms, ray_missed }
}
