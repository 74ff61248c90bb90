//! The portal backend: visibility found at run time by recursion through portals (thesis §5.3).
//!
//! From the eye's leaf, every portal whose far side faces away from the eye is clipped to the
//! current frustum; if something is left, the frustum is rebuilt from planes through the eye and
//! each edge of the clipped polygon, plus the portal's own plane (only what lies beyond the portal
//! counts) and the camera's far plane, and the search recurses into the leaf behind it. A leaf is
//! never re-entered while it is on the current path. A portal whose bounding sphere is outside a
//! frustum plane is rejected before any clipping. The depth is capped at [`MAX_DEPTH`] and the
//! portals crossed per frame at [`BUDGET`]. A frame that hits a cap
//! (`FrameStats::truncated`) falls back to the PVS backend's marks (everything when the level has
//! no vis), so a cut-short search never hides anything; with a budget of 4,096 no random view of
//! our E1M1 hits it (with 1,024, 3.4 % did). The leaves
//! reached are then walked front to back with the full camera frustum, as the PVS backend does.
//!
//! # Epsilon
//! Decisions round toward **not visible** by at most [`PORTAL_EPSILON`]: a portal whose plane
//! passes within `PORTAL_EPSILON` units of the eye is crossed only from the eye's own leaf (then
//! without narrowing the frustum, since the eye is on the opening), and a clipped portal polygon
//! with less than `PORTAL_EPSILON²` square units of area across the line of sight, or seen under
//! less than [`MIN_SOLID_ANGLE`], is treated as closed; clipped corners closer than
//! `PORTAL_EPSILON` are merged. So the leaves found
//! are those some line of sight reaches through openings at least that wide, which keeps them
//! inside any conservative PVS.

use glam::Vec3A;

use crate::backend::api::Backend;
use crate::backend::pvs::Pvs;
use crate::camera::View;
use crate::scratch::{Scratch, Visible};
use crate::walk::{Marks, walk};
use crate::world::{LeafId, World};

/// Tolerance of the portal search, in world units (see the module docs).
pub const PORTAL_EPSILON: f32 = 0.01;
/// Portal windows that, after clipping, cover less than this solid angle (steradians; about a
/// tenth of a pixel of a 1000-pixel-wide 90° view) are treated as closed.
pub const MIN_SOLID_ANGLE: f32 = 2.5e-7;
/// Longest chain of portals followed.
pub const MAX_DEPTH: u32 = 96;
/// Most portals crossed in one frame.
pub const BUDGET: u32 = 1 << 12;

/// The portal backend; see the module docs.
#[derive(Debug, Clone, Copy, Default)]
pub struct Portal;

impl Backend for Portal {
    fn name(&self) -> &'static str {
        "portal"
    }

    fn supports(&self, world: &World) -> bool {
        world.num_portals() > 0
    }

    fn cull(&self, world: &World, view: &View, scratch: &mut Scratch, out: &mut Visible) {
        scratch.bind(world);
        scratch.next_marks();
        scratch.stats.marks_reused = false;
        scratch.stats.truncated = false;
        let eye_leaf = world.leaf_at(view.eye);
        let open = world.leaf_contents(eye_leaf).is_some_and(|c| c.is_open());
        let mut search =
            Search { eye: view.eye, far: view.frustum.planes()[5], crossed: 0, marked: 0, truncated: false };
        let mut marks = Marks::SCRATCH;
        if open {
            scratch.mark_leaf(world, eye_leaf);
            search.marked = 1;
            scratch.planes.clear();
            let planes = view.frustum.planes();
            for i in [0, 1, 2, 3, 5] {
                scratch.planes.push(planes[i]);
            }
            search.enter(world, scratch, eye_leaf, 0, 0);
        } else {
            marks = Marks::ALL;
            search.marked = world.open_leaves().len() as u32;
        }
        if search.truncated {
            // Never hide what the search had no budget to reach: this frame is the PVS
            // backend's (everything when the level has no vis).
            marks = Pvs::mark(world, eye_leaf, scratch);
            search.marked = scratch.stats.marked_leaves;
        }
        scratch.stats.marks_reused = false;
        scratch.stats.marked_leaves = search.marked;
        scratch.stats.portals_crossed = search.crossed;
        scratch.stats.truncated = search.truncated;
        walk(world, view, marks, scratch, out);
    }
}

struct Search {
    eye: Vec3A,
    far: (Vec3A, f32),
    crossed: u32,
    marked: u32,
    truncated: bool,
}

