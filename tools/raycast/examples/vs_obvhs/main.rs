//! Our BVH against obvhs' compressed-wide BVH (CWBVH, Ylitie et al. 2017) on the same triangles and
//! the same rays: build time, closest-hit and any-hit rays per second, memory, and whether the
//! closest hits agree.
//!
//! ```text
//! cargo run --release -p sightline-raycast --example vs_obvhs -- [SCENE ...]
//! ```
//! A scene is a Quake-family `.bsp` or `.slvl` (its world model's triangles, as `sightline trace`
//! triangulates them; primary rays of 640 × 480 pictures from the runtime's random poses, seed 1,
//! as `sightline trace --poses`), or `gen:city:N` / `gen:spheres:N` (`sightline_gvs::scenegen`,
//! seed 1; rays from the scene's first cell as the GVS bench casts them: eye-level rays for the
//! city, rays leaving the cell's surface for the spheres). Without scenes: E1M1, `gen:city:30`,
//! `gen:city:100`, `gen:spheres:1000` (maps from `$SIGHTLINE_MAPS`, default `../shared/maps`).
//!
//! Both builds are single-threaded (ours has no other; obvhs without its `parallel` feature),
//! obvhs with `BvhBuildParams::medium_build()` (its default in its examples) and its triangles
//! reordered into its leaf order as `RtTriangle`s (counted in its build time and memory), which is
//! how its examples use it. Every figure is the best of [`ROUNDS`] interleaved runs (ours, theirs,
//! ours, ...) on one thread. Memory is the heap bytes of nodes, triangles and index arrays (vector
//! lengths, not capacities). Closest hits are compared as [`library::compare`] says: the same, a
//! graze (an edge or the ray's origin, where only our watertight test is exact), or a
//! disagreement, printed (the first five of a scene); any disagreement makes the run exit 1.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use glam::Vec3;
use sightline_gvs::scenegen::{self, Rng};
use sightline_raycast::Bvh;

mod library;

use library::{Agreement, Theirs, compare};

/// Interleaved runs of every measurement; the best is kept.
const ROUNDS: usize = 3;
/// Random poses of a level scene.
const POSES: usize = 8;
/// Rays of a generated scene.
const GEN_RAYS: usize = 500_000;
/// Length of an any-hit ray, as a fraction of the scene box's diagonal.
const ANY_HIT_FRACTION: f32 = 0.05;

/// A scene: its triangles and its rays (origin, direction; `t` unbounded).
struct Scene {
    name: String,
    triangles: Vec<[Vec3; 3]>,
    rays: Vec<(Vec3, Vec3)>,
}

fn maps_dir() -> PathBuf {
    std::env::var_os("SIGHTLINE_MAPS").map_or_else(|| PathBuf::from("../shared/maps"), PathBuf::from)
}

fn level(path: &Path) -> Scene {
    use sightline_validate::bsp::BspTree;
    use sightline_validate::trace::Camera;
    use sightline_validate::trace::frame::Rays;
    use sightline_validate::trace::scene::LevelScene;
    let fail = |what: &dyn std::fmt::Display| -> ! {
        eprintln!("{}: {what}", path.display());
        std::process::exit(2)
    };
    let level = sightline_validate::load::load_level(path, &sightline_job::progress::NoProgress)
        .unwrap_or_else(|e| fail(&e));
    let tree = BspTree::new(&level).unwrap_or_else(|e| fail(&e));
    let scene = LevelScene::new(&tree).unwrap_or_else(|e| fail(&e));
    let world = sightline_runtime::load::load_path(path).unwrap_or_else(|e| fail(&e));
    let mut rays = Vec::new();
    for c in sightline_runtime::poses::random_cameras(&world, 1, POSES) {
        let cam = Camera {
            eye: c.position.as_dvec3(),
            yaw: f64::from(c.yaw),
            pitch: f64::from(c.pitch),
            fov: 90.0,
            width: 640,
            height: 480,
        };
        let r = Rays::new(&cam).unwrap_or_else(|e| fail(&e));
        rays.extend(r.dirs.iter().map(|&d| (r.origin, d)));
    }
    Scene { name: path.display().to_string(), triangles: scene.triangles().to_vec(), rays }
}

