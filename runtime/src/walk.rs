//! The front-to-back walk over marked leaves with hierarchical frustum culling.
//!
//! Backends first choose a mark set (`layout`): a mark per leaf they consider visible and
//! per node with such a leaf below (Quake's `R_MarkLeaves`, but for the PVS precomputed at load
//! for every cluster). The walk then descends only into marked children, near child first (the
//! side of the node plane the eye is on; an eye exactly on the plane counts as front), skips every
//! node and leaf whose box is outside the frustum, and passes a plane mask down so a child fully
//! inside a plane never tests it again. The order is front to back: along any ray from the eye, a
//! leaf the ray crosses first is output first.
//!
//! Cost per visited node: the node record (pre-order, so descents read forwards), a mark test and a
//! branch-free eight-lane box test per child (the two tests are independent), and branch-free
//! pushes of the children that pass.
//!
//! With [`View::cull_back_faces`] a face is output only when the eye is not more than
//! [`crate::query::BACKFACE_EPSILON`] behind its plane (decided where the face is output, without
//! a branch on the decision, so there is no second pass; a culled face shared by several leaves
//! is not output by any of them).
//!
//! **Invariant:** both walks (over a cluster's PVS tree and over a mark set) output exactly what
//! `sightline_tests::runtime_check::reference_walk` (recursive, scalar, over the level's own tables)
//! outputs with the same view, back-face culling included: the same leaves, faces and order.
//! Tested on synthetic grids and on random poses of real maps.

use glam::Vec3A;

use crate::camera::{Frustum, View};
use crate::draw::DrawData;
use crate::layout::{MarkSet, SHARED_FACE, WalkTree};
use crate::pvs::ClusterTrees;
use crate::query::front_or_near;
use crate::scratch::{FrameStats, Scratch, Visible, WalkState};
use crate::world::World;

/// Which marks a walk reads; made by a backend ([`crate::backend::pvs::Pvs::mark`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Marks(Source);

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Source {
    /// Every open leaf.
    All,
    /// The PVS tree of a cluster (only made when the world keeps them).
    Cluster(u32),
    /// The marks in the caller's scratch.
    Scratch,
}

impl Marks {
    /// Every open leaf of the world tree.
    pub const ALL: Marks = Marks(Source::All);
    /// The marks the last backend call left in the scratch.
    pub(crate) const SCRATCH: Marks = Marks(Source::Scratch);

    /// The PVS tree of `cluster`.
    pub(crate) fn cluster(cluster: u32) -> Marks {
        Marks(Source::Cluster(cluster))
    }
}

/// Output every leaf of `marks` that survives the frustum, front to back, with its faces (each
/// face once per frame).
pub fn walk(world: &World, view: &View, marks: Marks, scratch: &mut Scratch, out: &mut Visible) {
    scratch.bind(world);
    let set = match marks.0 {
        Source::All => MarkSet { marks: world.all_marks(), gen_: 1 },
        Source::Cluster(c) => match world.cluster_trees() {
            Some(trees) => {
                walk_branches(world, view, trees, c, &mut scratch.walk, &mut scratch.stats, out);
                return;
            }
            None => MarkSet { marks: world.all_marks(), gen_: 1 },
        },
        Source::Scratch => MarkSet { marks: &scratch.marks, gen_: scratch.mark_gen },
    };
    walk_row(world, view, set, &mut scratch.walk, &mut scratch.stats, out);
}

/// Back-face culling for one frame: the draw data (face planes) and the eye.
#[derive(Clone, Copy)]
struct BackFaces<'a> {
    draw: &'a DrawData,
    eye: Vec3A,
}

impl<'a> BackFaces<'a> {
    /// The culling `view` asks for, if any.
    fn of(world: &'a World, view: &View) -> Option<Self> {
        view.cull_back_faces.then(|| Self { draw: world.draw(), eye: view.eye })
    }
}

