//! The walk's own copy of the world tree, laid out for the per-frame walk.
//!
//! # Layout
//! - The world tree's interior nodes and **open** leaves are numbered together in pre-order,
//!   front child (`children[0]`) first: these numbers are *elements*, and a subtree's elements are
//!   a contiguous range. A visible set is a [`MarkSet`]: generation marks per element (a leaf is
//!   marked when potentially visible, a node when some leaf below it is), so a new set needs no
//!   clearing. One element past the last (the *sentinel*) is never marked; solid leaves have no
//!   element and their parents point at the sentinel, so the walk tests one mark per child and
//!   needs no other case.
//! - [`TNode`]: 80 bytes with the plane and, for each child, its box (centre/half-size), its index
//!   in [`WalkTree::nodes`] or [`WalkTree::leaves`] and its element: both children are tested
//!   against the frustum at their parent (two independent tests), so a culled child is never
//!   loaded. Nodes and leaves are stored in pre-order too, so a front-first descent reads memory
//!   forwards. The root's box is [`WalkTree::root_box`].
//! - [`TLeaf`]: 8 bytes, start of its face entries and the leaf's id in the level. The entries of
//!   leaf `i` are `faces[leaves[i].face_start..leaves[i + 1].face_start]` (a sentinel leaf closes
//!   the last range). An entry carries [`SHARED_FACE`] when its face is listed more than once
//!   among the open leaves (split faces), so only those pay for de-duplication.
//!
//! Everything is built from the validated [`Tree`] (this module sits below [`crate::world`], which
//! owns the result); every index stored is in range by construction, and the walk still reads
//! with `get`, so no query can panic.

use crate::tree::{Tree, WLeaf};

/// Flag on an entry of [`WalkTree::faces`]: the face appears in more than one entry.
pub(crate) const SHARED_FACE: u32 = 1 << 31;
/// "No element" (solid or out-of-tree leaf, or the root's parent).
pub(crate) const NO_ELEMENT: u32 = u32::MAX;

/// A child waiting to be laid out: its code in the level, the parent's slot in `nodes` and which
/// child it is (none for the root), the parent's element.
type Pending = (i32, Option<(usize, usize)>, u32);

/// An interior node for the walk (see the module docs).
#[derive(Debug, Clone, Copy)]
#[repr(C, align(16))]
pub(crate) struct TNode {
    /// Box of each child (zero for a solid leaf, which is never tested).
    pub center: [[f32; 3]; 2],
    pub extent: [[f32; 3]; 2],
    pub normal: [f32; 3],
    pub dist: f32,
    /// `>= 0`: index in [`WalkTree::nodes`]; `< 0`: `!index` in [`WalkTree::leaves`].
    pub child: [i32; 2],
    /// Element of each child (the sentinel for a solid leaf).
    pub child_bit: [u32; 2],
}

/// An open leaf for the walk (see the module docs).
#[derive(Debug, Clone, Copy, Default)]
#[repr(C)]
pub(crate) struct TLeaf {
    pub face_start: u32,
    /// Index of the leaf in the level (below 2³¹: leaves are reached through `i32` child codes),
    /// with [`SHARED_FACE`] set when one of its face entries is shared.
    pub id: u32,
}

/// The walk layout of a world (see the module docs).
#[derive(Debug, Clone, Default)]
pub(crate) struct WalkTree {
    pub nodes: Vec<TNode>,
    /// Open leaves in pre-order, then one sentinel closing the last face range.
    pub leaves: Vec<TLeaf>,
    pub faces: Vec<u32>,
    /// The root as a child code (node index, or `!leaf index`); `root_bit` its element.
    pub root: i32,
    pub root_bit: u32,
    /// Box of the root (centre, half-size).
    pub root_box: ([f32; 3], [f32; 3]),
    /// Parent element of every element ([`NO_ELEMENT`] for the root).
    pub parent: Vec<u32>,
    /// Box of every element (centre, half-size), for walks that test a child by its element.
    pub elem_box: Vec<[[f32; 3]; 2]>,
    /// Plane of every node of `nodes` (normal, distance), compact.
    pub planes: Vec<[f32; 4]>,
    /// Element of every level leaf ([`NO_ELEMENT`] when it is solid or outside the world tree).
    pub leaf_bit: Vec<u32>,
}

/// A set of elements as generation marks: element `e` is in it when `marks[e] == gen_`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct MarkSet<'a> {
    pub marks: &'a [u32],
    pub gen_: u32,
}

impl MarkSet<'_> {
    /// True when element `e` is in the set (false out of range).
    #[inline]
    pub fn contains(&self, e: u32) -> bool {
        self.marks.get(e as usize) == Some(&self.gen_)
    }
}

