//! An engine's frame loop with sightline-runtime: load once, then every frame cull with a reused
//! scratch and output lists, and draw front to back. Run with a level or BSP path, e.g.
//! `cargo run --release -p sightline-runtime --example frame_loop -- ../shared/maps/ericw/e1m1.vis.bsp`
//! (without an argument it builds a small grid level in memory).

use std::time::Instant;

use glam::Vec3;
use sightline_runtime::backend;
use sightline_runtime::{Camera, Scratch, Visible, World, load, synth};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // Load and validate once; a World is immutable and can be shared between threads (Arc).
    let world = match std::env::args().nth(1) {
        Some(path) => load::load_path(path.as_ref())?,
        None => World::new(&synth::grid_level([8, 8, 2], 64.0, true, |x, y, _| x % 3 == 1 && y % 3 == 1))?,
    };
    // Per-view state, created once: no allocation happens inside the loop.
    let mut scratch = Scratch::new(&world);
    let mut visible = Visible::for_world(&world);
    let pvs = backend::by_name("pvs").ok_or("no pvs backend")?;

    // A camera walking a circle around a point in the first open leaf.
    let start = world.open_leaves().first().and_then(|&l| world.leaf_bounds(l)).ok_or("no open leaf")?;
    let centre = Vec3::from(start.center);
    let (mut drawn_faces, t0) = (0usize, Instant::now());
    for frame in 0..600 {
        let angle = frame as f32 * 0.6;
        let offset =
            Vec3::new(angle.to_radians().cos(), angle.to_radians().sin(), 0.0) * start.extent.x * 0.5;
        let camera = Camera::quake(centre + offset, angle, 0.0);

        // Movement: never walk into solid.
        if let Some(hit) = world.trace(centre, camera.position) {
            println!("frame {frame}: blocked at {:?}", hit.point);
        }
        // Culling: the eye cluster's PVS (kept as a tree since load), then the frustum walk.
        pvs.cull(&world, &camera.view(), &mut scratch, &mut visible);
        // Drawing: leaves and their faces arrive nearest first (good for early-z).
        drawn_faces += visible.faces.len(); // submit `visible.faces` to the GPU here
        if frame % 200 == 0 {
            println!(
                "frame {frame}: {} leaves, {} faces, {:?}",
                visible.leaves.len(),
                visible.faces.len(),
                scratch.stats
            );
        }
    }
    println!("600 frames in {:?}, {drawn_faces} faces submitted", t0.elapsed());
    Ok(())
}
