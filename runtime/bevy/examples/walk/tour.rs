//! A scripted camera path through a level's open leaves, for the headless walk
//! ([`crate::headless`]) and benchmarks: deterministic, and never in solid.
//!
//! The stops are the centres of the open, non-sky leaves whose centre lies in the leaf itself
//! (a leaf's box centre can fall outside a slanted cell), in leaf order, in Bevy's axes and level
//! units ([`sightline_bevy::coords`]). Frame `i` of `n` stands at stop `i * stops / n` and looks along a
//! heading turned 37° further each frame, level with the floor.

use bevy::math::{Quat, Vec3};
use bevy::transform::components::Transform;
use sightline_formats::level::Contents;
use sightline_runtime::World;

use sightline_bevy::coords::to_bevy;

/// Degrees the heading turns per frame.
const TURN_DEGREES: f32 = 37.0;

/// The stops of a level; see the module docs.
#[derive(Debug, Clone, PartialEq)]
pub struct Tour {
    stops: Vec<Vec3>,
}

impl Tour {
    /// The stops of `world`.
    pub fn new(world: &World) -> Self {
        let stops = world
            .open_leaves()
            .iter()
            .filter(|&&l| world.leaf_contents(l) != Some(Contents::Sky))
            .filter_map(|&l| {
                let center = world.leaf_bounds(l)?.center;
                (world.leaf_at(center) == l).then(|| to_bevy(center.to_array()))
            })
            .collect();
        Self { stops }
    }

    /// Number of stops.
    pub fn len(&self) -> usize {
        self.stops.len()
    }

    /// The camera's transform (in the level root's space) at `frame` of `frames`; `None` without
    /// stops.
    pub fn transform(&self, frame: u32, frames: u32) -> Option<Transform> {
        let n = self.stops.len() as u64;
        let index = (u64::from(frame) * n).checked_div(u64::from(frames.max(1)))?.min(n.checked_sub(1)?);
        let stop = *self.stops.get(index as usize)?;
        let heading = (frame as f32 * TURN_DEGREES).rem_euclid(360.0).to_radians();
        Some(Transform::from_translation(stop).with_rotation(Quat::from_rotation_y(heading)))
    }
}
