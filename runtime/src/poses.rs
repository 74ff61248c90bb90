//! Deterministic random camera poses inside open leaves, for benchmarks and tests.

use glam::{Vec3, Vec3A};

use crate::camera::Camera;
use crate::world::World;

/// SplitMix64: a tiny, fast, seedable generator (Steele, Lea & Flood 2014). Same seed, same
/// sequence, on every platform.
#[derive(Debug, Clone)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    /// A generator from a seed.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`.
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }

    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next_f32()
    }

    /// Uniform in `0..n` (`n > 0`; returns 0 for `n == 0`).
    pub fn below(&mut self, n: usize) -> usize {
        if n == 0 { 0 } else { ((u128::from(self.next_u64()) * n as u128) >> 64) as usize }
    }

    /// A point uniform in the box `mins..maxs`.
    pub fn point_in(&mut self, mins: Vec3A, maxs: Vec3A) -> Vec3A {
        Vec3A::new(self.range(mins.x, maxs.x), self.range(mins.y, maxs.y), self.range(mins.z, maxs.z))
    }
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
        let p = rng.point_in(b.mins(), b.maxs());
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
