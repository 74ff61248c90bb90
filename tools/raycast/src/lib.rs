//! Bounding volume hierarchy over triangles for ray casting.
//!
//! A binary BVH built top-down with a binned surface-area heuristic (16 bins per axis, leaves of at
//! most four triangles, `MAX_LEAF`), stored as a flat array of 32-byte nodes (the two children of an
//! interior node are adjacent) for the build and `groups`; rays traverse the tree collapsed to
//! 4-wide nodes (four children's boxes in SIMD lanes, tested at once; subtrees of at most
//! `MERGE_LEAF` triangles become one leaf) with a small explicit stack,
//! entered children nearest first, and test a leaf's triangles four at a time (one triangle per
//! SIMD lane, the same arithmetic as the one-triangle test, so the same hits). Box queries
//! (`overlapping`) walk the same 4-wide tree.
//!
//! # Conventions
//! - Rays are `origin + t * dir` with `dir` not necessarily normalised; `t` is in units of `dir`.
//!   A hit counts when `0 < t < t_max` (the origin itself is excluded, so a ray leaving a surface
//!   does not hit it at `t = 0`).
//! - Triangles are two-sided. `u`, `v` are barycentric coordinates: the hit point is
//!   `v0 + u * (v1 - v0) + v * (v2 - v0)`.
//! - `triangle` in a [`Hit`] is the index into the slice given to [`Bvh::build`].
//! - The triangle test is watertight (Woop et al. 2013) in `f32`: a ray through a shared edge or
//!   corner of a closed mesh cannot slip between its triangles. Degenerate (zero-area) triangles
//!   never hit.
//! - Results are deterministic: among hits at exactly equal `t` the one found first in the fixed
//!   traversal order wins.
//!
//! # Modules
//! - `build`: the binned-SAH build of the binary tree; `collapse`: the 4-wide traversal tree.
//! - `node`: the nodes and triangle blocks as stored; `triangle`: the watertight triangle test.
//! - `traverse`: one ray at a time; `packet`: up to 16 rays at once; `stack`: the one-ray
//!   traversal stack.
//! - `query`: box queries ([`Bvh::overlapping`]) and triangle groups ([`Bvh::groups`]).
//! - `brute`: [`intersect_brute`], the reference the tree is tested against.

// `unsafe` is denied workspace-wide. Only two places need it, each allowed where it is: calling
// the AVX-512/AVX2 builds of the packet kernel after checking the CPU has them (`packet`), and
// reading the one-ray traversal stack's uninitialised storage (`stack`).

mod brute;
mod build;
mod collapse;
mod node;
mod packet;
mod query;
mod stack;
mod traverse;
mod triangle;

#[cfg(test)]
mod tests;

pub use brute::{intersect_brute, intersect_brute_front};

use node::{Block, Node, Quad};

/// Most triangles in one leaf.
pub(crate) const MAX_LEAF: usize = 4;
/// Deepest tree the traversal stack holds; the build makes a (large) leaf rather than go deeper.
pub(crate) const STACK: usize = 96;
/// Factor widening a box's far distance (a few ulps), so that rounding in the slab test never culls
/// a box holding a hit the watertight triangle test reports.
pub(crate) const WIDEN: f32 = 1.0 + 4.0 * f32::EPSILON;
/// Traversal stack of the 4-wide tree for trees whose deepest path needs at most this many entries
/// (nearly all: a smaller stack is faster to set up per ray).
pub(crate) const STACK_SMALL: usize = 40;
/// Traversal stack of any 4-wide tree: it is no deeper than the binary tree, and a quad pushes at
/// most three children.
pub(crate) const STACK_DEEP: usize = 3 * STACK;

/// A ray hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit (`origin + t * dir`).
    pub t: f32,
    /// Index of the triangle in the build slice.
    pub triangle: u32,
    /// Barycentric coordinate along `v1 - v0`.
    pub u: f32,
    /// Barycentric coordinate along `v2 - v0`.
    pub v: f32,
}

/// A BVH over a triangle soup.
#[derive(Debug, Clone)]
pub struct Bvh {
    nodes: Vec<Node>,
    /// The 4-wide traversal tree, see [`Quad`].
    quads: Vec<Quad>,
    /// True when a ray may need more than [`STACK_SMALL`] stack entries.
    deep: bool,
    /// The leaves' triangles in [`Block`]s (the only copy of the geometry); leaf children of quads
    /// (and a leaf root) index these.
    blocks: Vec<Block>,
    ids: Vec<u32>,
}

impl Bvh {
    /// Number of triangles the tree holds (non-finite input triangles are left out).
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// True when the tree holds no triangle.
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// Number of nodes (for statistics).
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Bytes the tree holds on the heap (nodes, traversal nodes, triangle blocks and ids; the
    /// vectors' lengths, not their capacities).
    pub fn heap_bytes(&self) -> usize {
        use std::mem::size_of_val;
        size_of_val(self.nodes.as_slice())
            + size_of_val(self.quads.as_slice())
            + size_of_val(self.blocks.as_slice())
            + size_of_val(self.ids.as_slice())
    }
}