impl WalkTree {
    /// Lay out the world tree of `tree` (its root and every child index are in range and form a
    /// tree).
    pub fn build(tree: &Tree) -> Self {
        let (root, nodes, leaves) = (tree.root, &tree.nodes, &tree.leaves);
        let (leaf_faces, num_faces) = (&tree.leaf_faces, tree.num_faces);
        let mut t = WalkTree { leaf_bit: vec![NO_ELEMENT; leaves.len()], ..WalkTree::default() };
        let mut uses = vec![0u8; num_faces];
        // (child code in the level, parent node slot in `t.nodes` and which child, parent element)
        let mut stack: Vec<Pending> = vec![(root, None, NO_ELEMENT)];
        let mut leaf_ids = Vec::new();
        while let Some((code, slot, parent_elem)) = stack.pop() {
            let link = if code >= 0 {
                let Some(n) = nodes.get(code as usize) else { continue };
                let elem = t.parent.len() as u32;
                t.parent.push(parent_elem);
                t.elem_box.push([n.center.to_array(), n.extent.to_array()]);
                t.planes.push([n.normal.x, n.normal.y, n.normal.z, n.dist]);
                let index = t.nodes.len();
                t.nodes.push(TNode {
                    center: [[0.0; 3]; 2],
                    extent: [[0.0; 3]; 2],
                    normal: n.normal.to_array(),
                    dist: n.dist,
                    child: [0; 2],
                    child_bit: [NO_ELEMENT; 2],
                });
                // Back pushed first so that the front subtree is numbered first.
                stack.push((n.children[1], Some((index, 1)), elem));
                stack.push((n.children[0], Some((index, 0)), elem));
                Some((index as i32, elem, (n.center.to_array(), n.extent.to_array())))
            } else {
                let id = (!code) as usize;
                match leaves.get(id) {
                    Some(l) if l.contents.is_open() && l.in_tree => {
                        let elem = t.parent.len() as u32;
                        t.parent.push(parent_elem);
                        t.elem_box.push([l.center.to_array(), l.extent.to_array()]);
                        if let Some(b) = t.leaf_bit.get_mut(id) {
                            *b = elem;
                        }
                        let index = leaf_ids.len();
                        leaf_ids.push(id);
                        Some((!(index as i32), elem, (l.center.to_array(), l.extent.to_array())))
                    }
                    _ => None,
                }
            };
            match (slot, link) {
                (None, Some((child, elem, bounds))) => {
                    t.root = child;
                    t.root_bit = elem;
                    t.root_box = bounds;
                }
                (Some((p, k)), Some((child, elem, (center, extent)))) => {
                    if let Some(parent) = t.nodes.get_mut(p) {
                        parent.child[k] = child;
                        parent.child_bit[k] = elem;
                        parent.center[k] = center;
                        parent.extent[k] = extent;
                    }
                }
                (_, None) => {}
            }
        }
        let sentinel = t.parent.len() as u32;
        if t.parent.is_empty() {
            t.root_bit = sentinel;
        }
        for n in &mut t.nodes {
            for b in &mut n.child_bit {
                if *b == NO_ELEMENT {
                    *b = sentinel;
                }
            }
        }

        // Faces, in leaf order, flagged when listed more than once.
        let faces_of = |l: &WLeaf| {
            let start = l.first_face as usize;
            leaf_faces.get(start..start + l.num_faces as usize).unwrap_or(&[])
        };
        for &id in &leaf_ids {
            for &f in leaves.get(id).map_or(&[][..], faces_of) {
                if let Some(u) = uses.get_mut(f as usize) {
                    *u = u.saturating_add(1);
                }
            }
        }
        for &id in &leaf_ids {
            let Some(l) = leaves.get(id) else { continue };
            let face_start = t.faces.len() as u32;
            let mut any_shared = 0;
            for &f in faces_of(l) {
                let shared = if uses.get(f as usize).is_some_and(|&u| u > 1) { SHARED_FACE } else { 0 };
                any_shared |= shared;
                t.faces.push(f | shared);
            }
            t.leaves.push(TLeaf { face_start, id: id as u32 | any_shared });
        }
        t.leaves.push(TLeaf { face_start: t.faces.len() as u32, ..TLeaf::default() });
        t
    }

    /// Slots of a mark array: every element and the sentinel.
    pub fn mark_slots(&self) -> usize {
        self.parent.len() + 1
    }

    /// Mark level leaf `leaf` and its ancestors with `gen_` (stopping at the first ancestor
    /// already marked). False when the leaf has no element or was already marked.
    #[inline]
    pub fn mark_leaf(&self, marks: &mut [u32], gen_: u32, leaf: u32) -> bool {
        let Some(&elem) = self.leaf_bit.get(leaf as usize) else { return false };
        self.mark_element(marks, gen_, elem)
    }

    /// Mark element `elem` and its ancestors, as [`WalkTree::mark_leaf`].
    #[inline]
    pub fn mark_element(&self, marks: &mut [u32], gen_: u32, elem: u32) -> bool {
        if !set_mark(marks, gen_, elem) {
            return false;
        }
        let mut e = self.parent.get(elem as usize).copied().unwrap_or(NO_ELEMENT);
        while e != NO_ELEMENT && set_mark(marks, gen_, e) {
            e = self.parent.get(e as usize).copied().unwrap_or(NO_ELEMENT);
        }
        true
    }
}

/// Mark element `e` with `gen_`; true when it was not marked (false also out of range).
#[inline]
fn set_mark(marks: &mut [u32], gen_: u32, e: u32) -> bool {
    match marks.get_mut(e as usize) {
        Some(m) if *m != gen_ => {
            *m = gen_;
            true
        }
        _ => false,
    }
}
