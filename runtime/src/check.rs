//! Brute-force reference answers that tests and tools compare the fast queries against. None of
//! these walk the tree the way the queries do; they are slow and meant for checking only.

use glam::Vec3A;

use crate::world::{LeafId, World};

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
        let mut stack = vec![(world.root, Vec::new())];
        while let Some((child, path)) = stack.pop() {
            if child < 0 {
                regions.push(((!child) as LeafId, path));
                continue;
            }
            let Some(node) = world.nodes.get(child as usize) else { continue };
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
