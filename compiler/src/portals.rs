//! Portals between the cells of a [`Tree`] (thesis §6.2.1, done the qbsp way).
//!
//! Six portals on the faces of the tree's bounding box join the root to a virtual **outside**
//! node. Then, top-down, each node gets a huge winding on its plane clipped by every portal around
//! the node (which is clipping by the ancestors' planes and the box), joining its front and back
//! children; the portals around the node are split by its plane and handed to the child on their
//! side. When the recursion ends, every portal joins two leaves (or a leaf and the outside).
//!
//! A portal's plane faces `nodes[0]`; its winding is clockwise seen from there. Windings are clipped
//! and split with [`ON_EPSILON`]; a piece left with fewer than three distinct corners (after
//! merging corners closer than [`ON_EPSILON`]) is dropped, as qbsp does, unless the caller asks
//! [`build_with`] to keep tiny pieces ([`TinyPieces::Keep`]): then such a piece keeps its unmerged
//! corners whenever they still span a plane, so no opening is lost for being small.

use sightline_formats::geom::ON_EPSILON;
use sightline_formats::{Aabb, Plane, PlaneSet, Winding};

use crate::bsp::{Tree, TreeNode};

/// A portal while it is being built.
#[derive(Debug, Clone)]
pub struct BuildPortal {
    /// Plane facing `nodes[0]`.
    pub plane: Plane,
    /// Plane index of the node that made it; `None` for the six box portals.
    pub plane_index: Option<u32>,
    /// Front then back node (tree indices; [`Portals::outside`] for the outside).
    pub nodes: [u32; 2],
    /// The opening.
    pub winding: Winding,
}

/// The portal graph of a tree.
#[derive(Debug, Clone)]
pub struct Portals {
    /// Every portal (each now between two leaves or a leaf and the outside).
    pub portals: Vec<BuildPortal>,
    /// For each tree index, the portals touching it (leaves only once built).
    pub by_node: Vec<Vec<u32>>,
    /// The index standing for the outside (`tree.nodes.len()`).
    pub outside: u32,
}

/// What happens to a piece of portal whose corners merge (within [`ON_EPSILON`]) to fewer than
/// three.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TinyPieces {
    /// Dropped, as qbsp does (the compiler's own portals).
    #[default]
    Drop,
    /// Kept with its unmerged corners when they still span a plane (portals rebuilt from a
    /// compiled BSP, which must round toward visible).
    Keep,
}

impl TinyPieces {
    /// The winding a finished piece becomes, or `None` when it is dropped.
    fn finish(self, w: Winding) -> Option<Winding> {
        let cleaned = w.cleaned(ON_EPSILON);
        if !cleaned.is_empty() {
            return Some(cleaned);
        }
        (self == TinyPieces::Keep && w.plane().is_some()).then_some(w)
    }
}

/// Portalize `tree`, whose volume is `bounds` (tiny pieces dropped, as qbsp).
pub fn build(tree: &Tree, planes: &PlaneSet, bounds: &Aabb) -> Portals {
    build_with(tree, planes, bounds, TinyPieces::Drop)
}

/// Portalize `tree`, whose volume is `bounds`, treating tiny pieces as `tiny` says.
pub fn build_with(tree: &Tree, planes: &PlaneSet, bounds: &Aabb, tiny: TinyPieces) -> Portals {
    let outside = tree.nodes.len() as u32;
    let mut g = Portals { portals: Vec::new(), by_node: vec![Vec::new(); tree.nodes.len()], outside };
    head_portals(&mut g, bounds);
    // Pre-order is index order, so an iterative pass over indices visits parents first.
    for index in 0..tree.nodes.len() as u32 {
        if let TreeNode::Node { plane, children, .. } = &tree.nodes[index as usize] {
            let plane_ref = planes.get(*plane as usize);
            make_node_portal(&mut g, index, *plane, plane_ref, *children, tiny);
            split_node_portals(&mut g, index, plane_ref, *children, tiny);
        }
    }
    g
}

fn head_portals(g: &mut Portals, bounds: &Aabb) {
    let mut box_planes = Vec::with_capacity(6);
    for axis in 0..3 {
        let mut n = glam::DVec3::ZERO;
        n[axis] = 1.0;
        box_planes.push(Plane { normal: n, dist: bounds.mins[axis] });
        box_planes.push(Plane { normal: -n, dist: -bounds.maxs[axis] });
    }
    for (i, p) in box_planes.iter().enumerate() {
        let mut w = Some(Winding::base_for_plane(p));
        for (j, q) in box_planes.iter().enumerate() {
            if i != j {
                w = w.and_then(|w| w.clip(q, ON_EPSILON, false));
            }
        }
        if let Some(winding) = w {
            add(g, BuildPortal { plane: *p, plane_index: None, nodes: [0, g.outside], winding });
        }
    }
}

fn add(g: &mut Portals, p: BuildPortal) {
    let id = g.portals.len() as u32;
    for n in p.nodes {
        if n != g.outside {
            g.by_node[n as usize].push(id);
        }
    }
    g.portals.push(p);
}

fn make_node_portal(
    g: &mut Portals,
    node: u32,
    plane_index: u32,
    plane: &Plane,
    children: [u32; 2],
    tiny: TinyPieces,
) {
    let mut w = Some(Winding::base_for_plane(plane));
    for &id in &g.by_node[node as usize] {
        let Some(cur) = w else { break };
        let p = &g.portals[id as usize];
        let clip = if p.nodes[0] == node { p.plane } else { p.plane.flipped() };
        w = cur.clip(&clip, ON_EPSILON, false);
    }
    if let Some(winding) = w.and_then(|w| tiny.finish(w)) {
        add(g, BuildPortal { plane: *plane, plane_index: Some(plane_index), nodes: children, winding });
    }
}

