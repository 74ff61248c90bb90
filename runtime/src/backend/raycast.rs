//! The ray-casting backend (the culling thesis' chapter 6): a sparse grid of rays, one per
//! `spacing × spacing` pixels of a `width × height` viewport, cast front to back through the BSP
//! tree; the open leaves they reach are marked and walked with the full frustum as the PVS backend
//! walks its marks.
//!
//! **Aggressive, not conservative.** A leaf that no grid ray reaches is hidden even when part of it
//! is visible between the rays (a thin gap, a small far opening): its result may miss visible
//! leaves, by design. It is a speed/quality trade-off for engines that accept holes, and a
//! diagnostic; it never adds a leaf the eye cannot see through open leaves (the leaves it marks
//! lie in any conservative PVS of the eye's cluster).
//!
//! # Rays
//! The grid is laid over the view's frustum: the four side planes' corner edges span the picture,
//! and the ray of grid cell `(i, j)` goes through the centre of its `spacing × spacing` pixel block
//! (the last block clipped to the viewport), so any [`View`] (a camera's or a view-projection
//! matrix's) works. A ray walks the tree near side first (as [`World::trace`]) from the eye to the
//! far plane; in each open leaf it marks the leaf and tests the leaf's faces, and stops at the
//! first face it meets inside that leaf's part of the ray, at a solid or sky leaf, or at the far
//! plane. Liquid faces (texture names starting with `*`) let rays through.
//!
//! # Move to front
//! Each leaf remembers, in the caller's [`Scratch`], the last face a ray hit in it, and tests it
//! first: neighbouring rays and the next frame usually hit the same face (the thesis measured
//! 11 %). The world is shared and read-only, so the order lives in the scratch.
//!
//! # Falling back
//! With [`RayCast::adaptive`], every [`PROBE`]th frame on a scratch (and its first) runs both this
//! backend and the PVS backend and compares their cost: culling time plus [`RayCast::face_ns`] per
//! face output (what drawing a face costs the renderer). Until the next probe, the cheaper one
//! runs; when the PVS walk wins, frames are the PVS backend's (so in open scenes, where rays travel
//! far and hide little, it switches itself off, as the thesis says it must be able to). An eye in
//! solid or sky falls back to the PVS backend too. [`FrameStats::rays`](crate::scratch::FrameStats::rays) is 0 on fallback
//! frames.

use std::time::Instant;

use glam::Vec3A;

use crate::backend::api::Backend;
use crate::backend::pvs::Pvs;
use crate::camera::View;
use crate::scratch::{Scratch, Visible};
use crate::walk::{Marks, walk};
use crate::world::{LeafId, World};

/// Frames between two comparisons with the PVS backend (see the module docs).
pub const PROBE: u32 = 32;
/// Tolerance of the ray/face test, in world units: a hit this far outside a face's edges, or
/// outside the leaf's part of the ray, still stops the ray.
const FACE_EPSILON: f32 = 1e-3;

/// The ray-casting backend; see the module docs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayCast {
    /// Pixels between two rays, along each axis (at least 1).
    pub spacing: u32,
    /// Viewport width in pixels.
    pub width: u32,
    /// Viewport height in pixels.
    pub height: u32,
    /// Compare with the PVS backend every [`PROBE`] frames and run the cheaper (see the module
    /// docs); when false, every frame (with the eye in open space) casts rays.
    pub adaptive: bool,
    /// Cost of drawing one face, in ns, in the comparison with the PVS backend.
    pub face_ns: f32,
}

impl RayCast {
    /// The value in [`super::all`]: one ray per 8 × 8 pixels of 640 × 480 (4,800 rays), adaptive,
    /// 100 ns per face drawn.
    pub const DEFAULT: RayCast =
        RayCast { spacing: 8, width: 640, height: 480, adaptive: true, face_ns: 100.0 };

    /// Columns and rows of the ray grid.
    pub fn grid(&self) -> (u32, u32) {
        let n = self.spacing.max(1);
        (self.width.max(1).div_ceil(n), self.height.max(1).div_ceil(n))
    }

    /// True when a frame of rays, `(culling ns, faces output)`, costs no more than the PVS
    /// backend's frame, counting [`RayCast::face_ns`] per face.
    pub fn rays_win(&self, rays: (f32, usize), pvs: (f32, usize)) -> bool {
        rays.0 + rays.1 as f32 * self.face_ns <= pvs.0 + pvs.1 as f32 * self.face_ns
    }