/// True when face `f` is output under `cull`.
#[inline(always)]
fn keeps(cull: Option<BackFaces>, f: u32) -> bool {
    cull.is_none_or(|c| front_or_near(c.draw, f, c.eye))
}

/// Output leaf `l` of the walk tree and its faces not yet output this frame (and not culled).
#[inline(always)]
fn emit_leaf(
    tree: &WalkTree,
    l: usize,
    face_mark: &mut [u32],
    frame: u32,
    cull: Option<BackFaces>,
    out: &mut Visible,
) {
    let (Some(leaf), Some(after)) = (tree.leaves.get(l), tree.leaves.get(l + 1)) else { return };
    out.leaves.push(leaf.id & !SHARED_FACE);
    let entries = tree.faces.get(leaf.face_start as usize..after.face_start as usize).unwrap_or(&[]);
    if leaf.id & SHARED_FACE == 0 {
        match cull {
            None => out.faces.extend_from_slice(entries),
            Some(_) => {
                // Write every entry and advance past the kept ones: the keep decision (about
                // half the faces of a frame each way) does not branch.
                let start = out.faces.len();
                out.faces.resize(start + entries.len(), 0);
                let mut n = start;
                for &f in entries {
                    if let Some(slot) = out.faces.get_mut(n) {
                        *slot = f;
                    }
                    n += usize::from(keeps(cull, f));
                }
                out.faces.truncate(n);
            }
        }
        return;
    }
    for &e in entries {
        if e & SHARED_FACE == 0 {
            if keeps(cull, e) {
                out.faces.push(e);
            }
        } else if let Some(m) = face_mark.get_mut((e & !SHARED_FACE) as usize)
            && *m != frame
        {
            *m = frame;
            let f = e & !SHARED_FACE;
            if keeps(cull, f) {
                out.faces.push(f);
            }
        }
    }
}

/// The walk over a cluster's pruned PVS tree ([`ClusterTrees`]): the output of [`walk_row`] on
/// that cluster's marks, visiting only branch nodes and leaves. A child is tested with its own box
/// (the box of the branch node or leaf it is); the boxes of the skipped single-child chains above
/// it contain it and are not tested, so only a box within float rounding of a frustum plane could
/// be decided differently (tests compare both walks with the reference on real maps).
fn walk_branches(
    world: &World,
    view: &View,
    trees: &ClusterTrees,
    cluster: u32,
    st: &mut WalkState,
    stats: &mut FrameStats,
    out: &mut Visible,
) {
    let root = trees.root(cluster).and_then(|r| r.0);
    let nodes = trees.cluster_nodes(cluster);
    out.clear();
    let frame = st.next_frame_gen();
    let tree = world.walk_tree();
    let fr: &Frustum = &view.frustum;
    let eye = view.eye.to_array();
    let cull = BackFaces::of(world, view);
    let (mut visited, mut tests) = (0u32, 0u32);
    let stack = st.stack.as_mut_slice();
    let mut top = 0usize;
    let boxes = |e: u32| tree.elem_box.get(e as usize).copied().unwrap_or([[0.0; 3], [-1.0; 3]]);
    let mut next = None;
    // Touch the cluster's nodes once, with independent loads, so that the dependent loads of the
    // descent hit the cache: every frame in a new cluster starts cold.
    let mut touch = 0u32;
    for b in nodes.iter().step_by(3) {
        touch ^= b.node;
    }
    std::hint::black_box(touch);
    if let Some((code, elem)) = root {
        tests += 1;
        let [c, e] = boxes(elem);
        let (inside, mask) = fr.classify(c, e, Frustum::ALL);
        next = inside.then_some((code, mask));
    }
    while let Some((child, mask)) = next {
        visited += 1;
        if child >= 0 {
            if let Some(b) = trees.nodes.get(child as usize) {
                let [nx, ny, nz, d] = tree.planes.get(b.node as usize).copied().unwrap_or_default();
                // Same arithmetic as `Vec3A::dot`: (x + y) + z.
                let side = nx * eye[0] + ny * eye[1] + nz * eye[2] - d;
                let near = usize::from(side < 0.0);
                let far = near ^ 1;
                let [fc, fe] = boxes(b.child_elem[far]);
                let [nc, ne] = boxes(b.child_elem[near]);
                let (far_in, far_mask) = fr.classify(fc, fe, mask);
                let (near_in, near_mask) = fr.classify(nc, ne, mask);
                tests += 2 * u32::from(mask != 0);
                push(stack, &mut top, (b.child[far], far_mask), far_in);
                push(stack, &mut top, (b.child[near], near_mask), near_in);
            }
        } else {
            emit_leaf(tree, (!child) as usize, &mut st.face_mark, frame, cull, out);
        }
        next = pop(stack, &mut top);
    }
    stats.nodes_visited = visited;
    stats.box_tests = tests;
}

