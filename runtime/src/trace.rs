//! Segment tracing: the first solid leaf along a segment.
//!
//! The segment is split at node planes recursively, near side first (Quake's
//! `SV_RecursiveHullCheck` on the point hull). Every split point is computed from the original
//! endpoints as `from + (to - from) * t`, so no error accumulates down the tree. A point exactly on a
//! plane is in front of it, as in [`World::leaf_at`].

use glam::Vec3A;

use crate::world::{LeafId, World};

/// Distance, in world units, that a hit point is backed off along the segment so that it lies in
/// open space rather than on (or, after rounding, inside) the solid surface. Quake uses the same
/// value (`DIST_EPSILON`).
pub const TRACE_EPSILON: f32 = 0.03125;

/// Where a segment first enters solid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TraceHit {
    /// Fraction of the segment travelled before the hit, backed off by [`TRACE_EPSILON`] units
    /// (0 when the start is in solid).
    pub fraction: f32,
    /// `from + (to - from) * fraction`.
    pub point: Vec3A,
    /// Unit normal of the surface hit, facing the open side the segment came from (zero when the
    /// start is in solid).
    pub normal: Vec3A,
    /// The solid leaf entered.
    pub leaf: LeafId,
    /// True when `from` itself is in solid.
    pub start_solid: bool,
}

struct Seg {
    from: Vec3A,
    dir: Vec3A,
}

impl World {
    /// The first solid leaf on the segment `from → to`, or `None` when the whole segment is open.
    pub fn trace(&self, from: impl Into<Vec3A>, to: impl Into<Vec3A>) -> Option<TraceHit> {
        let from = from.into();
        let to = to.into();
        let seg = Seg { from, dir: to - from };
        let (t, normal, leaf) = self.trace_rec(self.tree().root, 0.0, 1.0, Vec3A::ZERO, &seg)?;
        let start_solid = t <= 0.0 && normal == Vec3A::ZERO;
        let len = seg.dir.length();
        let back = if len > 0.0 { TRACE_EPSILON / len } else { 0.0 };
        let fraction = if start_solid { 0.0 } else { (t - back).max(0.0) };
        Some(TraceHit { fraction, point: from + seg.dir * fraction, normal, leaf, start_solid })
    }

    /// The first solid leaf in `child` for the part `t0..t1` of the segment: `(t, entry normal,
    /// leaf)`. `entry` is the normal of the plane through which this part was entered.
    fn trace_rec(
        &self,
        child: i32,
        t0: f32,
        t1: f32,
        entry: Vec3A,
        seg: &Seg,
    ) -> Option<(f32, Vec3A, LeafId)> {
        if child < 0 {
            let leaf = (!child) as LeafId;
            let solid = self.tree().leaves.get(leaf as usize).is_some_and(|l| !l.contents.is_open());
            return solid.then_some((t0, entry, leaf));
        }
        let node = self.tree().nodes.get(child as usize)?;
        let d0 = node.normal.dot(seg.from + seg.dir * t0) - node.dist;
        let d1 = node.normal.dot(seg.from + seg.dir * t1) - node.dist;
        let [front, back] = node.children;
        if d0 >= 0.0 && d1 >= 0.0 {
            return self.trace_rec(front, t0, t1, entry, seg);
        }
        if d0 < 0.0 && d1 < 0.0 {
            return self.trace_rec(back, t0, t1, entry, seg);
        }
        // The part crosses the plane (or a value is NaN: then both halves are searched).
        let s = d0 / (d0 - d1);
        let tm = if s.is_finite() { (t0 + (t1 - t0) * s).clamp(t0, t1) } else { t0 };
        let (near, far, normal) =
            if d0 >= 0.0 { (front, back, node.normal) } else { (back, front, -node.normal) };
        self.trace_rec(near, t0, tm, entry, seg).or_else(|| self.trace_rec(far, tm, t1, normal, seg))
    }
}
