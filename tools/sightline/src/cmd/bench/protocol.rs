//! The culling thesis' benchmark protocol (§7.7) on saved poses (`sightline bench --poses-file`,
//! `--save-poses`): per pose and backend, the culling time, the faces submitted, and how many of
//! the faces a full-resolution ray cast sees are among them; and the ray-casting backend's time
//! against its grid spacing.
//!
//! # Measures
//! - *Visible faces* of a pose: the faces hit by one primary ray per pixel of the 640 × 480 picture
//!   (the ray-casting backend's viewport; the picture `sightline trace` casts, faces one-sided), cast
//!   against a BVH over the world model's triangles ([`sightline_validate::trace`]).
//! - Per backend: the fastest and the median of [`Args::repeats`](super::Args::repeats) timed culls
//!   (one untimed first, same scratch; the fastest is the figure to compare on a busy machine,
//!   where culls of a few milliseconds are often preempted), the faces it submits, the visible faces among them, the visible faces
//!   it leaves out and the pixels those cover (0 for every conservative backend).
//! - The ray-casting backend casts every frame here (`--ray-always`), at `--ray-spacing`, and again
//!   at each spacing of [`SPACINGS`] (the thesis measured 196 → 50 → 23 → 14 ms for n = 5 … 20 at
//!   61 K triangles).
//!
//! # Saving poses
//! `--save-poses` draws `--frames` random poses (seed `--seed`, as the random-pose benchmark) and
//! keeps two: the one whose eye cluster's PVS has the fewest leaves (*occluded*) and the one with
//! the most (*open*), the first of equals. Only poses whose eye is in an open-air leaf with a
//! cluster are candidates (a sky leaf is open to the runtime but opaque to sight, and an eye in
//! water sees through a surface the picture stops at), unless no pose is such.

use std::time::Instant;

use anyhow::Context;
use serde_json::json;
use sightline_formats::level::Contents;
use sightline_runtime::backend::{Backend, pvs::Pvs, raycast::RayCast};
use sightline_runtime::{Camera, Scratch, Visible, World};
use sightline_validate::bsp::BspTree;
use sightline_validate::trace::frame::{Rays, cast};
use sightline_validate::trace::scene::LevelScene;

use super::poses_file::Pose;
use crate::outcome::Outcome;

/// Grid spacings (pixels between rays) the ray-casting backend is timed at.
pub const SPACINGS: [u32; 4] = [5, 10, 15, 20];
/// The picture of the visible faces: the ray-casting backend's default viewport.
const WIDTH: u32 = 640;
const HEIGHT: u32 = 480;

/// Leaves in the PVS of the eye's cluster (every open leaf when the eye has none, or no vis).
pub fn pvs_leaves(world: &World, cam: &Camera) -> u32 {
    let mut scratch = Scratch::new(world);
    Pvs::mark(world, world.leaf_at(cam.position), &mut scratch);
    scratch.stats.marked_leaves
}

/// The occluded and the open pose among `cams` (see the module docs).
pub fn pick(world: &World, cams: &[Camera]) -> Vec<Pose> {
    let open_air = |c: &&Camera| {
        let leaf = world.leaf_at(c.position);
        world.leaf_cluster(leaf).is_some() && world.leaf_contents(leaf) == Some(Contents::Empty)
    };
    let clustered: Vec<&Camera> = cams.iter().filter(open_air).collect();
    let pool: Vec<&Camera> = if clustered.is_empty() { cams.iter().collect() } else { clustered };
    let scored: Vec<(u32, &Camera)> = pool.iter().map(|&c| (pvs_leaves(world, c), c)).collect();
    let mut out = Vec::new();
    if let Some(&(n, c)) = scored.iter().min_by_key(|(n, _)| *n) {
        out.push(Pose {
            camera: *c,
            label: format!("occluded: {n} PVS leaves, fewest of {} poses", cams.len()),
        });
    }
    if let Some(&(n, c)) = scored.iter().rev().max_by_key(|(n, _)| *n) {
        out.push(Pose { camera: *c, label: format!("open: {n} PVS leaves, most of {} poses", cams.len()) });
    }
    out
}

