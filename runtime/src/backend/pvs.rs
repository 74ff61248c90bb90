//! The PVS backend: Quake's scheme with a plane-masked, front-to-back walk.
//!
//! The eye cluster's row is decoded, and its leaves marked up the tree, only when the eye moves
//! to another cluster; a frame in the same cluster costs one point location and the walk.

use crate::backend::Backend;
use crate::camera::View;
use crate::scratch::{Scratch, Visible};
use crate::walk::walk_marked;
use crate::world::{LeafId, World};

/// The default backend; see the module docs.
#[derive(Debug, Clone, Copy, Default)]
pub struct Pvs;

impl Pvs {
    /// Mark the PVS of the cluster holding `eye_leaf` (everything when the level has no vis or the
    /// eye is in solid), unless the marks already are for that cluster. Returns the number of
    /// leaves marked.
    pub fn mark(world: &World, eye_leaf: LeafId, scratch: &mut Scratch) -> u32 {
        scratch.bind(world);
        let cluster = world.leaf_cluster(eye_leaf).filter(|_| world.has_vis());
        let key = cluster.unwrap_or(u32::MAX);
        if scratch.pvs_key == Some(key) {
            scratch.stats.marks_reused = true;
            return scratch.pvs_marked;
        }
        scratch.stats.marks_reused = false;
        scratch.next_mark_gen();
        let marked = match cluster {
            Some(c) => {
                let mut row = std::mem::take(&mut scratch.row);
                world.decode_pvs(c, &mut row);
                let mut marked = 0;
                for visible in row.iter_ones() {
                    for &l in world.cluster_leaves(visible as u32) {
                        scratch.mark_leaf(world, l);
                        marked += 1;
                    }
                }
                scratch.row = row;
                marked
            }
            None => scratch.mark_all(world),
        };
        scratch.pvs_key = Some(key);
        scratch.pvs_marked = marked;
        marked
    }
}

impl Backend for Pvs {
    fn name(&self) -> &'static str {
        "pvs"
    }

    fn supports(&self, _world: &World) -> bool {
        true
    }

    fn cull(&self, world: &World, view: &View, scratch: &mut Scratch, out: &mut Visible) {
        let eye_leaf = world.leaf_at(view.eye);
        let marked = Self::mark(world, eye_leaf, scratch);
        scratch.stats.marked_leaves = marked;
        scratch.stats.portals_crossed = 0;
        scratch.stats.truncated = false;
        walk_marked(world, view, scratch, out);
    }
}
