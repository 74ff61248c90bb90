//! Camera paths for walkthroughs: a random walk that keeps clear of walls, or a polyline given by
//! its points.
//!
//! # Conventions
//! - A step is an eye and a yaw in degrees (from +x towards +y); the walk's pitch is 0.
//! - The random walk moves horizontally at the start's height: a step goes `step` units along
//!   the yaw when the scene leaves at least twice that clear ahead (both faces of a triangle
//!   stop it), else the walk turns.

use glam::DVec3;
use sightline_job::rng::SplitMix64;
use sightline_raycast::Bvh;

/// One camera position of a path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Step {
    /// The eye.
    pub eye: DVec3,
    /// Yaw in degrees.
    pub yaw: f64,
}

/// A random walk of `steps` steps through the scene of `bvh` from `start` facing `yaw`, each
/// `step` units (positive): it goes straight on while the way is clear, and turns (left or right,
/// around, or a random yaw; one step in eight it first tries to turn left or right, to explore)
/// when it is not; when no way is clear it stays and turns around. Deterministic for `seed`.
pub fn random_walk(bvh: &Bvh, start: DVec3, yaw: f64, steps: usize, step: f64, seed: u64) -> Vec<Step> {
    let mut rng = SplitMix64::new(seed);
    let mut here = Step { eye: start, yaw };
    let mut out = Vec::with_capacity(steps);
    let clear = |eye: DVec3, yaw: f64| {
        let d = direction(yaw);
        bvh.intersect(eye.as_vec3(), d.as_vec3(), f32::INFINITY).is_none_or(|h| f64::from(h.t) > 2.0 * step)
    };
    for _ in 0..steps {
        out.push(here);
        let side = if rng.below(2) == 0 { 90.0 } else { -90.0 };
        let explore = rng.below(8) == 0;
        let mut tries = if explore {
            vec![here.yaw + side, here.yaw - side, here.yaw]
        } else {
            vec![here.yaw, here.yaw + side, here.yaw - side]
        };
        tries.push(here.yaw + 180.0);
        tries.extend((0..8).map(|_| rng.range_f64(0.0, 360.0)));
        match tries.into_iter().map(|y| y.rem_euclid(360.0)).find(|&y| clear(here.eye, y)) {
            Some(y) => here = Step { eye: here.eye + direction(y) * step, yaw: y },
            None => here.yaw = (here.yaw + 180.0).rem_euclid(360.0),
        }
    }
    out
}

/// The horizontal unit vector of `yaw` degrees.
fn direction(yaw: f64) -> DVec3 {
    let y = yaw.to_radians();
    DVec3::new(y.cos(), y.sin(), 0.0)
}

/// The steps of a polyline through `points`: the points themselves, or with `n` (at least 1) that
/// many steps spread evenly along it by length (the first and last points included when `n` is at
/// least 2). Each step faces the next (the last keeps the yaw before it; a lone point faces +x).
pub fn polyline(points: &[DVec3], n: Option<usize>) -> Vec<Step> {
    let eyes: Vec<DVec3> = match n {
        None => points.to_vec(),
        Some(n) => {
            let lengths: Vec<f64> = points.windows(2).map(|w| (w[1] - w[0]).length()).collect();
            let total: f64 = lengths.iter().sum();
            (0..n)
                .map(|i| {
                    let mut at = if n > 1 { total * i as f64 / (n - 1) as f64 } else { 0.0 };
                    for (w, &len) in points.windows(2).zip(&lengths) {
                        if at <= len && len > 0.0 {
                            return w[0] + (w[1] - w[0]) * (at / len);
                        }
                        at -= len;
                    }
                    points.last().copied().unwrap_or(DVec3::ZERO)
                })
                .collect()
        }
    };
    let mut yaw = 0.0;
    let mut out = Vec::with_capacity(eyes.len());
    for (i, &eye) in eyes.iter().enumerate() {
        if let Some(next) = eyes[i + 1..].iter().find(|p| (**p - eye).truncate().length() > 1e-9) {
            let d = *next - eye;
            yaw = d.y.atan2(d.x).to_degrees().rem_euclid(360.0);
        }
        out.push(Step { eye, yaw });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// A closed box of side 100 (two triangles a side), to walk inside.
    fn room() -> Vec<[Vec3; 3]> {
        let mut tris = Vec::new();
        let c = |x: f32, y: f32, z: f32| Vec3::new(x, y, z) * 100.0;
        let quads = [
            [c(0., 0., 0.), c(1., 0., 0.), c(1., 1., 0.), c(0., 1., 0.)],
            [c(0., 0., 1.), c(1., 0., 1.), c(1., 1., 1.), c(0., 1., 1.)],
            [c(0., 0., 0.), c(1., 0., 0.), c(1., 0., 1.), c(0., 0., 1.)],
            [c(0., 1., 0.), c(1., 1., 0.), c(1., 1., 1.), c(0., 1., 1.)],
            [c(0., 0., 0.), c(0., 1., 0.), c(0., 1., 1.), c(0., 0., 1.)],
            [c(1., 0., 0.), c(1., 1., 0.), c(1., 1., 1.), c(1., 0., 1.)],
        ];
        for [a, b, cc, d] in quads {
            tris.push([a, b, cc]);
            tris.push([a, cc, d]);
        }
        tris
    }

    #[test]
    fn a_random_walk_stays_inside_and_moves_a_step_at_a_time() {
        let bvh = Bvh::build(&room());
        for seed in 0..5 {
            let w = random_walk(&bvh, DVec3::splat(50.0), 30.0, 200, 7.0, seed);
            assert_eq!(w.len(), 200);
            assert_eq!(w, random_walk(&bvh, DVec3::splat(50.0), 30.0, 200, 7.0, seed), "deterministic");
            for s in &w {
                assert!(
                    s.eye.cmpgt(DVec3::splat(0.0)).all() && s.eye.cmplt(DVec3::splat(100.0)).all(),
                    "{s:?}"
                );
                assert_eq!(s.eye.z, 50.0);
            }
            for p in w.windows(2) {
                let d = (p[1].eye - p[0].eye).length();
                assert!(d == 0.0 || (d - 7.0).abs() < 1e-9, "a step of {d}");
            }
            assert!(w.windows(2).filter(|p| p[0].eye != p[1].eye).count() > 150, "it moves");
        }
    }

    #[test]
    fn a_polyline_is_walked_evenly_facing_ahead() {
        let pts = [DVec3::ZERO, DVec3::new(10.0, 0.0, 0.0), DVec3::new(10.0, 10.0, 0.0)];
        let own = polyline(&pts, None);
        assert_eq!(own.iter().map(|s| s.eye).collect::<Vec<_>>(), pts);
        assert_eq!(own.iter().map(|s| s.yaw).collect::<Vec<_>>(), [0.0, 90.0, 90.0]);
        let even = polyline(&pts, Some(5));
        let eyes: Vec<DVec3> = even.iter().map(|s| s.eye).collect();
        let want = [(0.0, 0.0), (5.0, 0.0), (10.0, 0.0), (10.0, 5.0), (10.0, 10.0)];
        for (e, (x, y)) in eyes.iter().zip(want) {
            assert!((*e - DVec3::new(x, y, 0.0)).length() < 1e-9, "{eyes:?}");
        }
        assert_eq!(polyline(&pts, Some(1)).len(), 1);
        assert_eq!(
            polyline(&[DVec3::ONE], Some(3)).iter().map(|s| s.eye).collect::<Vec<_>>(),
            [DVec3::ONE; 3]
        );
    }
}
