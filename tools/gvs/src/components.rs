//! Connected surface components, for target sampling: two triangles are connected when they share
//! a corner (bit-identical coordinates, as a mesh's shared vertices are), and a component is a
//! maximal connected set. Built once per scene.
//!
//! Target sampling aims at the parts of the scene that nothing has reached: a component with a
//! triangle in the PVS is reached (ABS and neighbour probing go on along its surface), one without
//! is not, however close it lies to reached ones (a lone triangle beside a found sphere).

use glam::Vec3;
use rayon::prelude::*;
use sightline_formats::bits;

use super::geom::Cell;
use super::union_find::ParityForest;

/// The component of every triangle.
#[derive(Debug, Clone, Default)]
pub struct Components {
    /// Component index per triangle (components numbered in order of their first triangle);
    /// non-finite triangles get [`Components::NONE`].
    of: Vec<u32>,
    count: usize,
    /// Per component, the bounding box of its triangles.
    bounds: Vec<Cell>,
}

impl Components {
    /// The component of a non-finite triangle (never hit, never aimed at).
    pub const NONE: u32 = u32::MAX;

    /// The components of `tris`. Deterministic: corners are sorted (in parallel) by their bits and
    /// triangle, and triangles sharing a corner are joined (union-find).
    pub fn build(tris: &[[Vec3; 3]]) -> Components {
        // Corners as (coordinate bits, triangle).
        let mut corners: Vec<([u32; 3], u32)> = tris
            .par_iter()
            .enumerate()
            .filter(|(_, t)| finite(t))
            .flat_map_iter(|(i, t)| t.iter().map(move |&p| (corner_key(p), i as u32)))
            .collect();
        corners.par_sort_unstable();
        let mut forest = ParityForest::new(tris.len());
        for w in corners.windows(2) {
            if w[0].0 == w[1].0 {
                forest.join(w[0].1, w[1].1, false);
            }
        }
        let mut of = vec![Self::NONE; tris.len()];
        let mut bounds: Vec<Cell> = Vec::new();
        for (i, t) in tris.iter().enumerate() {
            if !finite(t) {
                continue;
            }
            let r = forest.find(i as u32).0 as usize;
            if of[r] == Self::NONE {
                of[r] = bounds.len() as u32;
                bounds.push(Cell { min: Vec3::INFINITY, max: Vec3::NEG_INFINITY });
            }
            of[i] = of[r];
            if let Some(b) = bounds.get_mut(of[i] as usize) {
                for &p in t {
                    b.min = b.min.min(p);
                    b.max = b.max.max(p);
                }
            }
        }
        Components { of, count: bounds.len(), bounds }
    }

    /// Component of triangle `t` ([`Components::NONE`] for a non-finite or unknown triangle).
    pub fn of(&self, t: u32) -> u32 {
        self.of.get(t as usize).copied().unwrap_or(Self::NONE)
    }

    /// Bounding box of component `c` (`None` for [`Components::NONE`] or an unknown component).
    pub fn bounds(&self, c: u32) -> Option<&Cell> {
        self.bounds.get(c as usize)
    }

    /// Number of components.
    pub fn count(&self) -> usize {
        self.count
    }

    /// True when the table was built (an empty table knows no component).
    pub fn is_empty(&self) -> bool {
        self.of.is_empty()
    }

    /// Per component, true when one of `found` belongs to it (triangles of no component are
    /// skipped).
    pub fn reached(&self, found: impl IntoIterator<Item = u32>) -> Vec<bool> {
        let mut reached = vec![false; self.count];
        for t in found {
            if let Some(r) = reached.get_mut(self.of(t) as usize) {
                *r = true;
            }
        }
        reached
    }

