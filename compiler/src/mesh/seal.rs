//! Which of a mesh's solid cells its triangles really enclose.
//!
//! The polygon BSP calls a cell solid when it lies behind the last triangle that split it. That
//! guess holds for a closed, consistently oriented mesh and fails for open edges, flipped, missing
//! or stray triangles. So it is checked before anything uses it: a solid cell stays solid only
//! while every portal between it and an open cell is covered by triangles lying on that portal's
//! plane (either orientation), up to cracks no wider than [`CRACK_WIDTH`](super::cover::CRACK_WIDTH) ([`super::cover`] says how). A solid cell with an
//! uncovered portal is reachable by sight, so it is opened and the check goes on from it: a flood
//! from the open cells through uncovered portals. What stays solid is enclosed by triangles, so the
//! tree blocks sight only where the mesh's faces do, and open geometry blocks nothing.
//!
//! The solid cells outside the mesh's box ([`Cover::boundary`]) are solid by construction: the
//! level's world ends there, as a map's filled outside does.

use std::collections::btree_map::Entry;
use std::collections::{BTreeMap, VecDeque};

use sightline_formats::{Aabb, Contents, PlaneSet, Winding};
use sightline_job::cancel::{Cancel, Cancelled};

use super::cover::PlaneCover;
use crate::bsp::{Tree, TreeNode};
use crate::portals::Portals;

/// The mesh's triangles by plane, and the cells that are solid by construction.
#[derive(Debug, Clone, Default)]
pub struct Cover {
    /// Triangles (as windings) by even plane index; each list keeps input order.
    by_plane: BTreeMap<u32, Vec<Winding>>,
    /// Tree indices of the solid leaves outside the mesh's box.
    pub boundary: Vec<u32>,
}

/// The solid cells [`Cover::open_unenclosed`] opened.
#[derive(Debug, Clone, PartialEq)]
pub struct Opened {
    /// How many.
    pub cells: usize,
    /// The box around them (empty when there are none).
    pub bounds: Aabb,
    /// Triangle-against-piece tests the cover checks made (each one a convex subtraction): the
    /// work of the check, near-linear in the triangles.
    pub tests: u64,
}

impl Cover {
    /// Remember `triangle` (a winding on plane `plane`).
    pub fn add(&mut self, plane: u32, triangle: Winding) {
        self.by_plane.entry(plane & !1).or_default().push(triangle);
    }

    /// Open every solid leaf of `tree` that sight reaches from an open leaf through portals of
    /// `g` that no triangle covers, and the leaves reached from those in turn. The result does not
    /// depend on the order of the flood: it is the set of solid leaves joined to an open leaf by a
    /// chain of uncovered portals. Stops with [`Cancelled`] (the tree unchanged) once `cancel` is
    /// set.
    pub fn open_unenclosed(
        &self,
        tree: &mut Tree,
        planes: &PlaneSet,
        g: &Portals,
        cancel: &Cancel,
    ) -> Result<Opened, Cancelled> {
        // Each plane's index is built when a portal on it is first checked.
        let mut index: BTreeMap<u32, PlaneCover<'_>> = BTreeMap::new();
        let n = tree.nodes.len();
        let mut fixed = vec![false; n];
        for &b in &self.boundary {
            if let Some(f) = fixed.get_mut(b as usize) {
                *f = true;
            }
        }
        let solid: Vec<bool> = tree
            .nodes
            .iter()
            .map(|node| matches!(node, TreeNode::Leaf { contents: Contents::Solid, .. }))
            .collect();
        let mut open: Vec<bool> = tree
            .nodes
            .iter()
            .zip(&solid)
            .map(|(node, &s)| matches!(node, TreeNode::Leaf { .. }) && !s)
            .collect();
        let mut queue: VecDeque<u32> = (0..n as u32).filter(|&i| open[i as usize]).collect();
        let mut opened = Vec::new();
        let mut tests = 0u64;
        while let Some(leaf) = queue.pop_front() {
            cancel.check()?;
            for &id in &g.by_node[leaf as usize] {
                let p = &g.portals[id as usize];
                let other = if p.nodes[0] == leaf { p.nodes[1] } else { p.nodes[0] };
                let o = other as usize;
                if other == g.outside || open[o] || fixed[o] || !solid[o] || p.winding.is_empty() {
                    continue;
                }
                let on_plane = p.plane_index.and_then(|i| Some((i, self.by_plane.get(&(i & !1))?)));
                let covered = match on_plane {
                    Some((i, triangles)) => {
                        let cover = match index.entry(i & !1) {
                            Entry::Occupied(e) => e.into_mut(),
                            Entry::Vacant(e) => e.insert(PlaneCover::new(triangles, cancel)?),
                        };
                        cover.covers(&p.winding, planes.get(i as usize).normal, &mut tests, cancel)?
                    }
                    None => false,
                };
                if !covered {
                    open[o] = true;
                    opened.push(other);
                    queue.push_back(other);
                }
            }
        }
        opened.sort_unstable();
        let mut bounds = Aabb::EMPTY;
        for &i in &opened {
            if let Some(TreeNode::Leaf { contents, bounds: b }) = tree.nodes.get_mut(i as usize) {
                *contents = Contents::Empty;
                bounds = bounds.union(b);
            }
        }
        Ok(Opened { cells: opened.len(), bounds, tests })
    }
}
