//! Per-caller working memory for the walk, and the output lists.
//!
//! A [`Scratch`] belongs to one caller (one thread, one view) and is reused every frame: face marks
//! and element marks use generation counters instead of being cleared, and every buffer keeps its
//! capacity, so after the first frame on a world nothing is allocated. Using a scratch with another world resizes it
//! once.

use glam::Vec3A;

use crate::pvs::Bitset;
use crate::world::World;

/// Counters of the last frame, for benchmarks and tuning.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FrameStats {
    /// Leaves marked potentially visible (the PVS of the eye, or what the portal search reached).
    pub marked_leaves: u32,
    /// Nodes popped by the walk.
    pub nodes_visited: u32,
    /// Box–frustum tests made.
    pub box_tests: u32,
    /// PVS backend: the eye is in the same cluster as in this scratch's previous PVS frame (no
    /// row to decode even without PVS trees).
    pub marks_reused: bool,
    /// Portals crossed by the portal backend.
    pub portals_crossed: u32,
    /// True when the portal backend stopped at its work budget.
    pub truncated: bool,
    /// Rays cast by the ray-casting backend (0 when it fell back to the PVS backend).
    pub rays: u32,
}

/// Visible leaves and faces, front to back. Reuse one across frames.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Visible {
    /// Leaves, nearest first.
    pub leaves: Vec<u32>,
    /// Faces of those leaves, each once, in the order of their first leaf.
    pub faces: Vec<u32>,
}

impl Visible {
    /// Output lists with room for every leaf and face of `world`, so they never reallocate.
    pub fn for_world(world: &World) -> Self {
        Self { leaves: Vec::with_capacity(world.num_leaves()), faces: Vec::with_capacity(world.num_faces()) }
    }

    /// Empty both lists, keeping capacity.
    pub fn clear(&mut self) {
        self.leaves.clear();
        self.faces.clear();
    }
}

/// Working memory for culling (see the module docs).
#[derive(Debug, Clone, Default)]
pub struct Scratch {
    pub(crate) world_id: u64,
    /// Element marks ([`crate::layout`]) of generation `mark_gen`, made by the portal search, or
    /// by the PVS backend when the world keeps no PVS trees.
    pub(crate) marks: Vec<u32>,
    pub(crate) mark_gen: u32,
    /// The PVS key (eye cluster, `u32::MAX` for "everything") `marks` holds, if they are PVS marks.
    pub(crate) marks_key: Option<u32>,
    /// Leaves marked in `marks` when they are PVS marks.
    pub(crate) marks_count: u32,
    /// The PVS key of the last PVS frame (for [`FrameStats::marks_reused`]).
    pub(crate) pvs_key: Option<u32>,
    pub(crate) walk: WalkState,
    pub(crate) row: Bitset,
    // Portal search.
    pub(crate) on_path: Vec<bool>,
    pub(crate) planes: Vec<(Vec3A, f32)>,
    pub(crate) poly_a: Vec<Vec3A>,
    pub(crate) poly_b: Vec<Vec3A>,
    // Ray-casting backend: per leaf the face a ray last hit in it (`u32::MAX`: none), frames cast
    // on this scratch, whether the last probe chose the PVS backend, the probe's second output.
    pub(crate) ray_last_hit: Vec<u32>,
    pub(crate) ray_frames: u32,
    pub(crate) ray_off: bool,
    pub(crate) ray_other: Visible,
    /// Counters of the last frame.
    pub stats: FrameStats,
}

/// The walk's part of a [`Scratch`]: its stack and the face marks.
#[derive(Debug, Clone, Default)]
pub(crate) struct WalkState {
    /// Generation of the current frame, for face de-duplication.
    pub frame_gen: u32,
    pub face_mark: Vec<u32>,
    /// The walk's stack: `depth + 3` slots, never resized by the walk.
    pub stack: Vec<(i32, u8)>,
}

impl WalkState {
    /// Start a new frame; returns its generation (for face de-duplication).
    pub fn next_frame_gen(&mut self) -> u32 {
        self.frame_gen = self.frame_gen.wrapping_add(1);
        if self.frame_gen == 0 {
            self.face_mark.fill(0);
            self.frame_gen = 1;
        }
        self.frame_gen
    }
}

impl Scratch {
    /// Scratch sized for `world`.
    pub fn new(world: &World) -> Self {
        let mut s = Self::default();
        s.bind(world);
        s
    }

    /// Size the buffers for `world` if they were made for another one; drops cached marks.
    pub(crate) fn bind(&mut self, world: &World) {
        if self.world_id == world.id() {
            return;
        }
        self.world_id = world.id();
        self.marks_key = None;
        self.pvs_key = None;
        self.marks.clear();
        self.marks.resize(world.walk_tree().mark_slots(), 0);
        self.mark_gen = 0;
        self.walk.frame_gen = 0;
        self.walk.face_mark.clear();
        self.walk.face_mark.resize(world.num_faces(), 0);
        self.walk.stack.clear();
        self.walk.stack.resize(world.depth() + 3, (0, 0));
        self.on_path.clear();
        self.on_path.resize(world.num_leaves(), false);
        self.row.reset(world.num_clusters() as usize);
        self.planes.reserve(256);
        self.poly_a.reserve(64);
        self.poly_b.reserve(64);
        self.ray_last_hit.clear();
        self.ray_frames = 0;
        self.ray_off = false;
    }

    /// Start a new set of marks (not PVS marks until the caller says so).
    pub(crate) fn next_marks(&mut self) {
        self.mark_gen = self.mark_gen.wrapping_add(1);
        if self.mark_gen == 0 {
            self.marks.fill(0);
            self.mark_gen = 1;
        }
        self.marks_key = None;
    }

    /// Mark `leaf` and its ancestors in [`Scratch::marks`] ("mark up the tree", stopping at the
    /// first ancestor already marked). Returns false when it was already marked (or solid).
    #[inline]
    pub(crate) fn mark_leaf(&mut self, world: &World, leaf: u32) -> bool {
        world.walk_tree().mark_leaf(&mut self.marks, self.mark_gen, leaf)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::{Backend, pvs::Pvs};
    use crate::poses::{SplitMix64, random_cameras};
    use crate::world::World;
    use sightline_tests::synth::grid_level;

    /// The walk's buffers (private to the crate) keep their capacity once warm.
    #[test]
    fn walk_allocates_nothing_after_warm_up() {
        let mut rng = SplitMix64::new(2);
        let solid: Vec<bool> = (0..8 * 6 * 3).map(|_| rng.below(4) == 0).collect();
        let level = grid_level([8, 6, 3], 64.0, true, |x, y, z| solid[(z * 6 + y) * 8 + x]);
        let world = World::new(&level).expect("valid");
        let mut scratch = Scratch::new(&world);
        let mut out = Visible::for_world(&world);
        let cams = random_cameras(&world, 9, 200);
        let caps = (
            out.leaves.capacity(),
            out.faces.capacity(),
            scratch.walk.stack.capacity(),
            scratch.planes.capacity(),
        );
        for cam in &cams {
            Pvs.cull(&world, &cam.view(), &mut scratch, &mut out);
        }
        assert_eq!(
            caps,
            (
                out.leaves.capacity(),
                out.faces.capacity(),
                scratch.walk.stack.capacity(),
                scratch.planes.capacity()
            )
        );
    }
}
