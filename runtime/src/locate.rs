//! Point location: which leaf holds a point.

use glam::Vec3A;

use crate::world::{LeafId, World};

impl World {
    /// The leaf holding `p`: descend from the root, going to the front child when
    /// `normal · p - dist >= 0` (a point exactly on a plane is in front). Never fails: a
    /// non-finite point ends in some leaf (NaN compares as "front").
    #[inline]
    pub fn leaf_at(&self, p: impl Into<Vec3A>) -> LeafId {
        let p = p.into();
        let mut child = self.root;
        while child >= 0 {
            let Some(node) = self.nodes.get(child as usize) else { return 0 };
            child = node.children[usize::from(node.normal.dot(p) - node.dist < 0.0)];
        }
        (!child) as LeafId
    }
}