/// One backend on one pose.
#[derive(Debug, Clone, serde::Serialize)]
struct Row {
    backend: String,
    /// Ray-casting only: its grid spacing and rays per frame.
    spacing: Option<u32>,
    rays: Option<u32>,
    /// Fastest of the timed culls: on a shared machine a cull longer than a scheduler slice is
    /// often preempted, and then the median counts other processes' time.
    ns_min: u64,
    ns_median: u64,
    faces_submitted: usize,
    visible_submitted: usize,
    missed_visible_faces: usize,
    missed_pixels: usize,
    conservative: bool,
}

/// The faces one full-resolution picture of `cam` hits: per face, the pixels showing it.
fn visible_pixels(scene: &LevelScene<'_>, cam: &Camera, faces: usize) -> anyhow::Result<Vec<u32>> {
    let aspect = f64::from(WIDTH) / f64::from(HEIGHT);
    let fov = 2.0 * ((f64::from(cam.fov_y).to_radians() * 0.5).tan() * aspect).atan();
    let camera = sightline_validate::trace::Camera {
        eye: cam.position.as_dvec3(),
        yaw: f64::from(cam.yaw),
        pitch: f64::from(cam.pitch),
        fov: fov.to_degrees(),
        width: WIDTH,
        height: HEIGHT,
    };
    let rays = Rays::new(&camera)?;
    let frame = cast(scene, scene.bvh(), None, &rays);
    let mut pixels = vec![0u32; faces];
    for h in frame.hits.iter().flatten() {
        if let Some(p) = pixels.get_mut(h.face as usize) {
            *p += 1;
        }
    }
    Ok(pixels)
}

/// Time `backend` on `cam` (`setup.repeats` times) and compare its faces with the picture's `pixels` per face.
fn measure(world: &World, backend: &dyn Backend, cam: &Camera, setup: &Setup<'_>, pixels: &[u32]) -> Row {
    let mut scratch = Scratch::new(world);
    let mut out = Visible::for_world(world);
    let view = cam.view().with_back_face_culling(setup.cull_back_faces);
    backend.cull(world, &view, &mut scratch, &mut out);
    let mut times: Vec<u64> = (0..setup.repeats)
        .map(|_| {
            let start = Instant::now();
            backend.cull(world, &view, &mut scratch, &mut out);
            start.elapsed().as_nanos() as u64
        })
        .collect();
    times.sort_unstable();
    let mut shown = vec![false; pixels.len()];
    for &f in &out.faces {
        if let Some(s) = shown.get_mut(f as usize) {
            *s = true;
        }
    }
    let (mut visible_submitted, mut missed_visible_faces, mut missed_pixels) = (0, 0, 0);
    for (&p, &s) in pixels.iter().zip(&shown) {
        match (p > 0, s) {
            (true, true) => visible_submitted += 1,
            (true, false) => {
                missed_visible_faces += 1;
                missed_pixels += p as usize;
            }
            _ => {}
        }
    }
    Row {
        backend: backend.name().to_string(),
        spacing: None,
        rays: (scratch.stats.rays > 0).then_some(scratch.stats.rays),
        ns_min: times.first().copied().unwrap_or(0),
        ns_median: times.get(times.len() / 2).copied().unwrap_or(0),
        faces_submitted: out.faces.len(),
        visible_submitted,
        missed_visible_faces,
        missed_pixels,
        conservative: backend.conservative(),
    }
}

