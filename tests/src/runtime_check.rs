//! Brute-force reference answers of `sightline-runtime` that tests compare the fast queries
//! against. None of these walk the tree the way the queries do; they are slow and meant for
//! checking only. They read the world through its public queries ([`World::root`],
//! [`World::node`]).

use glam::Vec3A;

use sightline_runtime::{Bitset, Frustum, LeafId, View, Visible, World};

/// Every leaf region of the world tree as the list of half-spaces on its path from the root:
/// `(normal, dist, front)` means `normal · p - dist >= 0` when `front`, `< 0` otherwise. A leaf
/// shared by several parents (Quake's solid leaf 0) has one region per path.
#[derive(Debug, Clone)]
pub struct LeafRegions {
    regions: Vec<(LeafId, Vec<HalfSpace>)>,
}

/// One constraint of a leaf region: `(normal, dist, front)`.
pub type HalfSpace = (Vec3A, f32, bool);

impl LeafRegions {
    /// Collect the regions (depth-first from the world root).
    pub fn new(world: &World) -> Self {
        let mut regions = Vec::new();
        let mut stack = vec![(world.root(), Vec::new())];
        while let Some((child, path)) = stack.pop() {
            if child < 0 {
                regions.push(((!child) as LeafId, path));
                continue;
            }
            let Some(node) = world.node(child as u32) else { continue };
            for (k, &c) in node.children.iter().enumerate() {
                let mut p: Vec<HalfSpace> = path.clone();
                p.push((node.normal, node.dist, k == 0));
                stack.push((c, p));
            }
        }
        Self { regions }
    }

    /// Number of regions.
    pub fn len(&self) -> usize {
        self.regions.len()
    }

    /// True when there is none.
    pub fn is_empty(&self) -> bool {
        self.regions.is_empty()
    }

    /// Every leaf whose region holds `p` (exactly one for a correct tree and a finite point).
    pub fn leaves_at(&self, p: Vec3A) -> Vec<LeafId> {
        self.regions
            .iter()
            .filter(|(_, path)| path.iter().all(|&(n, d, front)| (n.dot(p) - d >= 0.0) == front))
            .map(|(l, _)| *l)
            .collect()
    }
}

/// The leaves a segment crosses, in order of first appearance, found by calling
/// [`World::leaf_at`] at `samples + 1` evenly spaced points.
pub fn sampled_leaves(world: &World, from: Vec3A, to: Vec3A, samples: usize) -> Vec<(f32, LeafId)> {
    let mut out: Vec<(f32, LeafId)> = Vec::new();
    let n = samples.max(1);
    for i in 0..=n {
        let t = i as f32 / n as f32;
        let leaf = world.leaf_at(from + (to - from) * t);
        if out.last().is_none_or(|&(_, l)| l != leaf) {
            out.push((t, leaf));
        }
    }
    out
}

/// Front-to-back check of an output list: for each output leaf, sample the segment from the eye
/// to its box centre; every other output leaf crossed on the way (in the open part before the
/// segment first meets solid) occludes-or-precedes it and must come earlier in the list. Returns
/// the violating `(earlier-in-list, later-in-list)` pairs.
pub fn order_violations(
    world: &World,
    eye: Vec3A,
    leaves: &[LeafId],
    samples: usize,
) -> Vec<(LeafId, LeafId)> {
    let mut position = std::collections::HashMap::new();
    for (i, &l) in leaves.iter().enumerate() {
        position.insert(l, i);
    }
    let mut bad = Vec::new();
    for (i, &target) in leaves.iter().enumerate() {
        let Some(b) = world.leaf_bounds(target) else { continue };
        for (_, crossed) in sampled_leaves(world, eye, b.center, samples) {
            if crossed == target {
                break;
            }
            if let Some(&j) = position.get(&crossed)
                && j > i
            {
                bad.push((target, crossed));
            }
        }
    }
    bad
}

/// The straightforward front-to-back walk the fast walks must reproduce exactly: recursive over
/// the level's own node and leaf tables, marks recomputed from scratch (a leaf is marked when
/// `marked(leaf)`, a node when some open leaf below it is), each box tested plane by plane in
/// scalar code with the plane mask passed down, near child (the eye's side, front when on the
/// plane) first, each face output at its first leaf unless [`View::cull_back_faces`] drops it.
/// Slow; for tests.
pub fn reference_walk(world: &World, view: &View, marked: &dyn Fn(LeafId) -> bool) -> Visible {
    let mut out = Visible::default();
    let mut seen = std::collections::HashSet::new();
    let mut any_below = std::collections::HashMap::new();
    if subtree_marked(world, world.root(), marked, &mut any_below) {
        reference_visit(world, view, world.root(), Frustum::ALL, &any_below, marked, &mut seen, &mut out);
    }
    out
}

