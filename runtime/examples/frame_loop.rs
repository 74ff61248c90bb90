//! An engine's frame loop with sightline-runtime: load once, then every frame move the camera
//! (tracing so it never walks into solid), cull with a reused scratch and output lists (back
//! faces dropped by the walk), and draw front to back with the draw data. Run with a level or BSP path, e.g.
//! `cargo run --release -p sightline-runtime --example frame_loop -- ../shared/maps/ericw/e1m1.vis.bsp`
//! (without an argument it builds a small grid level in memory).

use std::time::Instant;

use glam::Vec3;
use sightline_formats::entities::Entity;
use sightline_runtime::backend;
use sightline_runtime::{Camera, Scratch, Visible, World, load};
use sightline_tests::synth;

/// The `origin` of the first `info_player_start` among the level's entities, if it has a
/// well-formed one.
fn player_start(entities: &[Entity]) -> Option<Vec3> {
    let start = entities.iter().find(|e| e.classname() == "info_player_start")?;
    start.origin()?.ok().map(Vec3::from_array)
}

/// The centre of the largest open leaf that is not sky: a start for levels without entities.
fn largest_open_leaf(world: &World) -> Option<Vec3> {
    world
        .open_leaves()
        .iter()
        .filter(|&&l| world.leaf_contents(l) != Some(sightline_formats::level::Contents::Sky))
        .filter_map(|&l| world.leaf_bounds(l))
        .max_by(|a, b| a.extent.element_product().total_cmp(&b.extent.element_product()))
        .map(|b| Vec3::from(b.center))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // Load and validate once; a World is immutable and can be shared between threads (Arc).
    let world = match std::env::args().nth(1) {
        Some(path) => load::load_path(path.as_ref())?,
        // Pillars inside a ring of solid cells (the walls the camera turns at).
        None => World::new(&synth::grid_level([10, 10, 2], 64.0, true, |x, y, _| {
            x == 0 || y == 0 || x == 9 || y == 9 || (x % 3 == 1 && y % 3 == 1)
        }))?,
    };
    // Per-view state, created once: no allocation happens inside the loop.
    let mut scratch = Scratch::new(&world);
    let mut visible = Visible::for_world(&world);
    let pvs = backend::by_name("pvs").ok_or("no pvs backend")?;
    let draw = world.draw();

    let mut position =
        player_start(draw.entity_list()).or_else(|| largest_open_leaf(&world)).ok_or("no open leaf")?;
    println!("start at {position:?} (leaf {})", world.leaf_at(position));
    let (mut yaw, mut blocked, step) = (0.0f32, 0usize, 8.0f32);
    let (mut drawn_faces, t0) = (0usize, Instant::now());
    for frame in 0..600 {
        // Movement: walk forward; when a wall is near, turn and try again next frame.
        let forward = Vec3::new(yaw.to_radians().cos(), yaw.to_radians().sin(), 0.0);
        let ahead = position + forward * (step * 4.0);
        if world.trace(position, ahead).is_some() {
            blocked += 1;
            yaw += 67.0;
        } else {
            position += forward * step;
        }
        let camera = Camera::quake(position, yaw, 0.0);

        // Culling: the eye cluster's PVS (kept as a tree since load), then the frustum walk,
        // which also leaves out the faces turned away from the eye.
        let view = camera.view().with_back_face_culling(true);
        pvs.cull(&world, &view, &mut scratch, &mut visible);
        // Drawing: faces arrive nearest first (good for early-z); each has its corners, texture
        // and texture axes in `draw`.
        for &f in &visible.faces {
            if let Some(face) = draw.face(f) {
                drawn_faces += usize::from(face.vertices.len() >= 3); // submit to the GPU here
            }
        }
        if frame % 200 == 0 {
            let first =
                visible.faces.first().and_then(|&f| draw.face(f)).and_then(|f| draw.texture_name(f.texture));
            println!(
                "frame {frame}: at {position:?}, {} leaves, {} faces (nearest textured {first:?}), {:?}",
                visible.leaves.len(),
                visible.faces.len(),
                scratch.stats
            );
        }
    }
    println!(
        "600 frames in {:?}, {drawn_faces} faces submitted, {blocked} frames turned at a wall",
        t0.elapsed()
    );
    Ok(())
}
