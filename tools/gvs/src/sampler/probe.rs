//! Neighbour probing (this project's extension): slivers next to a found surface, seen from other
//! corners of the cell.

use glam::Vec3;
use sightline_raycast::intersect_brute;

use crate::neighbours::touching_box;

use super::{Class, EXPANDED, Gvs, PROBED, SEEN_BACK, SEEN_FRONT};

/// Probe points (of the nine in `Gvs::probe`'s order) that also aim near a probed triangle's
/// corners; the last four corners aim at its centre only. Measured on the default variant (5
/// cells, 50 views) against all nine aiming near the corners, rays more than with five points
/// only: city +1.9 % against +5.1 % (0.0 px either way; the moved cell's 90 px tile found by
/// both), `spheres:1000` +0.5 % against +2.0 % (0.5 against 0.4 px), `mixed:2000` +0.4 %
/// against +1.5 % (2.4 against 1.2 px), `spheres:10116` +3.2 % against +16 % (error no better).
const PROBE_FULL: usize = 5;

/// Fraction of the way from a probed triangle's corner to its centre where the corner rays aim.
const PROBE_INSET: f32 = 0.1;

/// Default of [`Params::probe_rays`](super::Params::probe_rays). The fixed probe rays start at the cell's corners and centre
/// only, so a triangle seen through a gap from the cell's inside alone gets no ray through it
/// (slivers of spheres seen between nearer ones). Measured on the default variant, wrong pixels per view and rays, 0 → 4 → 8:
/// twelve Quake levels (100 leaf cells each, 500 × 500 px) 0.227 → 0.197 → 0.190 px, +1.3 %,
/// +2.6 % rays; `spheres:1000` (5 cells, 250 views) 0.89 → 0.49 → 0.46 px, +0.6 %, +1.2 %;
/// `mixed:2000` 1.56 → 1.52 → 1.47 px; the city 0.02 px throughout, +1.1 %, +2.1 %; the thesis'
/// density (`spheres:10116`) 0 → 8: 83.3 → 45.2 px per triangle, +9 % rays. Time per cell
/// 1.01–1.03× on the spheres and the city (paired runs).
pub const PROBE_RAYS: u32 = 8;

/// First Halton index of neighbour probing's random rays, past the cell's seed: far from the
/// random rays' indices (at most [`Params::max_random`](super::Params::max_random) from the seed), so the two never reuse
/// points.
pub(super) const PROBE_SEQ_OFFSET: u64 = 1 << 32;

/// Most Halton points drawn per random probe ray (points behind the probed triangle's front are
/// skipped, so a triangle seen edge-on from the cell costs bounded work).
const PROBE_TRIES: u32 = 4;

