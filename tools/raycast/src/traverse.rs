//! One-ray traversal of the 4-wide tree: closest and any hits.

use glam::{Vec3, Vec3A, Vec4};

use crate::node::Node;
use crate::stack::Stack;
use crate::triangle::{Ray, WideRay};
use crate::{Bvh, Hit, STACK_DEEP, STACK_SMALL, WIDEN};

impl Bvh {
    /// Closest hit with `0 < t < t_max`, if any.
    pub fn intersect(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Option<Hit> {
        self.traverse::<false, false>(origin, dir, t_max)
    }

    /// Closest hit with `0 < t < t_max` among the triangles the ray meets from their front (the
    /// side `(v1 - v0) × (v2 - v0)` points to: `dir · normal < 0`), if any: one-sided triangles,
    /// as an engine that culls back faces draws them.
    pub fn intersect_front(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Option<Hit> {
        self.traverse::<false, true>(origin, dir, t_max)
    }

    /// True when anything is hit with `0 < t < t_max`.
    pub fn occluded(&self, origin: Vec3, dir: Vec3, t_max: f32) -> bool {
        self.traverse::<true, false>(origin, dir, t_max).is_some()
    }

    pub(crate) fn traverse<const ANY: bool, const FRONT: bool>(
        &self,
        origin: Vec3,
        dir: Vec3,
        t_max: f32,
    ) -> Option<Hit> {
        // A non-finite ray hits nothing (and could enter the empty lanes of a quad, which would
        // lead back to the root).
        if self.ids.is_empty() || t_max.is_nan() || t_max <= 0.0 || !(origin.is_finite() && dir.is_finite()) {
            return None;
        }
        let ray = Ray::new(origin, dir);
        // One traversal per dominant axis, so that the triangle test indexes by constants.
        // and one per stack size.
        match (ray.kz, self.deep) {
            (0, false) => self.walk::<ANY, FRONT, 0, STACK_SMALL>(&ray, dir, t_max),
            (1, false) => self.walk::<ANY, FRONT, 1, STACK_SMALL>(&ray, dir, t_max),
            (_, false) => self.walk::<ANY, FRONT, 2, STACK_SMALL>(&ray, dir, t_max),
            (0, true) => self.walk::<ANY, FRONT, 0, STACK_DEEP>(&ray, dir, t_max),
            (1, true) => self.walk::<ANY, FRONT, 1, STACK_DEEP>(&ray, dir, t_max),
            (_, true) => self.walk::<ANY, FRONT, 2, STACK_DEEP>(&ray, dir, t_max),
        }
    }

    pub(crate) fn walk<const ANY: bool, const FRONT: bool, const KZ: usize, const N: usize>(
        &self,
        ray: &Ray,
        dir: Vec3,
        t_max: f32,
    ) -> Option<Hit> {
        let origin = ray.origin;
        // Direction components smaller than the smallest normal float become it (same sign), so
        // that `inv` is finite and non-zero: slab distances are never 0 × ∞ = NaN, and the near
        // plane of a box is its min plane on an axis where `inv > 0`, its max plane otherwise.
        let safe = |d: f32| if d.abs() < f32::MIN_POSITIVE { f32::MIN_POSITIVE.copysign(d) } else { d };
        let inv = Vec3A::new(safe(dir.x), safe(dir.y), safe(dir.z)).recip();
        let o = Vec3A::from(origin);
        let (ox, oy, oz) = (Vec4::splat(o.x), Vec4::splat(o.y), Vec4::splat(o.z));
        let (ix, iy, iz) = (Vec4::splat(inv.x), Vec4::splat(inv.y), Vec4::splat(inv.z));
        // Far distances are widened by a few ulps so that boxes never cull a hit the watertight
        // test reports: through the reciprocal (and the current best distance), which keeps the
        // widening off each node's critical path (a few per cent faster than widening the result).
        let (wx, wy, wz) = (ix * WIDEN, iy * WIDEN, iz * WIDEN);
        let mut t_wide = Vec4::splat(t_max * WIDEN);
        let side = |i: f32, axis: usize| 2 * axis + usize::from(i < 0.0);
        let (nx, ny, nz) = (side(inv.x, 0), side(inv.y, 1), side(inv.z, 2));
        let (fx, fy, fz) = (nx ^ 1, ny ^ 1, nz ^ 1);
        let mut best: Option<Hit> = None;
        let mut t_best = t_max;
        // Stack of (first, count, entry distance) of children still to visit.
        let mut stack = Stack::<(u32, u32, f32), N>::new();
        box_hit(&self.nodes[0], o, inv, t_best)?;
        // The root: a leaf (its blocks start at 0), or quad 0.
        let (mut first, mut count) = (0, self.nodes[0].count());
        let wray = WideRay::new::<KZ>(ray);
        loop {
            if count > 0 {
                let first = first as usize;
                for b in &self.blocks[first..first + count.div_ceil(4) as usize] {
                    if let Some((k, t, u, v)) = b.hit::<KZ, FRONT>(&wray, ray, t_best) {
                        t_best = t;
                        t_wide = Vec4::splat(t * WIDEN);
                        best = Some(Hit { t, triangle: self.ids[k], u, v });
                        if ANY {
                            return best;
                        }
                    }
                }
            } else {
                let q = &self.quads[first as usize];
                let p = &q.planes;
                let near = ((p[nx] - ox) * ix).max((p[ny] - oy) * iy).max((p[nz] - oz) * iz).max(Vec4::ZERO);
                let far = ((p[fx] - ox) * wx).min((p[fy] - oy) * wy).min((p[fz] - oz) * wz).min(t_wide);
                let mask = near.cmple(far).bitmask();
                if mask != 0 {
                    let d: [f32; 4] = near.into();
                    // Entered children nearest first (lane order among equal distances).
                    let mut lanes = [0usize; 4];
                    let mut n = 0;
                    for i in 0..4 {
                        if mask & (1 << i) != 0 {
                            let mut j = n;
                            while j > 0 && d[lanes[j - 1]] > d[i] {
                                lanes[j] = lanes[j - 1];
                                j -= 1;
                            }
                            lanes[j] = i;
                            n += 1;
                        }
                    }
                    for &i in lanes[1..n].iter().rev() {
                        // `N` is at least the tree's need (`collapse`).
                        stack.push((q.first[i], q.count[i], d[i]));
                    }
                    (first, count) = (q.first[lanes[0]], q.count[lanes[0]]);
                    continue;
                }
            }
            // Pop, skipping children that the current best hit already rules out.
            loop {
                let Some((f, c, t_enter)) = stack.pop() else {
                    return best;
                };
                if t_enter <= t_best {
                    (first, count) = (f, c);
                    break;
                }
            }
        }
    }
}

/// Entry distance of the ray into the node's box when it enters before `t_max`.
#[inline(always)]
pub(crate) fn box_hit(node: &Node, origin: Vec3A, inv: Vec3A, t_max: f32) -> Option<f32> {
    let t0 = (Vec3A::from_vec4(node.lo) - origin) * inv;
    let t1 = (Vec3A::from_vec4(node.hi) - origin) * inv;
    let tnear = t0.min(t1).max_element().max(0.0);
    let tfar = t0.max(t1).min_element().min(t_max) * WIDEN;
    (tnear <= tfar).then_some(tnear)
}
