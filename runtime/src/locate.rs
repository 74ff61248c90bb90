//! Point location: which leaf holds a point.
//!
//! [`LocateTree`] is a compact copy of the world tree for [`World::leaf_at`](crate::World::leaf_at):
//! 24-byte nodes (plane and children) in pre-order, front child first, so a descent reads few
//! cache lines mostly forwards. It makes the same decisions as descending the level's own nodes.

use glam::Vec3A;

use crate::tree::{LeafId, Tree};

/// A node of the [`LocateTree`]: plane (normal, distance) and children (`>= 0`: index in the
/// locate tree, `< 0`: `!leaf` with the level's leaf index).
#[derive(Debug, Clone, Copy)]
pub(crate) struct LNode {
    pub plane: [f32; 4],
    pub child: [i32; 2],
}

/// The world tree for point location (see the module docs).
#[derive(Debug, Clone, Default)]
pub(crate) struct LocateTree {
    nodes: Vec<LNode>,
    /// The root as a child code.
    root: i32,
}

impl LocateTree {
    /// Copy the world tree of `tree` in pre-order.
    pub fn build(tree: &Tree) -> Self {
        let nodes = &tree.nodes;
        let mut t = LocateTree { nodes: Vec::with_capacity(nodes.len()), root: tree.root };
        // (level child code, slot in `t.nodes` and which child to patch; none for the root)
        let mut stack: Vec<(i32, Option<(usize, usize)>)> = vec![(tree.root, None)];
        while let Some((code, slot)) = stack.pop() {
            let child = match nodes.get(usize::try_from(code).unwrap_or(usize::MAX)) {
                Some(n) => {
                    let index = t.nodes.len();
                    t.nodes
                        .push(LNode { plane: [n.normal.x, n.normal.y, n.normal.z, n.dist], child: [-1; 2] });
                    stack.push((n.children[1], Some((index, 1))));
                    stack.push((n.children[0], Some((index, 0))));
                    index as i32
                }
                None => code,
            };
            match slot {
                None => t.root = child,
                Some((p, k)) => {
                    if let Some(parent) = t.nodes.get_mut(p) {
                        parent.child[k] = child;
                    }
                }
            }
        }
        t
    }

    /// The leaf holding `p`: descend from the root, going to the front child when
    /// `normal · p - dist >= 0` (a point exactly on a plane is in front). Never fails: a
    /// non-finite point ends in some leaf (NaN compares as "front").
    #[inline]
    pub fn leaf_at(&self, p: Vec3A) -> LeafId {
        let p = p.to_array();
        let mut child = self.root;
        while child >= 0 {
            let Some(node) = self.nodes.get(child as usize) else { return 0 };
            let [nx, ny, nz, d] = node.plane;
            // Same arithmetic as `Vec3A::dot`: (x + y) + z.
            let side = nx * p[0] + ny * p[1] + nz * p[2] - d;
            child = node.child[usize::from(side < 0.0)];
        }
        (!child) as LeafId
    }
}