impl Search {
    /// Visit `leaf` with the frustum `scratch.planes[planes_start..]`.
    fn enter(&mut self, world: &World, scratch: &mut Scratch, leaf: LeafId, planes_start: usize, depth: u32) {
        if let Some(p) = scratch.on_path.get_mut(leaf as usize) {
            *p = true;
        }
        let planes_end = scratch.planes.len();
        for &pi in world.leaf_portals(leaf) {
            if self.crossed >= BUDGET {
                self.truncated = true;
                break;
            }
            let Some(portal) = world.tree().portals.get(pi as usize) else { continue };
            // Orient the portal plane so that its front is the far side.
            let (other, n, d) = if portal.leaves[0] == leaf {
                (portal.leaves[1], -portal.normal, -portal.dist)
            } else {
                (portal.leaves[0], portal.normal, portal.dist)
            };
            if scratch.on_path.get(other as usize) != Some(&false) {
                continue;
            }
            let eye_side = n.dot(self.eye) - d;
            let start = portal.first_vertex as usize;
            let Some(pts) = world.tree().portal_vertices.get(start..start + portal.num_vertices as usize)
            else {
                continue;
            };
            if eye_side > -PORTAL_EPSILON {
                // The eye is on (or beyond) the portal plane: only an opening the eye stands in
                // can be passed, and without narrowing.
                if depth == 0 && eye_side < PORTAL_EPSILON && self.cross(world, scratch, other) {
                    self.enter(world, scratch, other, planes_start, depth + 1);
                }
                continue;
            }
            // Bounding sphere first: a portal outside a plane is rejected without clipping.
            let frustum = scratch.planes.get(planes_start..planes_end).unwrap_or(&[]);
            if frustum.iter().any(|&(pn, pd)| pn.dot(portal.center) - pd < -portal.radius) {
                continue;
            }
            // Clip the portal polygon to the current frustum (planes its sphere is inside of
            // cannot cut it).
            scratch.poly_a.clear();
            scratch.poly_a.extend_from_slice(pts);
            let mut empty = false;
            for k in planes_start..planes_end {
                let Some(&(pn, pd)) = scratch.planes.get(k) else { break };
                if pn.dot(portal.center) - pd >= portal.radius {
                    continue;
                }
                clip(&scratch.poly_a, pn, pd, &mut scratch.poly_b);
                std::mem::swap(&mut scratch.poly_a, &mut scratch.poly_b);
                if scratch.poly_a.len() < 3 {
                    empty = true;
                    break;
                }
            }
            if empty {
                continue;
            }
            dedup_points(&mut scratch.poly_a, PORTAL_EPSILON);
            let count = scratch.poly_a.len();
            if count < 3 {
                continue;
            }
            let centroid = scratch.poly_a.iter().copied().sum::<Vec3A>() / count as f32;
            // Solid angle of the window: area projected across the line of sight over distance².
            let to_window = centroid - self.eye;
            let projected =
                area(&scratch.poly_a) * n.dot(to_window).abs() / to_window.length().max(f32::MIN_POSITIVE);
            if projected < PORTAL_EPSILON * PORTAL_EPSILON
                || projected < MIN_SOLID_ANGLE * to_window.length_squared()
            {
                continue;
            }
            if !self.cross(world, scratch, other) {
                continue;
            }

            // The narrowed frustum: eye-edge planes, the portal plane, the far plane. Edge planes
            // are built in f64: an edge nearly aligned with the line of sight spans a tiny angle,
            // and its plane still matters (dropping it could widen the frustum a lot).
            let new_start = scratch.planes.len();
            let eye = self.eye.as_dvec3();
            let inside = to_window.as_dvec3();
            for i in 0..count {
                let (Some(&a), Some(&b)) = (scratch.poly_a.get(i), scratch.poly_a.get((i + 1) % count))
                else {
                    break;
                };
                let Some(en) = (a.as_dvec3() - eye).cross(b.as_dvec3() - eye).try_normalize() else {
                    continue;
                };
                let en = if en.dot(inside) < 0.0 { -en } else { en };
                scratch.planes.push((en.as_vec3a(), en.dot(eye) as f32));
            }
            scratch.planes.push((n, d));
            scratch.planes.push(self.far);
            if depth + 1 < MAX_DEPTH {
                self.enter(world, scratch, other, new_start, depth + 1);
            } else {
                self.truncated = true;
            }
            scratch.planes.truncate(new_start);
        }
        if let Some(p) = scratch.on_path.get_mut(leaf as usize) {
            *p = false;
        }
    }

    /// Count a crossing into `other` and mark it; false when `other` is solid.
    fn cross(&mut self, world: &World, scratch: &mut Scratch, other: LeafId) -> bool {
        if !world.leaf_contents(other).is_some_and(|c| c.is_open()) {
            return false;
        }
        self.crossed += 1;
        if scratch.mark_leaf(world, other) {
            self.marked += 1;
        }
        true
    }
}

/// Keep the part of convex polygon `input` in front of the plane (`n · p - d >= 0`).
fn clip(input: &[Vec3A], n: Vec3A, d: f32, out: &mut Vec<Vec3A>) {
    out.clear();
    let Some(&last) = input.last() else { return };
    let mut prev = last;
    let mut prev_d = n.dot(prev) - d;
    for &cur in input {
        let cur_d = n.dot(cur) - d;
        if (prev_d >= 0.0) != (cur_d >= 0.0) {
            let t = prev_d / (prev_d - cur_d);
            out.push(prev + (cur - prev) * t);
        }
        if cur_d >= 0.0 {
            out.push(cur);
        }
        prev = cur;
        prev_d = cur_d;
    }
}

/// Drop points closer than `eps` to the previous kept point (and a last point equal to the first).
fn dedup_points(poly: &mut Vec<Vec3A>, eps: f32) {
    let eps2 = eps * eps;
    let mut kept = 0;
    for i in 0..poly.len() {
        let Some(&p) = poly.get(i) else { break };
        if kept == 0 || poly.get(kept - 1).is_some_and(|q| q.distance_squared(p) > eps2) {
            if let Some(slot) = poly.get_mut(kept) {
                *slot = p;
            }
            kept += 1;
        }
    }
    poly.truncate(kept);
    while poly.len() > 1 && poly.first().zip(poly.last()).is_some_and(|(a, b)| a.distance_squared(*b) <= eps2)
    {
        poly.pop();
    }
}

/// Area of a planar polygon.
fn area(poly: &[Vec3A]) -> f32 {
    let Some(&o) = poly.first() else { return 0.0 };
    let mut sum = Vec3A::ZERO;
    for w in poly.windows(2).skip(1) {
        sum += (w[0] - o).cross(w[1] - o);
    }
    sum.length() * 0.5
}
