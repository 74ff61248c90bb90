//! Deterministic random camera poses inside open leaves: the benchmark input of `sightline bench`
//! and the runtime's criterion bench (the same seed gives the same poses on every machine), also
//! used by tests.

use glam::{Vec3, Vec3A};

use crate::camera::Camera;
use crate::world::World;

pub use sightline_job::rng::SplitMix64;

/// A point uniform in the box `mins..maxs`.
pub fn point_in(rng: &mut SplitMix64, mins: Vec3A, maxs: Vec3A) -> Vec3A {
    Vec3A::new(rng.range(mins.x, maxs.x), rng.range(mins.y, maxs.y), rng.range(mins.z, maxs.z))
}

/// A random point in a random open leaf of `world` (the leaf chosen uniformly, the point uniform
/// in its box and accepted only when [`World::leaf_at`] agrees), or `None` after 64 failed tries
/// or when the world has no open leaf.
pub fn random_open_point(world: &World, rng: &mut SplitMix64) -> Option<Vec3A> {
    let open = world.open_leaves();
    if open.is_empty() {
        return None;
    }
    for _ in 0..64 {
        let leaf = open[rng.below(open.len())];
        let b = world.leaf_bounds(leaf)?;
        let p = point_in(rng, b.mins(), b.maxs());
        if world.leaf_at(p) == leaf {
            return Some(p);
        }
    }
    None
}

/// `count` cameras ([`Camera::quake`] optics) at random open points, random yaw, pitch within
/// ±60°; deterministic for a seed. Fewer come back only when points cannot be found.
pub fn random_cameras(world: &World, seed: u64, count: usize) -> Vec<Camera> {
    let mut rng = SplitMix64::new(seed);
    let mut cams = Vec::with_capacity(count);
    let mut misses = 0;
    while cams.len() < count && misses < 64 {
        match random_open_point(world, &mut rng) {
            Some(p) => {
                let yaw = rng.range(0.0, 360.0);
                let pitch = rng.range(-60.0, 60.0);
                cams.push(Camera::quake(Vec3::from(p), yaw, pitch));
            }
            None => misses += 1,
        }
    }
    cams
}