/// What the protocol reads besides the poses.
#[derive(Debug)]
pub struct Setup<'a> {
    /// The level file (for the ray-cast picture's scene and the report).
    pub input: &'a std::path::Path,
    /// The loaded level.
    pub world: &'a World,
    /// The backends to time (the ray-casting one casting every frame).
    pub backends: &'a [&'a dyn Backend],
    /// Timed culls per backend and pose.
    pub repeats: usize,
    /// The ray-casting backend as the other rows run it (its spacing is swept besides).
    pub rays: RayCast,
    /// Leave out back faces in the walk (`--cull-back-faces`).
    pub cull_back_faces: bool,
    /// Print JSON instead of a table.
    pub json: bool,
}

/// Run the protocol on `poses` and print its report.
pub fn run(setup: &Setup<'_>, poses: &[Pose]) -> anyhow::Result<Outcome> {
    let file = || setup.input.display().to_string();
    let level = sightline_validate::load::load_level(setup.input, &crate::progress::Bars::new(true))?;
    let tree = BspTree::new(&level).with_context(file)?;
    let scene = LevelScene::new(&tree).with_context(file)?;
    let world = setup.world;
    let mut reports = Vec::new();
    for (i, pose) in poses.iter().enumerate() {
        let cam = &pose.camera;
        let pixels = visible_pixels(&scene, cam, world.num_faces())
            .with_context(|| format!("{}: pose {i}", file()))?;
        let rows: Vec<Row> = setup.backends.iter().map(|b| measure(world, *b, cam, setup, &pixels)).collect();
        let sweep: Vec<Row> = SPACINGS
            .iter()
            .map(|&n| {
                let rc = RayCast { spacing: n, ..setup.rays };
                Row { spacing: Some(n), ..measure(world, &rc, cam, setup, &pixels) }
            })
            .collect();
        reports.push((pose, pvs_leaves(world, cam), pixels.iter().filter(|&&p| p > 0).count(), rows, sweep));
    }
    if setup.json {
        let out = json!({
            "input": file(),
            "repeats": setup.repeats,
            "picture": [WIDTH, HEIGHT],
            "poses": reports.iter().enumerate().map(|(i, (pose, pvs, visible, rows, sweep))| json!({
                "index": i,
                "label": pose.label,
                "eye": pose.camera.position.to_array(),
                "yaw": pose.camera.yaw,
                "pitch": pose.camera.pitch,
                "pvs_leaves": pvs,
                "visible_faces": visible,
                "backends": rows,
                "raycast_spacing": sweep,
            })).collect::<Vec<_>>(),
        });
        println!("{}", serde_json::to_string_pretty(&out)?);
        return Ok(Outcome::Clean);
    }
    println!(
        "{}: {} saved poses; fastest and median of {} culls each; visible faces: hit by a {WIDTH} x {HEIGHT} ray cast",
        file(),
        poses.len(),
        setup.repeats
    );
    for (i, (pose, pvs, visible, rows, sweep)) in reports.iter().enumerate() {
        let c = &pose.camera;
        println!(
            "pose {i} ({}): eye {} {} {}, yaw {}, pitch {}; {pvs} PVS leaves, {visible} visible faces",
            if pose.label.is_empty() { "-" } else { &pose.label },
            c.position.x,
            c.position.y,
            c.position.z,
            c.yaw,
            c.pitch
        );
        println!(
            "  {:<12} {:>9} {:>9} {:>10} {:>12} {:>14} {:>13}",
            "backend", "min ms", "median ms", "submitted", "visible sub.", "missed visible", "missed pixels"
        );
        for r in rows.iter().chain(sweep) {
            let name = match r.spacing {
                Some(n) => format!("{} n={n}", r.backend),
                None => r.backend.clone(),
            };
            println!(
                "  {:<12} {:>9.4} {:>9.4} {:>10} {:>12} {:>14} {:>13}{}",
                name,
                r.ns_min as f64 / 1e6,
                r.ns_median as f64 / 1e6,
                r.faces_submitted,
                r.visible_submitted,
                r.missed_visible_faces,
                r.missed_pixels,
                if r.conservative { "" } else { "  (aggressive)" }
            );
        }
    }
    Ok(Outcome::Clean)
}