fn generated(spec: &str) -> Scene {
    let (kind, size) = match scenegen::parse_spec(spec) {
        Some(Ok(k)) => k,
        Some(Err(e)) => {
            eprintln!("{e}");
            std::process::exit(2)
        }
        None => {
            eprintln!("{spec}: neither gen:KIND:N nor a level file");
            std::process::exit(2)
        }
    };
    let scene = scenegen::generate(kind, size, 1);
    let (lo, hi) = scene.cells[0];
    let mut rng = Rng::new(3);
    let rays = if spec.starts_with("gen:city") {
        // Eye-level rays from the street cell, as the GVS bench and error metric cast them.
        (0..GEN_RAYS)
            .map(|_| {
                let o = lo + (hi - lo) * Vec3::new(rng.unit_f32(), rng.unit_f32(), rng.unit_f32());
                let yaw = rng.range(0.0, std::f32::consts::TAU);
                let pitch = rng.range(-0.8, 0.8);
                (o, Vec3::new(pitch.cos() * yaw.cos(), pitch.cos() * yaw.sin(), pitch.sin()))
            })
            .collect()
    } else {
        let cell = sightline_gvs::Cell::new(lo, hi);
        (1..=GEN_RAYS as u64).map(|i| cell.sample_ray(i)).collect()
    };
    Scene { name: spec.to_string(), triangles: scene.triangles, rays }
}

/// Best time of `ROUNDS` runs of `ours` and `theirs`, interleaved.
fn paired<A, B>(mut ours: impl FnMut() -> A, mut theirs: impl FnMut() -> B) -> (Duration, Duration) {
    let (mut a, mut b) = (Duration::MAX, Duration::MAX);
    for _ in 0..ROUNDS {
        let t = Instant::now();
        std::hint::black_box(ours());
        a = a.min(t.elapsed());
        let t = Instant::now();
        std::hint::black_box(theirs());
        b = b.min(t.elapsed());
    }
    (a, b)
}

fn mrays(n: usize, d: Duration) -> f64 {
    n as f64 / d.as_secs_f64() / 1e6
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let specs: Vec<String> = if args.is_empty() {
        let e1m1 = maps_dir().join("ericw/e1m1.vis.bsp");
        vec![
            e1m1.display().to_string(),
            "gen:city:30".into(),
            "gen:city:100".into(),
            "gen:spheres:1000".into(),
        ]
    } else {
        args
    };
    println!(
        "| scene | triangles | rays | build ms (ours / obvhs) | closest Mrays/s (ours / obvhs) | any-hit Mrays/s (ours / obvhs) | MB (ours / obvhs) | closest hits agree |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    let mut disagreements = 0usize;
    for spec in &specs {
        let scene = if spec.starts_with("gen:") { generated(spec) } else { level(Path::new(spec)) };
        let tris = &scene.triangles;
        let (build_ours, build_theirs) = paired(|| Bvh::build(tris), || Theirs::build(tris));
        let ours = Bvh::build(tris);
        let theirs = Theirs::build(tris);
        let rays = &scene.rays;
        let (closest_ours, closest_theirs) = paired(
            || rays.iter().filter(|&&(o, d)| ours.intersect(o, d, f32::INFINITY).is_some()).count(),
            || rays.iter().filter(|&&(o, d)| theirs.intersect(o, d, f32::INFINITY).is_some()).count(),
        );
        // Any-hit rays of a fixed length: a twentieth of the scene's diagonal.
        let (lo, hi) = tris
            .iter()
            .flatten()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
        let reach = (hi - lo).length() * ANY_HIT_FRACTION;
        let short: Vec<(Vec3, Vec3)> = rays.iter().map(|&(o, d)| (o, d.normalize_or_zero())).collect();
        let (any_ours, any_theirs) = paired(
            || short.iter().filter(|&&(o, d)| ours.occluded(o, d, reach)).count(),
            || short.iter().filter(|&&(o, d)| theirs.occluded(o, d, reach)).count(),
        );
        let (mut agree, mut grazes, mut differ) = (0usize, 0usize, 0usize);
        for &(o, d) in rays {
            match compare(tris, o, d, &ours, &theirs) {
                Agreement::Same => agree += 1,
                Agreement::Graze => grazes += 1,
                Agreement::Differ(a, b) => {
                    differ += 1;
                    if differ <= 5 {
                        eprintln!("{}: ray {o} {d}: ours {a:?}, obvhs {b:?}", scene.name);
                    }
                }
            }
        }
        disagreements += differ;
        let mb = |b: usize| b as f64 / 1e6;
        println!(
            "| {} | {} | {} | {:.0} / {:.0} | {:.2} / {:.2} | {:.2} / {:.2} | {:.1} / {:.1} | {agree} + {grazes} grazes of {} |",
            scene.name,
            tris.len(),
            rays.len(),
            build_ours.as_secs_f64() * 1e3,
            build_theirs.as_secs_f64() * 1e3,
            mrays(rays.len(), closest_ours),
            mrays(rays.len(), closest_theirs),
            mrays(short.len(), any_ours),
            mrays(short.len(), any_theirs),
            mb(ours.heap_bytes()),
            mb(theirs.heap_bytes()),
            rays.len(),
        );
    }
    if disagreements > 0 {
        eprintln!("{disagreements} rays whose closest hits disagree");
        std::process::exit(1);
    }
}
