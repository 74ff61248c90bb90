//! The brute-force reference: every triangle through the same watertight test.

use glam::Vec3;

use crate::Hit;
use crate::node::Prepared;
use crate::triangle::{Ray, tri_hit};

/// Brute-force closest hit over all `triangles`, with the same triangle test as the tree (a
/// reference for tests and for tiny scenes).
pub fn intersect_brute(triangles: &[[Vec3; 3]], origin: Vec3, dir: Vec3, t_max: f32) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    let mut t_best = t_max;
    let ray = Ray::new(origin, dir);
    for (i, &[a, b, c]) in triangles.iter().enumerate() {
        if !(a.is_finite() && b.is_finite() && c.is_finite()) {
            continue;
        }
        let tri = Prepared { v0: a, v1: b, v2: c };
        let hit = match ray.kz {
            0 => tri_hit::<0>(&tri, &ray, t_best),
            1 => tri_hit::<1>(&tri, &ray, t_best),
            _ => tri_hit::<2>(&tri, &ray, t_best),
        };
        if let Some((t, u, v)) = hit {
            t_best = t;
            best = Some(Hit { t, triangle: i as u32, u, v });
        }
    }
    best
}
