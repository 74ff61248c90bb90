//! The PVS backend: Quake's scheme with a plane-masked, front-to-back walk.
//!
//! When the world keeps every cluster's PVS as a pruned tree ([`World::pvs_trees_in_memory`],
//! every level within [`crate::pvs::CLUSTER_TREE_BUDGET`]), a frame costs one point location, a
//! lookup and the walk: nothing is decoded or marked per frame. Otherwise the eye cluster's row is decoded and its
//! leaves marked up the tree in the caller's scratch, only when the eye moves to another cluster.
//! The eye in solid, or a level without vis: everything.

use crate::backend::api::Backend;
use crate::camera::View;
use crate::scratch::{Scratch, Visible};
use crate::walk::{Marks, walk};
use crate::world::{LeafId, World};

/// The default backend; see the module docs.
#[derive(Debug, Clone, Copy, Default)]
pub struct Pvs;

impl Pvs {
    /// Choose the marks for the PVS of the cluster holding `eye_leaf` (everything when the level
    /// has no vis or the eye is in solid), decoding into the scratch only when the world keeps no
    /// cluster trees and the scratch does not hold that cluster's marks already. Sets
    /// `stats.marked_leaves` (leaves in the PVS) and `stats.marks_reused` (same cluster as the
    /// previous PVS frame on this scratch).
    pub fn mark(world: &World, eye_leaf: LeafId, scratch: &mut Scratch) -> Marks {
        scratch.bind(world);
        let cluster = world.leaf_cluster(eye_leaf).filter(|_| world.has_vis());
        let key = cluster.unwrap_or(u32::MAX);
        scratch.stats.marks_reused = scratch.pvs_key == Some(key);
        scratch.pvs_key = Some(key);
        let Some(c) = cluster else {
            scratch.stats.marked_leaves = world.open_leaves().len() as u32;
            return Marks::ALL;
        };
        if let Some((_, leaves)) = world.cluster_trees().and_then(|t| t.root(c)) {
            scratch.stats.marked_leaves = leaves;
            return Marks::cluster(c);
        }
        if scratch.marks_key != Some(key) {
            scratch.next_marks();
            let mut row = std::mem::take(&mut scratch.row);
            world.decode_pvs(c, &mut row);
            let mut marked = 0;
            for visible in row.iter_ones() {
                for &e in world.cluster_elements(visible as u32) {
                    world.walk_tree().mark_element(&mut scratch.marks, scratch.mark_gen, e);
                    marked += 1;
                }
            }
            scratch.row = row;
            scratch.marks_key = Some(key);
            scratch.marks_count = marked;
        }
        scratch.stats.marked_leaves = scratch.marks_count;
        Marks::SCRATCH
    }
}

impl Backend for Pvs {
    fn name(&self) -> &'static str {
        "pvs"
    }

    fn cull(&self, world: &World, view: &View, scratch: &mut Scratch, out: &mut Visible) {
        let eye_leaf = world.leaf_at(view.eye);
        let marks = Self::mark(world, eye_leaf, scratch);
        scratch.stats.portals_crossed = 0;
        scratch.stats.truncated = false;
        walk(world, view, marks, scratch, out);
    }
}
