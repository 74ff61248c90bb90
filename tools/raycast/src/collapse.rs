//! The binary tree collapsed into the 4-wide traversal tree.

use glam::Vec3;

use crate::MAX_LEAF;
use crate::node::{Block, Node, Prepared, Quad};

/// A child of a 4-wide node whose subtree holds at most this many triangles becomes one leaf (its
/// triangles in consecutive blocks) rather than a node of its own: a second block test costs less
/// than another node's box tests (+1.3 % GVS rays per second on the sphere cloud, the city's GVS
/// unchanged, ID-buffer rays +1 %: paired runs). 44 % of the 4-wide nodes had only two children,
/// mostly two leaves.
pub(crate) const MERGE_LEAF: u32 = 2 * MAX_LEAF as u32;

/// Every node's triangles as `first..end` build positions (a subtree's triangles are contiguous);
/// children come after their parent, so one backward pass finds them all.
pub(crate) fn subtree_ranges(nodes: &[Node]) -> Vec<(u32, u32)> {
    let mut range = vec![(0u32, 0u32); nodes.len()];
    for i in (0..nodes.len()).rev() {
        let n = &nodes[i];
        range[i] = if n.count() > 0 {
            (n.first(), n.first() + n.count())
        } else {
            let l = n.first() as usize;
            match (range.get(l), range.get(l + 1)) {
                (Some(a), Some(b)) => (a.0, b.1),
                _ => (0, 0),
            }
        };
    }
    range
}

/// Collapse the binary tree into [`Quad`]s (root quad first; empty when the root is a leaf), and
/// the most traversal stack entries a ray can need (a quad pushes all its children but one).
pub(crate) fn collapse(nodes: &[Node], tris: &[Prepared]) -> (Vec<Quad>, Vec<Block>, usize) {
    let half_area = |n: &Node| {
        let d = (n.hi - n.lo).truncate().max(Vec3::ZERO);
        d.x * d.y + d.y * d.z + d.z * d.x
    };
    let mut quads = Vec::new();
    let mut blocks = Vec::new();
    // A leaf root, or the empty tree (a root without triangles or children).
    if nodes.len() < 3 || nodes[0].count() > 0 {
        if let Some(root) = nodes.first() {
            blocks.extend(Block::of_leaf(tris, root.first(), root.count()));
        }
        return (quads, blocks, 0);
    }
    let range = subtree_ranges(nodes);
    quads.push(Quad::EMPTY);
    // Per quad: the most entries on the stack when a ray enters it.
    let mut stack_need = vec![0usize];
    let mut need = 0;
    let mut work = vec![(0usize, 0usize)];
    while let Some((bi, qi)) = work.pop() {
        let f = nodes[bi].first() as usize;
        let mut kids = [f, f + 1, 0, 0];
        let mut n = 2;
        while n < 4 {
            // The interior child with the largest box (the first of equals) opens.
            let mut open: Option<(usize, f32)> = None;
            for (i, &k) in kids[..n].iter().enumerate() {
                if nodes[k].count() == 0 && open.is_none_or(|(_, a)| half_area(&nodes[k]) > a) {
                    open = Some((i, half_area(&nodes[k])));
                }
            }
            let Some((i, _)) = open else { break };
            let g = nodes[kids[i]].first() as usize;
            kids.copy_within(i + 1..n, i + 2);
            kids[i] = g;
            kids[i + 1] = g + 1;
            n += 1;
        }
        let mut q = Quad::EMPTY;
        for (lane, &k) in kids[..n].iter().enumerate() {
            let node = &nodes[k];
            for axis in 0..3 {
                q.planes[2 * axis][lane] = node.lo[axis];
                q.planes[2 * axis + 1][lane] = node.hi[axis];
            }
            // A leaf, or a small subtree merged into one (its triangles are contiguous).
            let (a, b) = range[k];
            if node.count() > 0 || b - a <= MERGE_LEAF {
                (q.first[lane], q.count[lane]) = (blocks.len() as u32, b - a);
                blocks.extend(Block::of_leaf(tris, a, b - a));
            } else {
                q.first[lane] = quads.len() as u32;
                work.push((k, quads.len()));
                quads.push(Quad::EMPTY);
                stack_need.push(stack_need[qi] + n - 1);
            }
        }
        need = need.max(stack_need[qi] + n - 1);
        quads[qi] = q;
    }
    (quads, blocks, need)
}