/// Write `entry` at `top` and advance past it when `keep`: the write is unconditional, so the
/// push does not branch (the stack has a spare slot).
#[inline(always)]
fn push(stack: &mut [(i32, u8)], top: &mut usize, entry: (i32, u8), keep: bool) {
    if let Some(slot) = stack.get_mut(*top) {
        *slot = entry;
        *top += usize::from(keep);
    }
}

/// The entry below `top`, if any.
#[inline(always)]
fn pop(stack: &[(i32, u8)], top: &mut usize) -> Option<(i32, u8)> {
    let t = top.checked_sub(1)?;
    *top = t;
    stack.get(t).copied()
}

/// The walk over one mark set (see the module docs). Children are tested at their parent, so
/// the stack only holds children that are marked and not outside the frustum, each with its own
/// plane mask. The stack is a slice of `depth + 3` slots (a pending far child per level, the
/// current slot, one spare), written unconditionally and advanced by the push condition, so
/// pushes do not branch.
fn walk_row(
    world: &World,
    view: &View,
    set: MarkSet,
    st: &mut WalkState,
    stats: &mut FrameStats,
    out: &mut Visible,
) {
    out.clear();
    let frame = st.next_frame_gen();
    let tree = world.walk_tree();
    let fr: &Frustum = &view.frustum;
    let eye = view.eye.to_array();
    let cull = BackFaces::of(world, view);
    let mut visited = 0u32;
    let mut tests = 0u32;
    let stack = st.stack.as_mut_slice();
    let mut top = 0usize;
    let mut next = None;
    if set.contains(tree.root_bit) {
        tests += 1;
        let (inside, mask) = fr.classify(tree.root_box.0, tree.root_box.1, Frustum::ALL);
        next = inside.then_some((tree.root, mask));
    }
    while let Some((child, mask)) = next {
        visited += 1;
        if child >= 0 {
            if let Some(node) = tree.nodes.get(child as usize) {
                // Same arithmetic as `Vec3A::dot`: (x + y) + z.
                let n = node.normal;
                let side = n[0] * eye[0] + n[1] * eye[1] + n[2] * eye[2] - node.dist;
                let near = usize::from(side < 0.0);
                let far = near ^ 1;
                let far_marked = set.contains(node.child_bit[far]);
                let near_marked = set.contains(node.child_bit[near]);
                let (far_in, far_mask) = fr.classify(node.center[far], node.extent[far], mask);
                let (near_in, near_mask) = fr.classify(node.center[near], node.extent[near], mask);
                tests += u32::from(mask != 0) * (u32::from(far_marked) + u32::from(near_marked));
                // Far first, so the near child is popped (and drawn) first.
                push(stack, &mut top, (node.child[far], far_mask), far_marked & far_in);
                push(stack, &mut top, (node.child[near], near_mask), near_marked & near_in);
            }
        } else {
            emit_leaf(tree, (!child) as usize, &mut st.face_mark, frame, cull, out);
        }
        next = pop(stack, &mut top);
    }
    stats.nodes_visited = visited;
    stats.box_tests = tests;
}