    /// Cast the grid and mark the leaves reached in the scratch (the eye's leaf `eye_leaf` must be
    /// open); returns the number of leaves marked.
    fn cast(&self, world: &World, view: &View, eye_leaf: LeafId, scratch: &mut Scratch) -> u32 {
        scratch.next_marks();
        if scratch.ray_last_hit.len() != world.num_leaves() {
            scratch.ray_last_hit.clear();
            scratch.ray_last_hit.resize(world.num_leaves(), u32::MAX);
        }
        let mut marked = u32::from(scratch.mark_leaf(world, eye_leaf));
        let planes = view.frustum.planes();
        let (forward, far_dist) = (planes[4].0, planes[5].0.dot(view.eye) - planes[5].1);
        // Corner edges of the side planes (left 0, right 1, bottom 2, top 3), scaled to unit
        // distance along the view direction.
        let corner = |a: usize, b: usize| {
            let d = planes[a].0.cross(planes[b].0);
            let s = d.dot(forward);
            if s.abs() > f32::EPSILON { d / s } else { forward }
        };
        let (bl, br, tl, tr) = (corner(0, 2), corner(1, 2), corner(0, 3), corner(1, 3));
        let (cols, rows) = self.grid();
        let n = self.spacing.max(1) as f32;
        let (w, h) = (self.width.max(1) as f32, self.height.max(1) as f32);
        let far = if far_dist.is_finite() && far_dist > 0.0 { far_dist } else { 65536.0 };
        let mut ray = Ray { eye: view.eye, dir: Vec3A::ZERO, marked: 0 };
        for j in 0..rows {
            let v = ((j as f32 + 0.5) * n).min(h - 0.5) / h;
            let (left, right) = (bl.lerp(tl, v), br.lerp(tr, v));
            for i in 0..cols {
                let u = ((i as f32 + 0.5) * n).min(w - 0.5) / w;
                ray.dir = left.lerp(right, u) * far;
                ray.walk(world, scratch, world.root(), 0.0, 1.0);
            }
        }
        marked += ray.marked;
        scratch.stats.rays = cols * rows;
        marked
    }
}

impl Default for RayCast {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// One ray of the grid: `eye + dir * t` for `t` in `0..=1`.
struct Ray {
    eye: Vec3A,
    dir: Vec3A,
    /// Leaves newly marked by the rays so far.
    marked: u32,
}

impl Ray {
    /// Walk `child` for the part `t0..t1`, near side first; true when the ray stopped.
    fn walk(&mut self, world: &World, scratch: &mut Scratch, child: i32, t0: f32, t1: f32) -> bool {
        if child < 0 {
            return self.leaf(world, scratch, (!child) as LeafId, t0, t1);
        }
        let Some(node) = world.tree().nodes.get(child as usize) else { return true };
        let d0 = node.normal.dot(self.eye + self.dir * t0) - node.dist;
        let d1 = node.normal.dot(self.eye + self.dir * t1) - node.dist;
        let [front, back] = node.children;
        if d0 >= 0.0 && d1 >= 0.0 {
            return self.walk(world, scratch, front, t0, t1);
        }
        if d0 < 0.0 && d1 < 0.0 {
            return self.walk(world, scratch, back, t0, t1);
        }
        let s = d0 / (d0 - d1);
        let tm = if s.is_finite() { (t0 + (t1 - t0) * s).clamp(t0, t1) } else { t0 };
        let (near, far) = if d0 >= 0.0 { (front, back) } else { (back, front) };
        self.walk(world, scratch, near, t0, tm) || self.walk(world, scratch, far, tm, t1)
    }

    /// The part `t0..t1` of the ray in `leaf`: stop at solid or sky; else mark the leaf and test
    /// its faces, the last one hit first.
    fn leaf(&mut self, world: &World, scratch: &mut Scratch, leaf: LeafId, t0: f32, t1: f32) -> bool {
        let Some(contents) = world.leaf_contents(leaf) else { return true };
        if !contents.is_open() || contents == sightline_formats::Contents::Sky {
            return true;
        }
        self.marked += u32::from(scratch.mark_leaf(world, leaf));
        let len = self.dir.length().max(f32::MIN_POSITIVE);
        let (lo, hi) = (t0 - FACE_EPSILON / len, t1 + FACE_EPSILON / len);
        let last = scratch.ray_last_hit.get(leaf as usize).copied().unwrap_or(u32::MAX);
        if last != u32::MAX && self.hits(world, last, lo, hi) {
            return true;
        }
        for &f in world.leaf_faces(leaf) {
            if f != last && self.hits(world, f, lo, hi) {
                if let Some(l) = scratch.ray_last_hit.get_mut(leaf as usize) {
                    *l = f;
                }
                return true;
            }
        }
        false
    }

