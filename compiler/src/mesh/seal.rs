//! Which of a mesh's solid cells its triangles really enclose.
//!
//! The polygon BSP calls a cell solid when it lies behind the last triangle that split it. That
//! guess holds for a closed, consistently oriented mesh and fails for open edges, flipped, missing
//! or stray triangles. So it is checked before anything uses it: a solid cell stays solid only
//! while every portal between it and an open cell is covered by triangles lying on that portal's
//! plane (either orientation), up to cracks no wider than [`CRACK_WIDTH`]. A solid cell with an
//! uncovered portal is reachable by sight, so it is opened and the check goes on from it: a flood
//! from the open cells through uncovered portals. What stays solid is enclosed by triangles, so the
//! tree blocks sight only where the mesh's faces do, and open geometry blocks nothing.
//!
//! The solid cells outside the mesh's box ([`Cover::boundary`]) are solid by construction: the
//! level's world ends there, as a map's filled outside does.

use std::collections::{BTreeMap, VecDeque};

use glam::DVec3;
use sightline_formats::geom::ON_EPSILON;
use sightline_formats::{Aabb, Contents, Plane, PlaneSet, Winding};

use crate::bsp::{Tree, TreeNode};
use crate::portals::{BuildPortal, Portals};

/// A gap between triangles at most this wide (in units, across its narrowest direction) counts as
/// covered: splitting with [`ON_EPSILON`] already merges points this close, and no bundle of sight
/// lines passes such a crack.
pub const CRACK_WIDTH: f64 = 2.0 * ON_EPSILON;

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
}

impl Cover {
    /// Remember `triangle` (a winding on plane `plane`).
    pub fn add(&mut self, plane: u32, triangle: Winding) {
        self.by_plane.entry(plane & !1).or_default().push(triangle);
    }

    /// Open every solid leaf of `tree` that sight reaches from an open leaf through portals of
    /// `g` that no triangle covers, and the leaves reached from those in turn. The result does not
    /// depend on the order of the flood: it is the set of solid leaves joined to an open leaf by a
    /// chain of uncovered portals.
    pub fn open_unenclosed(&self, tree: &mut Tree, planes: &PlaneSet, g: &Portals) -> Opened {
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
        while let Some(leaf) = queue.pop_front() {
            for &id in &g.by_node[leaf as usize] {
                let p = &g.portals[id as usize];
                let other = if p.nodes[0] == leaf { p.nodes[1] } else { p.nodes[0] };
                let o = other as usize;
                if other == g.outside || open[o] || fixed[o] || !solid[o] || p.winding.is_empty() {
                    continue;
                }
                if !self.covers(p, planes) {
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
        Opened { cells: opened.len(), bounds }
    }

    /// True when triangles on the portal's plane cover its opening (up to [`CRACK_WIDTH`]).
    fn covers(&self, p: &BuildPortal, planes: &PlaneSet) -> bool {
        let Some(index) = p.plane_index else { return false };
        let Some(triangles) = self.by_plane.get(&(index & !1)) else { return false };
        let normal = planes.get(index as usize).normal;
        let near = p.winding.bounds().expanded(ON_EPSILON);
        let mut rest = vec![p.winding.clone()];
        for t in triangles.iter().filter(|t| t.bounds().intersects(&near)) {
            rest = rest.into_iter().flat_map(|piece| outside_of(piece, t, normal)).collect();
            if rest.is_empty() {
                return true;
            }
        }
        rest.iter().all(|piece| width(piece) <= CRACK_WIDTH)
    }
}

/// The parts of `piece` outside the convex winding `t` (both on the plane with `normal`): cut by
/// each of `t`'s edges in turn, the part beyond an edge is kept, the rest goes on to the next.
fn outside_of(piece: Winding, t: &Winding, normal: DVec3) -> Vec<Winding> {
    let mut out = Vec::new();
    let centre = t.center();
    let mut inside = Some(piece);
    for (i, &a) in t.points.iter().enumerate() {
        let Some(cur) = inside.take() else { break };
        let b = t.points[(i + 1) % t.points.len()];
        let Some(edge) = Plane::new((b - a).cross(normal), 0.0) else {
            inside = Some(cur);
            continue;
        };
        let mut edge = Plane { dist: edge.normal.dot(a), ..edge };
        if edge.distance(centre) > 0.0 {
            edge = edge.flipped();
        }
        let split = cur.split(&edge, ON_EPSILON);
        out.extend(split.front);
        inside = split.back;
    }
    out
}

/// The narrowest extent of a convex winding: over its edges, the farthest corner from the edge's
/// line, at the edge where that is least (0 for fewer than three corners).
fn width(w: &Winding) -> f64 {
    let n = w.points.len();
    if n < 3 {
        return 0.0;
    }
    let mut least = f64::INFINITY;
    for i in 0..n {
        let a = w.points[i];
        let dir = w.points[(i + 1) % n] - a;
        let len = dir.length();
        if len <= f64::EPSILON {
            continue;
        }
        let far = w.points.iter().map(|&p| (p - a).cross(dir).length() / len).fold(0.0, f64::max);
        least = least.min(far);
    }
    if least.is_finite() { least } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(x0: f64, y0: f64, x1: f64, y1: f64) -> Winding {
        Winding::new(vec![
            DVec3::new(x0, y0, 0.0),
            DVec3::new(x0, y1, 0.0),
            DVec3::new(x1, y1, 0.0),
            DVec3::new(x1, y0, 0.0),
        ])
    }

    fn remainder(piece: &Winding, cover: &[Winding]) -> Vec<Winding> {
        let mut rest = vec![piece.clone()];
        for t in cover {
            rest = rest.into_iter().flat_map(|p| outside_of(p, t, DVec3::Z)).collect();
        }
        rest
    }

    #[test]
    fn two_triangles_of_a_square_cover_it_and_a_gap_does_not() {
        let portal = square(0.0, 0.0, 64.0, 64.0);
        let a = Winding::new(vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(0.0, 64.0, 0.0),
            DVec3::new(64.0, 64.0, 0.0),
        ]);
        let b = Winding::new(vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(64.0, 64.0, 0.0),
            DVec3::new(64.0, 0.0, 0.0),
        ]);
        let rest = remainder(&portal, &[a.clone(), b]);
        assert!(rest.iter().all(|p| width(p) <= CRACK_WIDTH), "{rest:?}");
        let rest = remainder(&portal, &[a]);
        let area: f64 = rest.iter().map(Winding::area).sum();
        assert!((area - 2048.0).abs() < 1e-6, "{area}");
        // Two halves 1 unit apart leave a crack that counts; 0.005 apart one that does not.
        for (gap, open) in [(1.0, true), (0.005, false)] {
            let rest =
                remainder(&portal, &[square(0.0, 0.0, 32.0, 64.0), square(32.0 + gap, 0.0, 64.0, 64.0)]);
            assert_eq!(rest.iter().any(|p| width(p) > CRACK_WIDTH), open, "gap {gap}: {rest:?}");
        }
    }

    #[test]
    fn width_is_the_narrow_extent() {
        assert!((width(&square(0.0, 0.0, 100.0, 0.5)) - 0.5).abs() < 1e-9);
        let sliver =
            Winding::new(vec![DVec3::ZERO, DVec3::new(50.0, 0.001, 0.0), DVec3::new(100.0, 0.0, 0.0)]);
        assert!(width(&sliver) < 0.002);
        assert_eq!(width(&Winding::default()), 0.0);
    }
}
