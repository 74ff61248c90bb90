//! Outside fill and leak finding.
//!
//! The outside flood starts in every leaf that has a portal to the outside (the tree's box lies a
//! margin beyond every brush, so those leaves are the void around the world) and crosses portals
//! into leaves that are neither solid nor sky. It does not cross slivers
//! ([`crate::portals::is_sliver`]): two brushes that meet along an edge seal, as in qbsp. An entity whose origin lies in a reached leaf is a
//! **leak**: the path handed back is the breadth-first (fewest portals) path from that entity's
//! leaf to the outside, through portal centres.
//!
//! Entities are placed as Quake's tools place them: a point exactly on a plane goes to the back
//! ([`Tree::locate_back`]), so an entity on a brush's outer face is in the brush and ignored.
//!
//! Without a leak, the leaves worth keeping are those reachable through portals from an entity
//! origin that is not in solid; every other non-solid leaf (the outside and sealed-off pockets) is
//! filled solid so that it gets neither portals nor faces.

use std::collections::VecDeque;

use glam::DVec3;
use sightline_formats::{Contents, PlaneSet};

use crate::bsp::{Tree, TreeNode};
use crate::contents::blocks_outside;
use crate::portals::Portals;

/// A point that must stay inside the sealed world: an entity origin.
#[derive(Debug, Clone, Copy)]
pub struct Seed {
    /// The origin.
    pub point: DVec3,
    /// Index of the entity in the map.
    pub entity: usize,
}

/// What the flood found.
#[derive(Debug, Clone)]
pub struct Fill {
    /// Contents of every tree index after filling (interior nodes keep `Solid` as a placeholder).
    pub contents: Vec<Contents>,
    /// The first leaking seed (in seed order) and its path to the outside, when there is one.
    pub leak: Option<(Seed, Vec<DVec3>)>,
    /// Leaves turned solid.
    pub filled: usize,
    /// True when no seed lay in open space, so only the outside itself was filled.
    pub no_seed: bool,
}

/// Flood from the outside, look for leaks, and (unless there is one or `fill` is false) fill every
/// non-solid leaf that no seed reaches.
pub fn flood(tree: &Tree, planes: &PlaneSet, g: &Portals, seeds: &[Seed], fill: bool) -> Fill {
    let n = tree.nodes.len();
    let mut contents = tree.contents_by_node();
    let other_of = |id: u32, from: u32| {
        let p = &g.portals[id as usize];
        if p.nodes[0] == from { p.nodes[1] } else { p.nodes[0] }
    };

    // Outside flood, breadth first, remembering the portal each leaf was entered through.
    let mut parent = vec![u32::MAX; n];
    let mut reached = vec![false; n];
    let mut queue = VecDeque::new();
    for (id, p) in g.portals.iter().enumerate() {
        if !g.is_passable(id as u32) || !p.nodes.contains(&g.outside) {
            continue;
        }
        let leaf = other_of(id as u32, g.outside);
        if leaf != g.outside && !reached[leaf as usize] && !blocks_outside(contents[leaf as usize]) {
            reached[leaf as usize] = true;
            parent[leaf as usize] = id as u32;
            queue.push_back(leaf);
        }
    }
    while let Some(leaf) = queue.pop_front() {
        for &id in &g.by_node[leaf as usize] {
            if !g.is_passable(id) {
                continue;
            }
            let next = other_of(id, leaf);
            if next == g.outside || reached[next as usize] || blocks_outside(contents[next as usize]) {
                continue;
            }
            reached[next as usize] = true;
            parent[next as usize] = id;
            queue.push_back(next);
        }
    }

    let open_seeds: Vec<(Seed, u32)> = seeds
        .iter()
        .map(|s| (*s, tree.locate_back(planes, s.point)))
        .filter(|(_, leaf)| contents[*leaf as usize] != Contents::Solid)
        .collect();
    if let Some(&(seed, leaf)) = open_seeds.iter().find(|(_, leaf)| reached[*leaf as usize]) {
        let mut points = vec![seed.point];
        let mut cur = leaf;
        while cur != g.outside {
            let id = parent[cur as usize];
            let Some(p) = g.portals.get(id as usize) else { break };
            points.push(p.winding.center());
            cur = other_of(id, cur);
            if cur == g.outside {
                // One step beyond the box face, into the void.
                points.push(p.winding.center() - p.plane.normal * 16.0);
            }
        }
        return Fill { contents, leak: Some((seed, points)), filled: 0, no_seed: false };
    }
    if !fill {
        return Fill { contents, leak: None, filled: 0, no_seed: false };
    }

    let no_seed = open_seeds.is_empty();
    let mut keep = vec![false; n];
    if no_seed {
        for (i, t) in tree.nodes.iter().enumerate() {
            keep[i] = matches!(t, TreeNode::Leaf { .. }) && !reached[i];
        }
    } else {
        let mut queue: VecDeque<u32> = VecDeque::new();
        for &(_, leaf) in &open_seeds {
            if !keep[leaf as usize] {
                keep[leaf as usize] = true;
                queue.push_back(leaf);
            }
        }
        while let Some(leaf) = queue.pop_front() {
            for &id in &g.by_node[leaf as usize] {
                if !g.is_live(id) {
                    continue;
                }
                let next = other_of(id, leaf);
                if next == g.outside
                    || keep[next as usize]
                    || reached[next as usize]
                    || contents[next as usize] == Contents::Solid
                {
                    continue;
                }
                keep[next as usize] = true;
                queue.push_back(next);
            }
        }
    }
    let mut filled = 0;
    for (i, t) in tree.nodes.iter().enumerate() {
        if matches!(t, TreeNode::Leaf { .. }) && contents[i] != Contents::Solid && !keep[i] {
            contents[i] = Contents::Solid;
            filled += 1;
        }
    }
    Fill { contents, leak: None, filled, no_seed }
}

/// Points along a polyline every `step` units (the corners themselves included), as a pointfile
/// wants them.
pub fn sample_path(points: &[DVec3], step: f64) -> Vec<DVec3> {
    let mut out = Vec::new();
    for pair in points.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        let len = a.distance(b);
        let count = (len / step).ceil().max(1.0) as usize;
        for k in 0..count {
            out.push(a + (b - a) * (k as f64 / count as f64));
        }
    }
    if let Some(last) = points.last() {
        out.push(*last);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn path_samples_every_step() {
        let pts = sample_path(&[DVec3::ZERO, DVec3::new(20.0, 0.0, 0.0)], 8.0);
        assert_eq!(pts.first(), Some(&DVec3::ZERO));
        assert_eq!(pts.last(), Some(&DVec3::new(20.0, 0.0, 0.0)));
        assert!(pts.windows(2).all(|w| w[0].distance(w[1]) <= 8.0 + 1e-9));
        assert_eq!(pts.len(), 4);
    }
}