fn split_node_portals(g: &mut Portals, node: u32, plane: &Plane, children: [u32; 2], tiny: TinyPieces) {
    let list = std::mem::take(&mut g.by_node[node as usize]);
    for id in list {
        let p = &g.portals[id as usize];
        let side = if p.nodes[0] == node { 0 } else { 1 };
        let other = p.nodes[1 - side];
        if other != g.outside {
            let l = &mut g.by_node[other as usize];
            if let Some(pos) = l.iter().position(|&x| x == id) {
                l.remove(pos);
            }
        }
        let split = p.winding.split(plane, ON_EPSILON);
        let front = split.front.and_then(|w| tiny.finish(w));
        let back = split.back.and_then(|w| tiny.finish(w));
        let template = g.portals[id as usize].clone();
        let mut reuse = Some(id);
        for (child, piece) in [(children[0], front), (children[1], back)] {
            let Some(winding) = piece else { continue };
            let mut nodes = template.nodes;
            nodes[side] = child;
            let portal = BuildPortal { winding, nodes, ..template.clone() };
            match reuse.take() {
                Some(id) => {
                    g.portals[id as usize] = portal;
                    for n in nodes {
                        if n != g.outside {
                            g.by_node[n as usize].push(id);
                        }
                    }
                }
                None => add(g, portal),
            }
        }
        if let Some(id) = reuse {
            // Nothing left: the portal vanishes (an empty winding nobody refers to).
            g.portals[id as usize].winding = Winding::default();
        }
    }
}

impl Portals {
    /// True when portal `id` still has an opening.
    pub fn is_live(&self, id: u32) -> bool {
        self.portals.get(id as usize).is_some_and(|p| !p.winding.is_empty())
    }

    /// True when portal `id` is live and not a sliver that nothing can pass through (see
    /// [`is_sliver`]). Only the leak flood uses this; vis keeps every live portal, since it must
    /// round toward visible.
    pub fn is_passable(&self, id: u32) -> bool {
        self.portals.get(id as usize).is_some_and(|p| !p.winding.is_empty() && !is_sliver(&p.winding))
    }
}

/// Edges shorter than this (map units) do not count towards a portal's width in [`is_sliver`].
pub const SLIVER_EDGE: f64 = 0.2;

/// A winding with fewer than three edges longer than [`SLIVER_EDGE`]: a pinch where two brushes
/// meet along a line, or a crack far narrower than anything that could pass (qbsp drops such
/// portals too). A long thin crack has two long edges and two short ones, so it is a sliver.
pub fn is_sliver(w: &Winding) -> bool {
    let n = w.points.len();
    let long = (0..n).filter(|&i| w.points[i].distance(w.points[(i + 1) % n]) > SLIVER_EDGE).count();
    long < 3
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pinches_and_hairline_cracks_are_slivers_but_narrow_doors_are_not() {
        let quad = |w: f64, h: f64| {
            Winding::new(vec![
                glam::DVec3::new(0.0, 0.0, 0.0),
                glam::DVec3::new(0.0, 0.0, h),
                glam::DVec3::new(0.0, w, h),
                glam::DVec3::new(0.0, w, 0.0),
            ])
        };
        assert!(is_sliver(&quad(0.0, 848.0)), "a pinch along an edge");
        assert!(is_sliver(&quad(0.1, 848.0)), "a hairline crack");
        assert!(!is_sliver(&quad(0.5, 848.0)), "a narrow slot still lets things through");
        assert!(!is_sliver(&quad(64.0, 96.0)), "a door");
    }
    use crate::brush::Brush;
    use glam::DVec3;
    use sightline_formats::Contents;

    #[test]
    fn hollow_box_room_has_closed_portal_graph() {
        let mut planes = PlaneSet::new();
        let room = Aabb::new(DVec3::splat(0.0), DVec3::splat(256.0));
        let mut walls = Vec::new();
        for axis in 0..3 {
            for hi in [false, true] {
                let mut lo = room.mins - DVec3::splat(16.0);
                let mut up = room.maxs + DVec3::splat(16.0);
                if hi {
                    lo[axis] = room.maxs[axis];
                } else {
                    up[axis] = room.mins[axis];
                }
                let mut b = Brush::from_box(&mut planes, &Aabb::new(lo, up), Contents::Solid);
                for s in &mut b.sides {
                    s.used = false;
                }
                walls.push(b);
            }
        }
        let bounds = Aabb::new(DVec3::splat(-32.0), DVec3::splat(288.0));
        let vol = Brush::from_box(&mut planes, &bounds, Contents::Empty);
        let tree = crate::bsp::build(&planes, walls, vol, &sightline_job::cancel::Cancel::new());
        let g = build(&tree, &planes, &bounds);
        let inside = tree.locate(&planes, DVec3::splat(128.0));
        // The room's only neighbours are solid walls.
        for &id in &g.by_node[inside as usize] {
            let p = &g.portals[id as usize];
            let other = if p.nodes[0] == inside { p.nodes[1] } else { p.nodes[0] };
            assert_ne!(other, g.outside);
            assert!(matches!(tree.nodes[other as usize], TreeNode::Leaf { contents: Contents::Solid, .. }));
            assert!(p.winding.is_valid(0.01));
        }
        assert!(g.by_node[inside as usize].len() >= 6);
    }
}
