//! `sightline trace`: primary rays through a level or a mesh, against the whole scene's BVH and
//! against a BVH over only the eye's visible set, gated pixel by pixel (see
//! [`sightline_validate::trace`]). On a level the set is the eye cluster's PVS set; on a mesh
//! (`.obj`, `gen:<kind>:<size>`) it is the GVS set of the grid cell containing the eye. Exit 1
//! when a pixel differs other than by a tie or a graze: the set hides a visible surface (on a
//! mesh, GVS's sampling missed it).
//!
//! Cameras: `--view X,Y,Z` with `--look YAW,PITCH`, or `--pose player_start` (levels: the first
//! `info_player_start`, 22 units up as Quake's eye, its `angle` as yaw), or `--poses N` random
//! poses (levels: the runtime's [`sightline_runtime::poses`]; meshes: open points of the scene, on
//! the city's streets at eye height), seeded by `--seed`; several poses in one cell reuse its
//! cached set; a generated pose the trace cannot use (a level's sky leaf, open to the runtime but
//! opaque to sight; a mesh eye outside the grid) is skipped with a note.
//!
//! Walkthroughs: `--walk N` (a random walk of N steps from `--view`, from `player_start` on a
//! level, from a random open pose on a mesh) or `--path "x,y,z;x,y,z;..."` (its points, or N steps
//! spread along it with `--walk N`); per step the cell change, the visible-set time, the BVH
//! rebuild time and both render times, as a table or in JSON.
//!
//! `--shadows` (levels): shadow rays to the level's point lights, every light in the full mode, the
//! light list of the hit point's cluster in the PVS mode ([`sightline_validate::trace::shadow`]).

use std::ops::Bound::{Excluded, Unbounded};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use anyhow::{Context, bail};
use clap::builder::RangedU64ValueParser;
use glam::DVec3;
use serde_json::{Value, json};

use sightline_gvs::scenegen::{self, Kind};
use sightline_validate::bsp::BspTree;
use sightline_validate::pvs::BitMatrix;
use sightline_validate::render::image::Image;
use sightline_validate::trace::cells::CellCache;
use sightline_validate::trace::frame::{Frame, Rays, picture};
use sightline_validate::trace::mesh::{MeshCellSet, MeshCells, MeshScene, trace_mesh_camera};
use sightline_validate::trace::scene::LevelScene;
use sightline_validate::trace::shadow::{self, Light, LightLists, Lit};
use sightline_validate::trace::walk::{self, Step};
use sightline_validate::trace::{Camera, Surfaces, TraceError, trace_camera};
use sightline_validate::{load, pvs};

use super::render::{pair, size, vec3};
use crate::limits;
use crate::outcome::Outcome;

/// What `sightline trace` does: its line in `sightline --help` and the first line of its own help.
pub const ABOUT: &str = "Ray-trace a level or mesh against the whole scene and against the eye's visible set; exit 1 if they differ";