    /// True when the ray meets face `face` (either side, liquids excepted) at a `t` in `lo..=hi`.
    fn hits(&self, world: &World, face: u32, lo: f32, hi: f32) -> bool {
        let draw = world.draw();
        let Some(f) = draw.face(face) else { return false };
        if draw.texture_name(f.texture).is_some_and(|n| n.starts_with('*')) {
            return false;
        }
        let denom = f.normal.dot(self.dir);
        if denom == 0.0 {
            return false;
        }
        let t = (f.dist - f.normal.dot(self.eye)) / denom;
        if !(t >= lo && t <= hi && t > 0.0) {
            return false;
        }
        let p = self.eye + self.dir * t;
        // Inside when on the same side of every edge (either winding), within the tolerance.
        let (mut pos, mut neg) = (false, false);
        let n = f.vertices.len();
        for k in 0..n {
            let a = Vec3A::from(f.vertices[k]);
            let b = Vec3A::from(f.vertices[(k + 1) % n]);
            let edge = b - a;
            let side = edge.cross(p - a).dot(f.normal);
            let tol = FACE_EPSILON * edge.length();
            pos |= side > tol;
            neg |= side < -tol;
            if pos && neg {
                return false;
            }
        }
        n >= 3
    }
}

impl Backend for RayCast {
    fn name(&self) -> &'static str {
        "raycast"
    }

    fn conservative(&self) -> bool {
        false
    }

    fn cull(&self, world: &World, view: &View, scratch: &mut Scratch, out: &mut Visible) {
        scratch.bind(world);
        scratch.stats.portals_crossed = 0;
        scratch.stats.truncated = false;
        scratch.stats.rays = 0;
        let eye_leaf = world.leaf_at(view.eye);
        let open = world
            .leaf_contents(eye_leaf)
            .is_some_and(|c| c.is_open() && c != sightline_formats::Contents::Sky);
        if !open {
            Pvs.cull(world, view, scratch, out);
            return;
        }
        let frame = scratch.ray_frames;
        scratch.ray_frames = frame.wrapping_add(1);
        let probe = self.adaptive && frame.is_multiple_of(PROBE);
        if !probe && self.adaptive && scratch.ray_off {
            Pvs.cull(world, view, scratch, out);
            return;
        }
        let start = Instant::now();
        let marked = self.cast(world, view, eye_leaf, scratch);
        scratch.stats.marks_reused = false;
        scratch.stats.marked_leaves = marked;
        walk(world, view, Marks::SCRATCH, scratch, out);
        if !probe {
            return;
        }
        let ray_ns = start.elapsed().as_nanos() as f32;
        let mut other = std::mem::take(&mut scratch.ray_other);
        let ray_stats = scratch.stats;
        let start = Instant::now();
        Pvs.cull(world, view, scratch, &mut other);
        let pvs_ns = start.elapsed().as_nanos() as f32;
        scratch.ray_off = !self.rays_win((ray_ns, out.faces.len()), (pvs_ns, other.faces.len()));
        if scratch.ray_off {
            std::mem::swap(out, &mut other);
            scratch.stats.rays = 0;
        } else {
            scratch.stats = ray_stats;
        }
        scratch.ray_other = other;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_covers_the_viewport_and_costs_count_faces() {
        let r = RayCast::DEFAULT;
        assert_eq!(r.grid(), (80, 60));
        assert_eq!(RayCast { spacing: 7, ..r }.grid(), (92, 69));
        assert_eq!(RayCast { spacing: 0, width: 3, height: 2, ..r }.grid(), (3, 2));
        // 50 µs of rays and 100 faces against 5 µs of walk and 1000 faces: rays win at 100 ns a
        // face, lose when faces are free.
        assert!(r.rays_win((50_000.0, 100), (5_000.0, 1000)));
        assert!(!RayCast { face_ns: 0.0, ..r }.rays_win((50_000.0, 100), (5_000.0, 1000)));
    }
}