    /// Bitset over `n` triangles (a `formats::bits` word row) of every triangle whose component
    /// holds one of `found`: the PVS at the level of objects, as the thesis counts its error
    /// (a pixel of a sphere is wrong only when no part of that sphere was found). Triangles of
    /// no component are covered when they are in `found` themselves.
    pub fn covered(&self, n: usize, found: impl IntoIterator<Item = u32> + Clone) -> Vec<u64> {
        let reached = self.reached(found.clone());
        let mut row = vec![0u64; bits::words(n)];
        let mut set = |t: u32| bits::set(&mut row, t as usize);
        for t in found {
            if self.of(t) == Self::NONE {
                set(t);
            }
        }
        for t in 0..n.min(self.of.len()) as u32 {
            if reached.get(self.of(t) as usize) == Some(&true) {
                set(t);
            }
        }
        row
    }
}

/// A corner as the bits of its coordinates, the identity of shared vertices (−0 and +0 are the
/// same point).
pub(super) fn corner_key(p: Vec3) -> [u32; 3] {
    p.to_array().map(|c| if c == 0.0 { 0 } else { c.to_bits() })
}

/// True when every corner of `t` is finite (others belong to no component and no sheet).
pub(super) fn finite(t: &[Vec3; 3]) -> bool {
    t.iter().all(|p| p.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shared_corners_connect_and_lone_triangles_stay_apart() {
        let (a, b, c, d) = (Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0));
        let far = Vec3::splat(10.0);
        let nan = Vec3::NAN;
        let tris = [
            [a, b, c],
            [far, far + Vec3::X, far + Vec3::Y],
            [b, d, c],
            [nan, a, b],
            // Touches the first only at a point that is not a corner of both: not connected.
            [Vec3::new(0.5, 0.0, 0.0), Vec3::new(0.5, -1.0, 0.0), Vec3::new(0.6, -1.0, 0.0)],
            // -0.0 is the same corner as 0.0.
            [Vec3::new(-0.0, 0.0, 0.0), Vec3::new(0.0, 0.0, -1.0), Vec3::new(0.0, -1.0, -1.0)],
        ];
        let comp = Components::build(&tris);
        assert_eq!(comp.count(), 3);
        assert_eq!(comp.of(0), 0);
        assert_eq!(comp.of(1), 1);
        assert_eq!(comp.of(2), 0);
        assert_eq!(comp.of(3), Components::NONE);
        assert_eq!(comp.of(4), 2);
        assert_eq!(comp.of(5), 0);
        assert_eq!(comp.of(99), Components::NONE);
        let bounds = |c: u32| comp.bounds(c).map(|b| (b.min, b.max));
        assert_eq!(bounds(0), Some((Vec3::new(0.0, -1.0, -1.0), Vec3::new(1.0, 1.0, 0.0))));
        assert_eq!(bounds(1), Some((far, far + Vec3::new(1.0, 1.0, 0.0))));
        assert_eq!(bounds(2), Some((Vec3::new(0.5, -1.0, 0.0), Vec3::new(0.6, 0.0, 0.0))));
        assert_eq!(bounds(Components::NONE), None);
    }

    #[test]
    fn covered_spreads_a_found_triangle_over_its_component() {
        let (a, b, c, d) = (Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0));
        let far = Vec3::splat(10.0);
        let tris = [[a, b, c], [far, far + Vec3::X, far + Vec3::Y], [b, d, c], [Vec3::NAN, a, b]];
        let comp = Components::build(&tris);
        // Triangle 3 (non-finite) belongs to no component.
        assert_eq!(comp.reached([2, 3]), vec![true, false]);
        assert_eq!(comp.covered(4, [2]), vec![0b0101]);
        assert_eq!(comp.covered(4, [1, 3]), vec![0b1010]);
        assert_eq!(comp.covered(4, []), vec![0]);
        // Without a table only the found triangles themselves are covered.
        assert_eq!(Components::default().covered(4, [2]), vec![0b0100]);
    }

    #[test]
    fn the_same_for_any_thread_count() {
        let sc = crate::scenegen::spheres(60, true, 5);
        let build = |n| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(n).build().expect("pool");
            pool.install(|| Components::build(&sc.triangles))
        };
        let (one, two) = (build(1), build(2));
        assert_eq!(one.of, two.of);
        // 30 spheres of 80 triangles and 30 lone triangles.
        assert_eq!(one.count(), 60);
    }
}