/// Arguments of `sightline trace`.
#[derive(Debug, clap::Args)]
#[command(about = ABOUT)]
pub struct Args {
    /// A Quake-family `.bsp`, a Sightline `.slvl`, a `.obj` mesh or `gen:<city|spheres|mixed|mesh>:<size>`.
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
    /// A named pose of a level: `player_start` (the first `info_player_start`, 22 units up, its
    /// `angle`).
    #[arg(long, value_name = "NAME")]
    pub pose: Option<String>,
    /// This many random poses (a level's: the runtime's `poses`, as `sightline bench`; a mesh's:
    /// open points, on the city's streets at eye height), 1 to 100000.
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
    /// A walkthrough of N steps, 1 to 100000: a random walk, or N steps spread along `--path`.
    #[arg(long, value_name = "N", value_parser = RangedU64ValueParser::<usize>::new().range(1..=100_000))]
    pub walk: Option<usize>,
    /// A walkthrough through these points `x,y,z;x,y,z;...` (each step faces the next).
    #[arg(long, value_name = "X,Y,Z;...", allow_hyphen_values = true)]
    pub path: Option<String>,
    /// Step of the random walk in world units (default 32 on a level, half a cell on a mesh).
    #[arg(long, value_name = "LEN", value_parser = limits::float_in::<f64>((Excluded(0.0), Unbounded), "a length"))]
    pub step: Option<f64>,
    /// Meshes: side of the grid's cubic view cells (default half a block, 5, for `gen:city`,
    /// else a sixteenth of the bounds' largest side).
    #[arg(long, value_name = "SIZE", value_parser = limits::float_in::<f32>((Excluded(0.0), Unbounded), "a cell size"))]
    pub cell: Option<f32>,
    /// Meshes: make every new cell's set by a fresh GVS run (default: a walk's next cell updates
    /// the set of the cell it comes from, `sightline_gvs::update`).
    #[arg(long)]
    pub fresh_gvs: bool,
    /// Seed of a generated scene.
    #[arg(long, default_value_t = 1)]
    pub scene_seed: u64,
    /// Levels: light every hit pixel by the level's point lights (`light*` entities) with shadow
    /// rays against the whole scene, trying every light (full mode) or the light list of the hit
    /// point's cluster (PVS mode); `-o` writes the lit picture. The gate stays on primary rays.
    #[arg(long)]
    pub shadows: bool,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

/// Bytes per pixel while a camera is traced: its ray (12), two frames' hits (2 × 12) and their
/// unmapped hits (2 × 8), the picture (3) and the PNG's rows (at most 8).
const BYTES_PER_PIXEL: u64 = 64;

/// Quake's eye height above the player's origin.
const EYE_HEIGHT: f64 = 22.0;

/// The random walk's default step on a level, in world units (a quarter of a small room).
const LEVEL_STEP: f64 = 32.0;

/// Most points `--path` may name.
const MAX_PATH_POINTS: usize = 100_000;

/// The numbers of the arguments, parsed before any work.
#[derive(Debug, Clone, PartialEq)]
struct Parsed {
    view: Option<DVec3>,
    look: (f64, f64),
    path: Option<Vec<DVec3>>,
}

impl Parsed {
    fn of(args: &Args) -> anyhow::Result<Parsed> {
        Ok(Parsed {
            view: args.view.as_deref().map(|s| vec3(s, "--view")).transpose()?,
            look: args.look.as_deref().map(|s| pair(s, ",", "--look")).transpose()?.unwrap_or((0.0, 0.0)),
            path: args.path.as_deref().map(parse_path).transpose()?,
        })
    }

