//! Points inside a leaf's convex cell. The cell is the intersection of the half-spaces on the path
//! from the root to the leaf and the leaf's bounding box; points are drawn by hit-and-run (a random
//! chord through the current point, then a uniform point on it), which stays inside the cell
//! however thin or slanted it is, unlike rejection sampling in the box.

use glam::DVec3;

use super::rng::Rng;

/// Inward margin, in world units, kept from every face of the cell by the starting point.
const START_MARGIN: f64 = 1e-3;

/// A convex cell as half-spaces `normal · p - dist >= 0`.
#[derive(Debug, Clone)]
pub struct Cell {
    half_spaces: Vec<(DVec3, f64)>,
}

impl Cell {
    /// The cell bounded by `path` (the node half-spaces down to the leaf) and the box `mins..maxs`.
    pub fn new(mut path: Vec<(DVec3, f64)>, mins: DVec3, maxs: DVec3) -> Self {
        for axis in 0..3 {
            let mut n = DVec3::ZERO;
            n[axis] = 1.0;
            path.push((n, mins[axis]));
            path.push((-n, -maxs[axis]));
        }
        Self { half_spaces: path }
    }

    /// Largest violation of any half-space by `p` (0 when inside).
    fn violation(&self, p: DVec3) -> f64 {
        self.half_spaces.iter().map(|&(n, d)| d - n.dot(p)).fold(0.0, f64::max)
    }

    /// A point inside the cell found by cyclic projection onto violated half-spaces, starting at
    /// `guess`; `None` when the cell is empty or too thin to hold a point with the margin.
    pub fn interior_point(&self, guess: DVec3) -> Option<DVec3> {
        let mut p = guess;
        for _ in 0..2000 {
            let mut moved = false;
            for &(n, d) in &self.half_spaces {
                let gap = d + START_MARGIN - n.dot(p);
                if gap > 0.0 {
                    p += n * gap;
                    moved = true;
                }
            }
            if !moved {
                return Some(p);
            }
        }
        (self.violation(p) <= 0.0).then_some(p)
    }

    /// One hit-and-run step from `p` (inside): a uniform point on a random chord through `p`.
    pub fn step(&self, p: DVec3, rng: &mut Rng) -> DVec3 {
        let u = rng.direction();
        let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
        for &(n, d) in &self.half_spaces {
            // n·(p + s u) >= d  ⇔  s (n·u) >= d - n·p
            let nu = n.dot(u);
            let slack = d - n.dot(p);
            if nu > 1e-12 {
                lo = lo.max(slack / nu);
            } else if nu < -1e-12 {
                hi = hi.min(slack / nu);
            } else if slack > 0.0 {
                return p;
            }
        }
        if !(lo.is_finite() && hi.is_finite()) || hi < lo {
            return p;
        }
        p + u * (lo + (hi - lo) * rng.unit())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_stay_in_a_slanted_thin_cell() {
        // A slab 0.05 thick across the diagonal of a 100-unit box.
        let n = DVec3::new(1.0, 1.0, 0.0).normalize();
        let cell = Cell::new(vec![(n, 0.0), (-n, -0.05)], DVec3::splat(-50.0), DVec3::splat(50.0));
        let mut p = cell.interior_point(DVec3::new(30.0, 20.0, 0.0)).unwrap();
        let mut rng = Rng::for_key(3, 0, 0);
        let mut spread = 0.0f64;
        for _ in 0..1000 {
            p = cell.step(p, &mut rng);
            assert!(cell.violation(p) < 1e-9, "{p:?}");
            spread = spread.max(p.z.abs());
        }
        assert!(spread > 20.0, "hit-and-run should wander through the slab, got {spread}");
    }

    #[test]
    fn empty_cell_has_no_point() {
        let n = DVec3::X;
        let cell = Cell::new(vec![(n, 10.0), (-n, 5.0)], DVec3::splat(-50.0), DVec3::splat(50.0));
        assert!(cell.interior_point(DVec3::ZERO).is_none());
    }
}
