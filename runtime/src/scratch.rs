//! Per-caller working memory for the walk, and the output lists.
//!
//! A [`Scratch`] belongs to one caller (one thread, one view) and is reused every frame: marks use
//! generation counters instead of being cleared, and every buffer keeps its capacity, so after
//! the first frame on a world nothing is allocated. Using a scratch with another world resizes it
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
    /// True when the marks were reused from the previous frame (same eye leaf).
    pub marks_reused: bool,
    /// Portals crossed by the portal backend.
    pub portals_crossed: u32,
    /// True when the portal backend stopped at its work budget.
    pub truncated: bool,
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
    /// Generation of the current leaf/node marks.
    pub(crate) mark_gen: u32,
    pub(crate) leaf_mark: Vec<u32>,
    pub(crate) node_mark: Vec<u32>,
    /// `(eye leaf)` the PVS marks were made for, when they are PVS marks.
    pub(crate) pvs_key: Option<u32>,
    pub(crate) pvs_marked: u32,
    /// Generation of the current frame, for face de-duplication.
    pub(crate) frame_gen: u32,
    pub(crate) face_mark: Vec<u32>,
    pub(crate) row: Bitset,
    pub(crate) stack: Vec<(i32, u8)>,
    // Portal search.
    pub(crate) on_path: Vec<bool>,
    pub(crate) planes: Vec<(Vec3A, f32)>,
    pub(crate) poly_a: Vec<Vec3A>,
    pub(crate) poly_b: Vec<Vec3A>,
    /// Counters of the last frame.
    pub stats: FrameStats,
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
        if self.world_id == world.id {
            return;
        }
        self.world_id = world.id;
        self.mark_gen = 0;
        self.frame_gen = 0;
        self.pvs_key = None;
        self.leaf_mark.clear();
        self.leaf_mark.resize(world.num_leaves(), 0);
        self.node_mark.clear();
        self.node_mark.resize(world.num_nodes(), 0);
        self.face_mark.clear();
        self.face_mark.resize(world.num_faces(), 0);
        self.on_path.clear();
        self.on_path.resize(world.num_leaves(), false);
        self.row.reset(world.num_clusters() as usize);
        self.stack.clear();
        self.stack.reserve(2 * world.depth() + 2);
        self.planes.reserve(256);
        self.poly_a.reserve(64);
        self.poly_b.reserve(64);
    }

    /// Start a new set of leaf/node marks; returns its generation.
    pub(crate) fn next_mark_gen(&mut self) -> u32 {
        self.mark_gen = self.mark_gen.wrapping_add(1);
        if self.mark_gen == 0 {
            self.leaf_mark.fill(0);
            self.node_mark.fill(0);
            self.mark_gen = 1;
        }
        self.pvs_key = None;
        self.mark_gen
    }

    /// Start a new frame; returns its generation (for face de-duplication).
    pub(crate) fn next_frame_gen(&mut self) -> u32 {
        self.frame_gen = self.frame_gen.wrapping_add(1);
        if self.frame_gen == 0 {
            self.face_mark.fill(0);
            self.frame_gen = 1;
        }
        self.frame_gen
    }

    /// Mark `leaf` and its ancestors with the current generation ("mark up the tree", stopping
    /// at the first ancestor already marked). Returns false when it was already marked.
    #[inline]
    pub(crate) fn mark_leaf(&mut self, world: &World, leaf: u32) -> bool {
        let gen_ = self.mark_gen;
        let Some(m) = self.leaf_mark.get_mut(leaf as usize) else { return false };
        if *m == gen_ {
            return false;
        }
        *m = gen_;
        let mut p = world.leaf_parent.get(leaf as usize).copied().unwrap_or(u32::MAX);
        while let Some(mark) = self.node_mark.get_mut(p as usize) {
            if *mark == gen_ {
                break;
            }
            *mark = gen_;
            p = world.node_parent.get(p as usize).copied().unwrap_or(u32::MAX);
        }
        true
    }

    /// Mark every open leaf of the world tree.
    pub(crate) fn mark_all(&mut self, world: &World) -> u32 {
        let gen_ = self.mark_gen;
        for &l in world.open_leaves() {
            if let Some(m) = self.leaf_mark.get_mut(l as usize) {
                *m = gen_;
            }
        }
        self.node_mark.fill(gen_);
        world.open_leaves().len() as u32
    }
}