/// Whether any open, marked leaf is below `child`, memoised per node.
fn subtree_marked(
    world: &World,
    child: i32,
    marked: &dyn Fn(LeafId) -> bool,
    memo: &mut std::collections::HashMap<i32, bool>,
) -> bool {
    if child < 0 {
        let l = (!child) as LeafId;
        return world.leaf_contents(l).is_some_and(|c| c.is_open()) && marked(l);
    }
    let Some(node) = world.node(child as u32) else { return false };
    let children = node.children;
    let any = children.iter().fold(false, |acc, &c| subtree_marked(world, c, marked, memo) | acc);
    memo.insert(child, any);
    any
}

#[allow(clippy::too_many_arguments)]
fn reference_visit(
    world: &World,
    view: &View,
    child: i32,
    mask: u8,
    any_below: &std::collections::HashMap<i32, bool>,
    marked: &dyn Fn(LeafId) -> bool,
    seen: &mut std::collections::HashSet<u32>,
    out: &mut Visible,
) {
    if child >= 0 {
        let Some(node) = world.node(child as u32) else { return };
        let Some(mask) = scalar_box_test(&view.frustum, node.bounds.center, node.bounds.extent, mask) else {
            return;
        };
        let back_first = node.normal.dot(view.eye) - node.dist < 0.0;
        let [front, back] = node.children;
        let (near, far) = if back_first { (back, front) } else { (front, back) };
        for c in [near, far] {
            let is_marked = if c >= 0 {
                any_below.get(&c).copied().unwrap_or(false)
            } else {
                let l = (!c) as LeafId;
                world.leaf_contents(l).is_some_and(|k| k.is_open()) && marked(l)
            };
            if is_marked {
                reference_visit(world, view, c, mask, any_below, marked, seen, out);
            }
        }
    } else {
        let l = (!child) as LeafId;
        let Some(b) = world.leaf_bounds(l) else { return };
        if scalar_box_test(&view.frustum, b.center, b.extent, mask).is_none() {
            return;
        }
        out.leaves.push(l);
        for &f in world.leaf_faces(l) {
            if seen.insert(f) && (!view.cull_back_faces || front_or_near(world, f, view.eye)) {
                out.faces.push(f);
            }
        }
    }
}

/// Whether `face` is kept by [`View::cull_back_faces`] for an eye at `eye`: the runtime's one
/// copy of the rule ([`World::cull_back_faces`]), asked about a single face.
fn front_or_near(world: &World, face: u32, eye: Vec3A) -> bool {
    let mut one = vec![face];
    world.cull_back_faces(eye, &mut one);
    !one.is_empty()
}

/// The plane-by-plane box test: `None` when outside a plane of `mask`, else the planes the box
/// still crosses.
pub fn scalar_box_test(fr: &Frustum, center: Vec3A, extent: Vec3A, mask: u8) -> Option<u8> {
    let mut out = mask;
    for (i, (n, d)) in fr.planes().into_iter().enumerate() {
        if mask & (1 << i) == 0 {
            continue;
        }
        let dist = n.dot(center) - d;
        let radius = n.abs().dot(extent);
        if dist + radius < 0.0 {
            return None;
        }
        if dist - radius >= 0.0 {
            out &= !(1 << i);
        }
    }
    Some(out)
}

/// The leaves in the PVS of the cluster holding `eye` (every open leaf without vis or with the
/// eye in solid), from the RLE row, for [`reference_walk`].
pub fn pvs_leaves(world: &World, eye: Vec3A) -> Vec<bool> {
    let mut marked = vec![false; world.num_leaves()];
    let cluster = world.leaf_cluster(world.leaf_at(eye)).filter(|_| world.has_vis());
    match cluster {
        Some(c) => {
            let mut row = Bitset::new(0);
            world.decode_pvs(c, &mut row);
            for v in row.iter_ones() {
                for &l in world.cluster_leaves(v as u32) {
                    marked[l as usize] = true;
                }
            }
        }
        None => marked.fill(true),
    }
    marked
}