impl Gvs<'_> {
    /// Neighbour probing (this project's extension, "probe"): every triangle touching a PVS
    /// triangle's box (its mesh neighbours, found through the BVH) that is not in the PVS yet is
    /// probed once. Its front is the side it is expected to be seen from: the side the expanded
    /// triangle was seen from, carried over through the windings of their sheet
    /// ([`crate::sheets`]); for a triangle of another sheet, the side that sheet was first seen
    /// from in this cell; failing both, the side `(v1 - v0) × (v2 - v0)` points to (triangles
    /// counter-clockwise seen from the front, as in `.obj` meshes and in
    /// [`crate::scene::from_level`]'s triangles). It is probed from points in front of its
    /// plane (the cell corner furthest in front, the
    /// cell's centre, the three corners next to that corner), one after the other until it is
    /// found, a ray at its centre and then rays near its three corners (those that do not cross
    /// the triangle which hid its centre from that point); then from the other four
    /// corners in front, a ray at its centre (what only one edge of the cell sees: a city facade
    /// tile 90 px large in a moved cell's view); from the corner furthest behind its plane, one
    /// ray at its centre; last, up to [`Params::probe_rays`](super::Params::probe_rays) rays from random points of the cell
    /// in front of it at random points of it (Halton), for what is seen only through a gap from
    /// the cell's inside. This finds the slivers next to a
    /// surface's silhouette that only part of the cell sees (seen nearly edge-on, or from the
    /// back from the seed's origin), which ABS from one origin misses. A probed triangle that is
    /// hit joins the PVS and is queued from that corner, so ABS and probing continue from there.
    pub(crate) fn probe_neighbours(&mut self, t: u32, tri: &[Vec3; 3], seen_from: Vec3) {
        let Some(state) = self.probe_state.get_mut(t as usize) else {
            return;
        };
        if *state & EXPANDED != 0 {
            return;
        }
        *state |= EXPANDED;
        // The table's row, or (a crowded triangle) the BVH query it stands for.
        let table = self.neighbours;
        let mut cand = std::mem::take(&mut self.candidates);
        cand.clear();
        let list = match table.of(t) {
            Some(row) => row,
            None => {
                let (lo, hi) = touching_box(tri);
                self.bvh.overlapping(lo, hi, |u| {
                    cand.push(u);
                    true
                });
                &cand[..]
            }
        };
        let seen_back = (tri[1] - tri[0]).cross(tri[2] - tri[0]).dot(seen_from - tri[0]) < 0.0;
        let sheet = self.neighbours.sheets().of(t);
        if let Some((s, flipped)) = sheet
            && let Some(side) = self.sheet_side.get_mut(s as usize)
            && *side == 0
        {
            *side = if seen_back != flipped { SEEN_BACK } else { SEEN_FRONT };
        }
        for &u in list {
            self.probe(u, sheet, seen_back);
        }
        self.candidates = cand;
    }

    /// Probe the neighbour `u` once (see [`Gvs::probe_neighbours`]), unless it is in the PVS.
    pub(super) fn probe(&mut self, u: u32, t_sheet: Option<(u32, bool)>, t_back: bool) {
        if self.has(u) || self.out_of_rays() {
            return;
        }
        let (Some(state), Some(ut)) = (self.probe_state.get_mut(u as usize), self.tris.get(u as usize))
        else {
            return;
        };
        if *state & PROBED != 0 {
            return;
        }
        *state |= PROBED;
        let n = (ut[1] - ut[0]).cross(ut[2] - ut[0]);
        // Seen from behind: in the expanded triangle's sheet, as that triangle was; in another
        // sheet seen before, as that sheet was; otherwise by the winding convention.
        let back = match (self.neighbours.sheets().of(u), t_sheet) {
            (Some((s, f)), Some((ts, tf))) if s == ts => t_back != (f != tf),
            (Some((s, f)), _) => match self.sheet_side.get(s as usize) {
                Some(&SEEN_FRONT) => f,
                Some(&SEEN_BACK) => !f,
                _ => false,
            },
            (None, _) => false,
        };
        let n = if back { -n } else { n };
        let centre = (ut[0] + ut[1] + ut[2]) / 3.0;
        let corners = self.cell.corners();
        let side = corners.map(|c| n.dot(c - ut[0]));
        let (mut kmax, mut kmin) = (0, 0);
        for k in 1..8 {
            if side[k] > side[kmax] {
                kmax = k;
            }
            if side[k] < side[kmin] {
                kmin = k;
            }
        }
        // In front: the corner furthest in front, the cell's centre and the three corners next
        // to the first, then the other four corners (those in front too), until one sees it: a
        // ray at its centre from each, then (from the first five) rays near its corners.
        let centre_cell = self.cell.centre();
        let order = [kmax, 8, kmax ^ 1, kmax ^ 2, kmax ^ 4, kmax ^ 3, kmax ^ 5, kmax ^ 6, kmax ^ 7];
        for (i, c) in order.map(|k| corners.get(k).copied().unwrap_or(centre_cell)).into_iter().enumerate() {
            if n.dot(c - ut[0]) <= 0.0 || self.has(u) || self.out_of_rays() {
                continue;
            }
            let s = self.handle(c, centre - c, Class::Probe);
            if i >= PROBE_FULL {
                continue;
            }
            // A triangle partly hidden from `c` may show a corner: aim near each (a tenth of the
            // way to the centre, inside the triangle). A corner ray that crosses the triangle which
            // hid the centre from `c` would end on it or nearer, never on `u`, and is not cast (a
            // new triangle nearer than it is left to the other rays).
            let hider = if s.tri != u && s.t < 1.0 { self.tris.get(s.tri as usize) } else { None };
            for v in ut {
                if self.has(u) || self.out_of_rays() {
                    break;
                }
                let d = v + (centre - v) * PROBE_INSET - c;
                if hider.is_some_and(|x| intersect_brute(std::slice::from_ref(x), c, d, 1.0).is_some()) {
                    continue;
                }
                self.handle(c, d, Class::Probe);
            }
        }
        let c = corners[kmin];
        if n.dot(c - ut[0]) < 0.0 && !self.has(u) && !self.out_of_rays() {
            self.handle(c, centre - c, Class::Probe);
        }
        // Last, rays from random points of the cell in front of it at random points of it (none
        // when the whole cell is behind it).
        let (mut cast, mut drawn) = (0, 0);
        let budget = if side[kmax] > 0.0 { PROBE_TRIES * self.p.probe_rays } else { 0 };
        while cast < self.p.probe_rays && drawn < budget {
            if self.has(u) || self.out_of_rays() {
                break;
            }
            drawn += 1;
            let (o, aim) = self.cell.segment_to(ut, self.probe_seq.next_point());
            if n.dot(o - ut[0]) <= 0.0 {
                continue;
            }
            self.handle(o, aim - o, Class::Probe);
            cast += 1;
        }
    }
}
