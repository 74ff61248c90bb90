//! The front-to-back walk over marked leaves with hierarchical frustum culling.
//!
//! Backends first mark the leaves they consider visible (and, with [`Scratch::mark_leaf`], every
//! ancestor: Quake's `R_MarkLeaves`). The walk then descends only into marked nodes, near child
//! first (the side of the node plane the eye is on; an eye exactly on the plane counts as front),
//! skips every node and leaf whose box is outside the frustum, and passes a plane mask down so a
//! child fully inside a plane never tests it again. The order is front to back: along any ray
//! from the eye, a leaf the ray crosses first is output first.

use crate::camera::{BoxSide, Frustum, View};
use crate::scratch::{Scratch, Visible};
use crate::world::World;

/// True when `child` (node or leaf code) carries the mark `mark`.
#[inline]
fn is_marked(scratch: &Scratch, child: i32, mark: u32) -> bool {
    if child >= 0 {
        scratch.node_mark.get(child as usize) == Some(&mark)
    } else {
        scratch.leaf_mark.get((!child) as usize) == Some(&mark)
    }
}

/// Output every marked leaf (the marks of the last [`crate::backend::pvs::Pvs::mark`] or backend
/// call on this scratch) that survives the frustum, front to back,
/// with its faces (each face once per frame).
pub fn walk_marked(world: &World, view: &View, scratch: &mut Scratch, out: &mut Visible) {
    out.clear();
    let mark = scratch.mark_gen;
    let frame = scratch.next_frame_gen();
    let fr = &view.frustum;
    let eye = view.eye;
    let mut visited = 0u32;
    let mut tests = 0u32;
    scratch.stack.clear();
    scratch.stack.push((world.root, Frustum::ALL));
    if !is_marked(scratch, world.root, mark) {
        scratch.stack.clear();
    }
    while let Some((child, mask)) = scratch.stack.pop() {
        visited += 1;
        if child >= 0 {
            let Some(node) = world.nodes.get(child as usize) else { continue };
            let mut mask = mask;
            if mask != 0 {
                tests += 1;
                match fr.test_box(node.center, node.extent, mask) {
                    BoxSide::Outside => continue,
                    BoxSide::Inside(m) => mask = m,
                }
            }
            // Near child first: push it last. Unmarked children are never pushed.
            let back_first = node.normal.dot(eye) - node.dist < 0.0;
            let [front, back] = node.children;
            let (near, far) = if back_first { (back, front) } else { (front, back) };
            if is_marked(scratch, far, mark) {
                scratch.stack.push((far, mask));
            }
            if is_marked(scratch, near, mark) {
                scratch.stack.push((near, mask));
            }
        } else {
            let l = (!child) as usize;
            let Some(leaf) = world.leaves.get(l) else { continue };
            if mask != 0 {
                tests += 1;
                if fr.test_box(leaf.center, leaf.extent, mask) == BoxSide::Outside {
                    continue;
                }
            }
            out.leaves.push(l as u32);
            let start = leaf.first_face as usize;
            let faces = world.leaf_faces.get(start..start + leaf.num_faces as usize).unwrap_or(&[]);
            for &f in faces {
                if let Some(m) = scratch.face_mark.get_mut(f as usize)
                    && *m != frame
                {
                    *m = frame;
                    out.faces.push(f);
                }
            }
        }
    }
    scratch.stats.nodes_visited = visited;
    scratch.stats.box_tests = tests;
}