    /// True when the cameras are the steps of a walkthrough.
    fn walks(&self, args: &Args) -> bool {
        self.path.is_some() || args.walk.is_some()
    }
}

/// Parse `--path`: points `x,y,z` separated by `;` (a `;` after the last point is allowed), 1 to
/// [`MAX_PATH_POINTS`] of them.
fn parse_path(s: &str) -> anyhow::Result<Vec<DVec3>> {
    let parts: Vec<&str> = s.split(';').collect();
    let parts = match parts.split_last() {
        Some((last, rest)) if last.trim().is_empty() => rest,
        _ => &parts[..],
    };
    if parts.is_empty() {
        bail!("--path `{s}`: no points; expected x,y,z;x,y,z;...");
    }
    if parts.len() > MAX_PATH_POINTS {
        bail!("--path: {} points, at most {MAX_PATH_POINTS}", parts.len());
    }
    parts.iter().enumerate().map(|(i, p)| vec3(p, &format!("--path point {}", i + 1))).collect()
}

/// A camera of the arguments' optics at `eye`.
fn camera(args: &Args, eye: DVec3, yaw: f64, pitch: f64) -> Camera {
    let (width, height) = args.size;
    Camera { eye, yaw, pitch, fov: args.fov, width, height }
}

/// The steps of the walkthrough the arguments ask for (`None`: not a walkthrough): `--path`'s,
/// or a random walk over `bvh` of `step` units from `--view` or from `start()`.
fn walk_steps(
    args: &Args,
    p: &Parsed,
    bvh: &sightline_raycast::Bvh,
    step: f64,
    start: impl FnOnce() -> anyhow::Result<(DVec3, f64)>,
) -> anyhow::Result<Option<Vec<Step>>> {
    if let Some(points) = &p.path {
        return Ok(Some(walk::polyline(points, args.walk)));
    }
    let Some(n) = args.walk else { return Ok(None) };
    let (eye, yaw) = match p.view {
        Some(eye) => (eye, p.look.0),
        None => start()?,
    };
    Ok(Some(walk::random_walk(bvh, eye, yaw, n, step, args.seed)))
}

/// Refuse camera flags that do not go together (`level`: the input is a level), before any work.
fn check_cameras(args: &Args, p: &Parsed, level: bool) -> anyhow::Result<()> {
    let file = args.input.display();
    let named = [p.view.is_some(), args.pose.is_some(), args.poses.is_some()];
    if p.path.is_some() && named.iter().any(|&n| n) {
        bail!("{file}: --path takes no --view, --pose or --poses");
    }
    if args.walk.is_some() && (args.poses.is_some() || (p.view.is_some() && args.pose.is_some())) {
        bail!("{file}: --walk starts from --view, --pose or the scene's own start, not --poses");
    }
    if !p.walks(args) && named.iter().filter(|&&n| n).count() != 1 {
        bail!("{file}: give exactly one of --view, --pose, --poses, --walk, --path");
    }
    if !level && args.pose.is_some() {
        bail!("{file}: --pose names a level's pose; a mesh takes --view, --poses, --walk or --path");
    }
    if !level && args.shadows {
        bail!("{file}: --shadows lights a level by its light entities; a mesh has none");
    }
    if level && (args.cell.is_some() || args.fresh_gvs) {
        bail!("{file}: --cell and --fresh-gvs are for meshes");
    }
    if !level && args.raycast_spacing.is_some() {
        bail!("{file}: --raycast-spacing culls a level; a mesh has no runtime world");
    }
    Ok(())
}

/// The eye and yaw of the level's `--pose` (or `player_start` when `name` is `None`).
fn named_pose(args: &Args, name: Option<&str>, entities: &str) -> anyhow::Result<(DVec3, f64)> {
    let file = args.input.display();
    let name = name.unwrap_or("player_start");
    if name != "player_start" {
        bail!("--pose `{name}`: the only named pose is `player_start`");
    }
    let ents = sightline_formats::entities::parse(entities).with_context(|| format!("{file}: entities"))?;
    let start = ents
        .iter()
        .find(|e| e.classname() == "info_player_start")
        .with_context(|| format!("{file}: no info_player_start"))?;
    let o = start
        .origin()
        .with_context(|| format!("{file}: info_player_start has no origin"))?
        .with_context(|| format!("{file}: info_player_start"))?;
    let yaw = start.get("angle").and_then(|a| a.trim().parse::<f64>().ok()).filter(|a| a.is_finite());
    Ok((DVec3::from(o.map(f64::from)) + DVec3::Z * EYE_HEIGHT, yaw.unwrap_or(0.0)))
}

/// The cameras the arguments name on a level.
fn level_cameras(
    args: &Args,
    p: &Parsed,
    entities: &str,
    bvh: &sightline_raycast::Bvh,
) -> anyhow::Result<Vec<Camera>> {
    let step = args.step.unwrap_or(LEVEL_STEP);
    if let Some(steps) = walk_steps(args, p, bvh, step, || named_pose(args, args.pose.as_deref(), entities))?
    {
        return Ok(steps.iter().map(|s| camera(args, s.eye, s.yaw, 0.0)).collect());
    }
    let file = args.input.display();
    match (p.view, &args.pose, args.poses) {
        (Some(eye), None, None) => Ok(vec![camera(args, eye, p.look.0, p.look.1)]),
        (None, Some(name), None) => {
            let (eye, yaw) = named_pose(args, Some(name), entities)?;
            Ok(vec![camera(args, eye, yaw, 0.0)])
        }
        (None, None, Some(n)) => {
            let world = sightline_runtime::load::load_path(&args.input)?;
            let cams = sightline_runtime::poses::random_cameras(&world, args.seed, n);
            anyhow::ensure!(!cams.is_empty(), "{file}: no open leaf to put a camera in");
            Ok(cams
                .iter()
                .map(|c| camera(args, c.position.as_dvec3(), f64::from(c.yaw), f64::from(c.pitch)))
                .collect())
        }
        _ => bail!("{file}: give exactly one of --view, --pose, --poses, --walk, --path"),
    }
}

/// The cameras the arguments name on a mesh whose open space is `open` (see
/// [`MeshScene::random_eyes`]).
fn mesh_cameras(
    args: &Args,
    p: &Parsed,
    scene: &MeshScene<'_>,
    open: &[sightline_gvs::Cell],
    step: f64,
) -> anyhow::Result<Vec<Camera>> {
    let file = args.input.display();
    let start = || {
        let eyes = scene.random_eyes(open, 1, args.seed);
        let &(eye, yaw, _) =
            eyes.first().with_context(|| format!("{file}: no open point to start the walk"))?;
        // Along a street of the city: the nearest axis.
        Ok((eye, (yaw / 90.0).round() * 90.0))
    };
    if let Some(steps) = walk_steps(args, p, scene.bvh(), step, start)? {
        return Ok(steps.iter().map(|s| camera(args, s.eye, s.yaw, 0.0)).collect());
    }
    match (p.view, args.poses) {
        (Some(eye), None) => Ok(vec![camera(args, eye, p.look.0, p.look.1)]),
        (None, Some(n)) => {
            let eyes = scene.random_eyes(open, n, args.seed);
            anyhow::ensure!(!eyes.is_empty(), "{file}: no open point to put a camera in");
            Ok(eyes.iter().map(|&(eye, yaw, pitch)| camera(args, eye, yaw, pitch)).collect())
        }
        _ => bail!("{file}: give exactly one of --view, --poses, --walk, --path"),
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

/// True when `input` names a level (`.bsp` or `.slvl`, in any case) rather than a mesh.
fn is_level(input: &Path) -> bool {
    input.extension().and_then(|e| e.to_str()).is_some_and(|e| {
        let e = e.to_ascii_lowercase();
        e == "bsp" || e == "slvl"
    })
}

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<Outcome> {
    let (w, h) = args.size;
    // Every number first, then the memory, then the files: all before any work.
    let parsed = Parsed::of(args)?;
    check_cameras(args, &parsed, is_level(&args.input))?;
    limits::fits_memory(
        &format!("a trace of --size {w}x{h}"),
        u64::from(w) * u64::from(h) * BYTES_PER_PIXEL,
        1,
    )?;
    if let Some(out) = &args.output {
        crate::output::check(&[args.input.as_path()], &[out.as_path()])?;
    }
    let file = || args.input.display().to_string();
    if is_level(&args.input) {
        let level = load::load_level(&args.input, &crate::progress::Bars::new(true))?;
        let tree = BspTree::new(&level).with_context(file)?;
        let matrix = pvs::level_pvs(&level).with_context(file)?;
        let scene = LevelScene::new(&tree).with_context(file)?;
        let cams = level_cameras(args, &parsed, &level.entities, scene.bvh())?;
        let world = match args.raycast_spacing {
            Some(_) => Some(sightline_runtime::load::load_path(&args.input)?),
            None => None,
        };
        let lights = if args.shadows {
            Some(shadow::lights(&scene, &level.entities).with_context(|| format!("{}: entities", file()))?)
        } else {
            None
        };
        let mut tracer = Tracer::Level {
            scene: Box::new(scene),
            matrix,
            cache: CellCache::default(),
            lights,
            lists: LightLists::default(),
        };
        drive(args, &parsed, &mut tracer, &cams, world.as_ref(), json!({}))
    } else {
        let input = args.input.to_str().with_context(|| format!("{}: not a UTF-8 name", file()))?;
        let (mesh, _) =
            sightline_gvs::scene::load(input, args.scene_seed, &crate::progress::Bars::new(true))?;
        let bounds = mesh.bounds();
        let city = matches!(scenegen::parse_spec(input), Some(Ok((Kind::City, _))));
        let cell = args.cell.unwrap_or_else(|| {
            if city {
                scenegen::BLOCK / 2.0
            } else {
                (bounds.max - bounds.min).max_element().max(f32::MIN_POSITIVE) / 16.0
            }
        });
        let scene = MeshScene::new(&mesh.triangles, &bounds, cell, sightline_gvs::Params::default())
            .with_context(file)?;
        let cams =
            mesh_cameras(args, &parsed, &scene, &mesh.open, args.step.unwrap_or(f64::from(cell) / 2.0))?;
        let extra = json!({
            "cell_size": cell,
            "grid_cells": scene.grid().len(),
            "gvs_index_ms": scene.index_time().as_secs_f64() * 1e3,
            "gvs_sampled": true,
        });
        if !args.json {
            eprintln!(
                "{}: {} triangles, grid of {} cells of side {cell}, BVH {:.1} s, GVS index {:.1} s",
                file(),
                mesh.triangles.len(),
                scene.grid().len(),
                scene.build_time().as_secs_f64(),
                scene.index_time().as_secs_f64()
            );
        }
        let cache = MeshCells::new(parsed.walks(args) && !args.fresh_gvs);
        let mut tracer = Tracer::Mesh { scene: Box::new(scene), cache, last: None };
        drive(args, &parsed, &mut tracer, &cams, None, extra)
    }
}

/// The scene being traced, with its visible sets.
enum Tracer<'a> {
    /// A level: its triangles, its PVS, the sets of the clusters entered so far, and with
    /// `--shadows` its lights and the light lists of the clusters lit so far.
    Level {
        scene: Box<LevelScene<'a>>,
        matrix: BitMatrix,
        cache: CellCache,
        lights: Option<Vec<Light>>,
        lists: LightLists,
    },
    /// A mesh: its triangles and grid, the GVS sets of the cells entered so far, and the set of
    /// the last camera's cell (the incremental update starts from it).
    Mesh { scene: Box<MeshScene<'a>>, cache: MeshCells, last: Option<Arc<MeshCellSet>> },
}

/// One camera traced in both modes, in the terms both kinds of scene share.
struct Shot {
    rays: Rays,
    full: Frame,
    reduced: Frame,
    /// The eye's cluster (level) or grid cell (mesh).
    cell: u64,
    /// The eye's leaf (levels).
    eye_leaf: Option<usize>,
    /// `cached`, or how the set was made: `pvs row` (a level), `gvs` or `update` (a mesh).
    source: &'static str,
    /// Time to make the visible set (the PVS row's faces, or GVS); 0 when cached.
    set_ms: f64,
    /// Time to build its BVH; 0 when cached.
    bvh_ms: f64,
    set_triangles: usize,
    set_faces: usize,
    set_bytes: usize,
    same: usize,
    ties: usize,
    grazes: usize,
    mismatches: usize,
    listed: Vec<String>,
    /// With `--shadows`: the whole scene's frame lit, and the lighting of both modes.
    shadows: Option<Shadows>,
}

/// The lighting of one camera in both modes.
struct Shadows {
    /// The full mode's lighting (every light).
    full: Lit,
    /// Time and shadow rays of the PVS mode (per-cluster light lists).
    pvs_time: std::time::Duration,
    pvs_rays: u64,
    /// Pixels whose two frames hit the same triangle but light it differently.
    differ: usize,
}

/// Milliseconds of `d`.
fn ms(d: std::time::Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

impl Tracer<'_> {
    fn trace(&mut self, cam: &Camera) -> Result<Shot, TraceError> {
        match self {
            Tracer::Level { scene, matrix, cache, lights, lists } => {
                let t = trace_camera(scene, matrix, cache, cam)?;
                let built = !t.cached;
                let shadows = lights.as_deref().map(|lights| {
                    let full = shadow::light(scene, &t.rays, &t.full, lights, None);
                    let pvs = shadow::light(scene, &t.rays, &t.pvs, lights, Some((matrix, lists)));
                    // Pixels whose two frames hit the same triangle (a tie hits another, lit
                    // from another point) but light it differently.
                    let same = |i: usize| match (t.full.hits[i], t.pvs.hits[i]) {
                        (Some(a), Some(b)) => a.triangle == b.triangle,
                        (a, b) => a.is_none() && b.is_none(),
                    };
                    let differ =
                        (0..full.light.len()).filter(|&i| same(i) && full.light[i] != pvs.light[i]).count();
                    Shadows { full, pvs_time: pvs.time, pvs_rays: pvs.shadow_rays, differ }
                });
                Ok(Shot {
                    cell: u64::from(t.eye_cluster),
                    eye_leaf: Some(t.eye_leaf),
                    source: if built { "pvs row" } else { "cached" },
                    set_ms: if built { ms(t.set.gather) } else { 0.0 },
                    bvh_ms: if built { ms(t.set.bvh_build) } else { 0.0 },
                    set_triangles: t.set.triangles.len(),
                    set_faces: t.set.faces,
                    set_bytes: t.set.heap_bytes(),
                    same: t.gate.same,
                    ties: t.gate.ties,
                    grazes: t.gate.grazes,
                    mismatches: t.gate.mismatches,
                    listed: t.gate.listed.iter().map(ToString::to_string).collect(),
                    shadows,
                    rays: t.rays,
                    full: t.full,
                    reduced: t.pvs,
                })
            }
            Tracer::Mesh { scene, cache, last } => {
                let t = trace_mesh_camera(scene, cache, cam, last.as_deref())?;
                *last = Some(t.set.clone());
                let built = !t.cached;
                Ok(Shot {
                    cell: t.cell as u64,
                    eye_leaf: None,
                    source: if built { t.set.source.name() } else { "cached" },
                    set_ms: if built { ms(t.set.gvs_time) } else { 0.0 },
                    bvh_ms: if built { ms(t.set.bvh_build) } else { 0.0 },
                    set_triangles: t.set.triangles.len(),
                    set_faces: t.set.triangles.len(),
                    set_bytes: t.set.heap_bytes(),
                    same: t.gate.same,
                    ties: t.gate.ties,
                    grazes: t.gate.grazes,
                    mismatches: t.gate.mismatches,
                    listed: t.gate.listed.iter().map(ToString::to_string).collect(),
                    shadows: None,
                    rays: t.rays,
                    full: t.full,
                    reduced: t.reduced,
                })
            }
        }
    }

    /// The picture of a shot's whole-scene frame (lit with `--shadows`).
    fn picture(&self, t: &Shot) -> Image {
        match (self, &t.shadows) {
            (Tracer::Level { scene, .. }, Some(s)) => shadow::lit_picture(scene, &t.rays, &t.full, &s.full),
            _ => picture(self.surfaces(), &t.rays, &t.full),
        }
    }

    fn surfaces(&self) -> &dyn Surfaces {
        match self {
            Tracer::Level { scene, .. } => scene.as_ref(),
            Tracer::Mesh { scene, .. } => scene.as_ref(),
        }
    }

    /// Whole-scene BVH: its build time and heap bytes.
    fn whole(&self) -> (std::time::Duration, usize) {
        match self {
            Tracer::Level { scene, .. } => (scene.build_time(), scene.bvh().heap_bytes()),
            Tracer::Mesh { scene, .. } => (scene.build_time(), scene.bvh().heap_bytes()),
        }
    }

    /// Visible sets made so far.
    fn sets(&self) -> usize {
        match self {
            Tracer::Level { cache, .. } => cache.len(),
            Tracer::Mesh { cache, .. } => cache.len(),
        }
    }

    /// What the eye's cell is called.
    fn cell_name(&self) -> &'static str {
        match self {
            Tracer::Level { .. } => "cluster",
            Tracer::Mesh { .. } => "cell",
        }
    }
}

/// Trace every camera, print, and give the gate's outcome.
fn drive(
    args: &Args,
    parsed: &Parsed,
    tracer: &mut Tracer<'_>,
    cams: &[Camera],
    world: Option<&sightline_runtime::World>,
    extra: Value,
) -> anyhow::Result<Outcome> {
    let (w, h) = args.size;
    let file = || args.input.display().to_string();
    let walks = parsed.walks(args);
    let what = if walks { "step" } else { "pose" };
    let generated = walks || args.poses.is_some();
    let cell_name = tracer.cell_name();
    let mut outcome = Outcome::Clean;
    let (mut rays, mut full_s, mut pvs_s) = (0usize, 0f64, 0f64);
    let (mut records, mut skipped) = (Vec::new(), 0usize);
    let mut previous: Option<u64> = None;
    if walks && !args.json {
        println!(
            "{:>5} {:>9} {:>9} {:>9} {:>8} {:>7} {:>8} {:>9} {:>9} {:>9} {:>9} {:>9} {:>7}",
            "step",
            "x",
            "y",
            "z",
            cell_name,
            "change",
            "set",
            "set ms",
            "bvh ms",
            "full ms",
            "set ms",
            "set tris",
            "differ"
        );
    }
    // Start the worker threads before the first timed cast, so that it does not pay for them.
    rayon::broadcast(|_| ());
    for (i, cam) in cams.iter().enumerate() {
        let t = match tracer.trace(cam) {
            Ok(t) => t,
            // A generated pose in a sky leaf (open to the runtime, opaque to sight), on a boundary
            // the two trees round differently, or off a mesh's grid is skipped.
            Err(e @ (TraceError::Camera(_) | TraceError::EyeOutsideGrid { .. })) if generated => {
                eprintln!("{}: {what} {i} skipped: {e}", file());
                skipped += 1;
                continue;
            }
            Err(e) => return Err(e).with_context(|| format!("{}: {what} {i}", file())),
        };
        let changed = previous != Some(t.cell);
        previous = Some(t.cell);
        rays += t.rays.len();
        full_s += t.full.time.as_secs_f64();
        pvs_s += t.reduced.time.as_secs_f64();
        if t.mismatches > 0 {
            outcome = Outcome::Finding;
        }
        if let Some(out) = &args.output {
            let path = png_path(out, i, cams.len());
            tracer.picture(&t).save(&path)?;
        }
        let speedup = t.full.time.as_secs_f64() / t.reduced.time.as_secs_f64().max(1e-9);
        if walks && !args.json {
            let e = cam.eye;
            println!(
                "{i:>5} {:>9.1} {:>9.1} {:>9.1} {:>8} {:>7} {:>8} {:>9.2} {:>9.2} {:>9.2} {:>9.2} {:>9} {:>7}",
                e.x,
                e.y,
                e.z,
                t.cell,
                if changed { "yes" } else { "" },
                t.source,
                t.set_ms,
                t.bvh_ms,
                ms(t.full.time),
                ms(t.reduced.time),
                t.set_triangles,
                t.mismatches,
            );
        } else if !args.json {
            println!(
                "pose {i}: eye {cell_name} {}, set {} of {} triangles ({} faces), full {:.2} Mrays/s, set {:.2} Mrays/s, speed-up {speedup:.2}x, set {} ({:.2} ms, {} KiB); {} same, {} ties, {} grazes, {} differ",
                t.cell,
                t.set_triangles,
                tracer.surfaces().triangles().len(),
                t.set_faces,
                t.full.mrays_per_s(),
                t.reduced.mrays_per_s(),
                t.source,
                t.set_ms + t.bvh_ms,
                t.set_bytes / 1024,
                t.same,
                t.ties,
                t.grazes,
                t.mismatches,
            );
        }
        if let Some(sh) = &t.shadows
            && !args.json
        {
            println!(
                "{what} {i}: shadows: full {} rays in {:.2} ms, PVS light lists {} rays in {:.2} ms; {} pixels lit differently (same triangle)",
                sh.full.shadow_rays,
                ms(sh.full.time),
                sh.pvs_rays,
                ms(sh.pvs_time),
                sh.differ
            );
        }
        for m in &t.listed {
            eprintln!("{}: {what} {i}, eye {cell_name} {}: {m}", file(), t.cell);
        }
        let culled = match (world, args.raycast_spacing) {
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
        let mut record = json!({
            "index": i,
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
            "cell": t.cell,
            "cell_changed": changed,
            "full_mrays_per_s": t.full.mrays_per_s(),
            "pvs_mrays_per_s": t.reduced.mrays_per_s(),
            "full_ms": ms(t.full.time),
            "pvs_ms": ms(t.reduced.time),
            "speedup": speedup,
            "set_source": t.source,
            "set_ms": t.set_ms,
            "bvh_ms": t.bvh_ms,
            "set_triangles": t.set_triangles,
            "set_faces": t.set_faces,
            "set_build_ms": t.set_ms + t.bvh_ms,
            "set_bytes": t.set_bytes,
            "set_cached": t.source == "cached",
            "same": t.same,
            "ties": t.ties,
            "grazes": t.grazes,
            "mismatches": t.mismatches,
            "listed": t.listed,
        });
        if let Some(sh) = &t.shadows {
            record["shadows"] = json!({
                "full_rays": sh.full.shadow_rays,
                "full_ms": ms(sh.full.time),
                "pvs_rays": sh.pvs_rays,
                "pvs_ms": ms(sh.pvs_time),
                "differ": sh.differ,
            });
        }
        if let Some(leaf) = t.eye_leaf {
            record["eye_leaf"] = json!(leaf);
            record["eye_cluster"] = json!(t.cell);
        }
        records.push(record);
    }
    let (full, reduced) = (rays as f64 / full_s.max(1e-9) / 1e6, rays as f64 / pvs_s.max(1e-9) / 1e6);
    let (build, bytes) = tracer.whole();
    let triangles = tracer.surfaces().triangles().len();
    if args.json {
        let mut report = json!({
            "input": file(),
            "scene": if cell_name == "cluster" { "level" } else { "mesh" },
            "width": w,
            "height": h,
            "threads": rayon::current_num_threads(),
            "scene_triangles": triangles,
            "scene_build_ms": ms(build),
            "scene_bytes": bytes,
            "sets_built": tracer.sets(),
            "full_mrays_per_s": full,
            "pvs_mrays_per_s": reduced,
            "speedup": full_s / pvs_s.max(1e-9),
            "passed": outcome == Outcome::Clean,
        });
        if cell_name == "cluster" {
            report["clusters_built"] = json!(tracer.sets());
        }
        if let (Some(r), Some(e)) = (report.as_object_mut(), extra.as_object()) {
            r.extend(e.clone());
        }
        report[if walks { "steps_skipped" } else { "poses_skipped" }] = json!(skipped);
        report[if walks { "steps" } else { "poses" }] = Value::Array(records);
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!(
            "{} {what}s ({skipped} skipped), {} sets built; whole scene {triangles} triangles (BVH {:.1} ms, {} KiB): full {full:.2} Mrays/s, set {reduced:.2} Mrays/s, speed-up {:.2}x; gate {}",
            cams.len() - skipped,
            tracer.sets(),
            ms(build),
            bytes / 1024,
            full_s / pvs_s.max(1e-9),
            match (outcome, cell_name) {
                (Outcome::Clean, _) => "passed",
                (_, "cluster") => "FAILED: the PVS hides visible surfaces",
                _ => "FAILED: the sampled GVS sets miss visible triangles",
            },
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

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: Args,
    }

    #[test]
    fn paths_parse_and_bad_ones_are_clear_errors() {
        let p = parse_path("1,2,3; -4,5.5,6;").expect("two points and a final ;");
        assert_eq!(p, [DVec3::new(1.0, 2.0, 3.0), DVec3::new(-4.0, 5.5, 6.0)]);
        for (bad, says) in [
            ("", "no points"),
            (";", "point 1"),
            ("1,2,3;;4,5,6", "point 2"),
            ("1,2,3;4,5", "point 2"),
            ("1,2,3;4,5,6,7", "point 2"),
            ("nan,0,0", "point 1"),
            ("1,2,inf", "point 1"),
            ("1;2;3", "point 1"),
            ("x,y,z", "point 1"),
        ] {
            let err = parse_path(bad).expect_err(bad).to_string();
            assert!(err.contains("--path") && err.contains(says), "{bad}: {err}");
        }
        let many = vec!["0,0,0"; MAX_PATH_POINTS + 1].join(";");
        assert!(parse_path(&many).is_err());
        // Through the arguments, before any work: `Parsed::of` refuses them.
        let cli = Cli::try_parse_from(["trace", "gen:city:4", "--path", "1,2,3;4,5,nope"]).expect("clap");
        assert!(Parsed::of(&cli.args).is_err());
        let cli = Cli::try_parse_from(["trace", "gen:city:4", "--path", "-1,2,3"]).expect("clap");
        assert!(Parsed::of(&cli.args).is_ok_and(|p| p.walks(&cli.args)));
        assert!(Cli::try_parse_from(["trace", "gen:city:4", "--walk", "0"]).is_err());
        assert!(Cli::try_parse_from(["trace", "gen:city:4", "--step", "-1"]).is_err());
        assert!(Cli::try_parse_from(["trace", "gen:city:4", "--cell", "NaN"]).is_err());
    }
}
