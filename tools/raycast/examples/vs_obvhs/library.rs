//! obvhs' CWBVH behind the calls the benchmark makes of ours, and the comparison of two closest
//! hits (shared by the `vs_obvhs` example and the `vs_obvhs` test).

use std::time::Duration;

use glam::{Vec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::cwbvh::{CwBvh, builder::build_cwbvh_from_tris};
use obvhs::ray::{Ray, RayHit};
use obvhs::rt_triangle::RtTriangle;
use obvhs::triangle::Triangle;
use sightline_raycast::Bvh;

/// Relative tolerance on a hit's `t` for two closest hits to agree.
pub const T_EPS: f32 = 1e-4;
/// Absolute tolerance, in world units along the ray, for two closest hits to agree (coplanar
/// faces a hair apart, seen from close by).
pub const DIST_EPS: f32 = 1e-3;
/// Barycentric distance from an edge under which a disagreement is a graze.
pub const EDGE_EPS: f64 = 1e-4;

/// obvhs' tree and its triangles in leaf order.
pub struct Theirs {
    bvh: CwBvh,
    tris: Vec<RtTriangle>,
}

impl Theirs {
    pub fn build(triangles: &[[Vec3; 3]]) -> Theirs {
        let tris: Vec<Triangle> = triangles
            .iter()
            .map(|t| Triangle { v0: t[0].into(), v1: t[1].into(), v2: t[2].into() })
            .collect();
        let bvh = build_cwbvh_from_tris(&tris, BvhBuildParams::medium_build(), &mut Duration::default());
        let tris = bvh.primitive_indices.iter().map(|&i| RtTriangle::from(&tris[i as usize])).collect();
        Theirs { bvh, tris }
    }

    pub fn heap_bytes(&self) -> usize {
        size_of_val(self.bvh.nodes.as_slice())
            + size_of_val(self.bvh.primitive_indices.as_slice())
            + size_of_val(self.tris.as_slice())
    }

    /// Closest hit: `(t, triangle index in the build slice)`.
    pub fn intersect(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, u32)> {
        let mut hit = RayHit::none();
        let ray = Ray::new(Vec3A::from(o), Vec3A::from(d), 0.0, t_max);
        self.bvh
            .ray_traverse(ray, &mut hit, |ray, id| self.tris[id].intersect(ray))
            .then(|| (hit.t, self.bvh.primitive_indices[hit.primitive_id as usize]))
    }

    pub fn occluded(&self, o: Vec3, d: Vec3, t_max: f32) -> bool {
        let ray = Ray::new(Vec3A::from(o), Vec3A::from(d), 0.0, t_max);
        !self.bvh.ray_traverse_miss(ray, |ray, id| self.tris[id].intersect(ray))
    }
}

/// How the two closest hits of one ray compare.
#[derive(Debug)]
pub enum Agreement {
    /// Both miss, or both hit the same triangle or at `t` within [`T_EPS`] relative or
    /// [`DIST_EPS`] world units (a tie).
    Same,
    /// Otherwise, and the nearer of the two hits is within [`EDGE_EPS`] of its triangle's edge (a
    /// ray through a shared edge, which the watertight test, ours, cannot let through and the
    /// Möller–Trumbore test, obvhs', can) or within [`EDGE_EPS`] units of the origin (a ray
    /// starting on a surface, which rounding puts on either side).
    Graze,
    /// Any other difference: ours, theirs.
    Differ(Option<(f32, u32)>, Option<(f32, u32)>),
}

/// Compare the closest hits of ray `o + t d` in both trees over `tris`.
pub fn compare(tris: &[[Vec3; 3]], o: Vec3, d: Vec3, ours: &Bvh, theirs: &Theirs) -> Agreement {
    let a = ours.intersect(o, d, f32::INFINITY).map(|h| (h.t, h.triangle));
    let b = theirs.intersect(o, d, f32::INFINITY);
    match (a, b) {
        (None, None) => return Agreement::Same,
        (Some(a), Some(b))
            if a.1 == b.1
                || (a.0 - b.0).abs() <= T_EPS * a.0.max(b.0)
                || (a.0 - b.0).abs() * d.length() <= DIST_EPS =>
        {
            return Agreement::Same;
        }
        _ => {}
    }
    let nearer = match (a, b) {
        (Some(a), Some(b)) => {
            if a.0 <= b.0 {
                a
            } else {
                b
            }
        }
        (Some(h), None) | (None, Some(h)) => h,
        (None, None) => return Agreement::Same,
    };
    if f64::from(nearer.0) * d.as_dvec3().length() < EDGE_EPS {
        return Agreement::Graze;
    }
    let near_edge = tris.get(nearer.1 as usize).is_some_and(|t| {
        let p = o.as_dvec3() + d.as_dvec3() * f64::from(nearer.0);
        let [v0, v1, v2] = t.map(|v| v.as_dvec3());
        let n = (v1 - v0).cross(v2 - v0);
        let area = n.length_squared();
        let u = (v2 - v1).cross(p - v1).dot(n) / area;
        let v = (v0 - v2).cross(p - v2).dot(n) / area;
        area > 0.0 && u.min(v).min(1.0 - u - v) < EDGE_EPS
    });
    if near_edge { Agreement::Graze } else { Agreement::Differ(a, b) }
}
