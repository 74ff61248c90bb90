//! The brute-force reference: every triangle through the same watertight test.

use glam::Vec3;

use crate::Hit;
use crate::node::Prepared;
use crate::triangle::{Ray, tri_hit_sided};

/// Brute-force closest hit over all `triangles`, with the same triangle test as the tree (a
/// reference for tests and for tiny scenes).
pub fn intersect_brute(triangles: &[[Vec3; 3]], origin: Vec3, dir: Vec3, t_max: f32) -> Option<Hit> {
    brute::<false>(triangles, origin, dir, t_max)
}

/// [`intersect_brute`] among the triangles the ray meets from their front, the reference of
/// [`Bvh::intersect_front`](crate::Bvh::intersect_front).
pub fn intersect_brute_front(triangles: &[[Vec3; 3]], origin: Vec3, dir: Vec3, t_max: f32) -> Option<Hit> {
    brute::<true>(triangles, origin, dir, t_max)
}

fn brute<const FRONT: bool>(triangles: &[[Vec3; 3]], origin: Vec3, dir: Vec3, t_max: f32) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    let mut t_best = t_max;
    let ray = Ray::new(origin, dir);
    for (i, &[a, b, c]) in triangles.iter().enumerate() {
        if !(a.is_finite() && b.is_finite() && c.is_finite()) {
            continue;
        }
        let tri = Prepared { v0: a, v1: b, v2: c };
        let hit = match ray.kz {
            0 => tri_hit_sided::<0, FRONT>(&tri, &ray, t_best),
            1 => tri_hit_sided::<1, FRONT>(&tri, &ray, t_best),
            _ => tri_hit_sided::<2, FRONT>(&tri, &ray, t_best),
        };
        if let Some((t, u, v)) = hit {
            t_best = t;
            best = Some(Hit { t, triangle: i as u32, u, v });
        }
    }
    best
}
