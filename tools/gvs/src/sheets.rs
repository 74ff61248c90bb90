//! Sheets: triangles joined through shared edges (both corners bit-identical, as a mesh's shared
//! vertices are), with each triangle's winding relative to the other triangles of its sheet. Built
//! once per scene beside the neighbour table.
//!
//! Neighbour probing casts most of its rays from the side of a triangle it expects the triangle to
//! be seen from. Once a triangle has been seen from one side, the triangles of its sheet are seen
//! from the side that agrees with it through their windings, whichever way the mesh is wound
//! (counter-clockwise seen from outside, clockwise, or a two-sided surface seen from below).
//!
//! Two triangles that share an edge are wound alike when the edge runs opposite ways in them. A
//! sheet whose edges cannot all agree (a Möbius strip, or two triangles wound against each other)
//! keeps the relations found first, edges taken in sorted order, so the result is deterministic.

use glam::Vec3;
use rayon::prelude::*;

use super::components::{corner_key, finite};
use super::union_find::ParityForest;

/// Per triangle, its sheet and whether it is wound against the sheet's first triangle.
#[derive(Debug, Clone, Default)]
pub struct Sheets {
    /// Sheet per triangle (the index of a triangle of the sheet); [`Sheets::NONE`] for a
    /// non-finite triangle.
    sheet: Vec<u32>,
    /// Per triangle: wound against the triangle that names its sheet.
    flipped: Vec<bool>,
}

impl Sheets {
    /// The sheet of a non-finite triangle (it shares no edge).
    pub const NONE: u32 = u32::MAX;

    /// The sheets of `tris`. Edges are sorted (in parallel) by their corners' bits, and the
    /// triangles sharing one are joined by a union-find that keeps the parity of each triangle's
    /// winding to its root.
    pub fn build(tris: &[[Vec3; 3]]) -> Sheets {
        // (lower corner, higher corner, triangle, runs from the lower to the higher corner).
        let mut edges: Vec<([u32; 3], [u32; 3], u32, bool)> = tris
            .par_iter()
            .enumerate()
            .filter(|(_, t)| finite(t))
            .flat_map_iter(|(i, t)| {
                (0..3).filter_map(move |k| {
                    let (a, b) = (corner_key(t[k]), corner_key(t[(k + 1) % 3]));
                    match a.cmp(&b) {
                        std::cmp::Ordering::Less => Some((a, b, i as u32, true)),
                        std::cmp::Ordering::Greater => Some((b, a, i as u32, false)),
                        std::cmp::Ordering::Equal => None,
                    }
                })
            })
            .collect();
        edges.par_sort_unstable();
        let mut uf = ParityForest::new(tris.len());
        for run in edges.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1)) {
            let first = run[0];
            for e in &run[1..] {
                // The same direction in both: wound against each other.
                uf.join(first.2, e.2, first.3 == e.3);
            }
        }
        let (mut sheet, mut flipped) = (vec![Self::NONE; tris.len()], vec![false; tris.len()]);
        for (i, t) in tris.iter().enumerate() {
            if finite(t) {
                (sheet[i], flipped[i]) = uf.find(i as u32);
            }
        }
        Sheets { sheet, flipped }
    }

    /// The sheet of triangle `t` (the index of the triangle that names it) and whether `t` is
    /// wound against that triangle; `None` for a non-finite or unknown triangle or an empty table.
    pub fn of(&self, t: u32) -> Option<(u32, bool)> {
        let s = *self.sheet.get(t as usize)?;
        (s != Self::NONE).then(|| (s, self.flipped.get(t as usize).copied().unwrap_or(false)))
    }

    /// Bytes the table holds.
    pub fn bytes(&self) -> usize {
        self.sheet.len() * size_of::<u32>() + self.flipped.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `Some(true)` when `a` and `b` lie in one sheet wound alike, `Some(false)` when wound
    /// against each other, `None` otherwise.
    fn same_winding(s: &Sheets, a: u32, b: u32) -> Option<bool> {
        let ((sa, fa), (sb, fb)) = (s.of(a)?, s.of(b)?);
        (sa == sb).then_some(fa == fb)
    }

    /// A closed tetrahedron wound consistently, one face turned round, and a lone triangle.
    #[test]
    fn shared_edges_relate_windings_and_sheets_stay_apart() {
        let (a, b, c, d) = (Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z);
        let far = Vec3::splat(10.0);
        let tris = vec![
            [a, c, b],
            [a, b, d],
            [b, c, d],
            [c, a, d],
            [far, far + Vec3::X, far + Vec3::Y],
            [Vec3::NAN, b, c],
        ];
        let s = Sheets::build(&tris);
        for i in 0..4 {
            for j in 0..4 {
                assert_eq!(same_winding(&s, i, j), Some(true), "{i} {j}");
            }
            assert_eq!(same_winding(&s, i, 4), None);
            assert_eq!(same_winding(&s, i, 5), None);
        }
        assert_eq!(same_winding(&s, 5, 5), None);
        assert_eq!(same_winding(&s, 4, 4), Some(true));
        assert_eq!(same_winding(&s, 0, 99), None);
        // Turning one face round: it is wound against the other three, which still agree.
        let mut turned = tris.clone();
        turned[2] = [b, d, c];
        let s = Sheets::build(&turned);
        for i in [0, 1, 3] {
            assert_eq!(same_winding(&s, i, 2), Some(false), "{i}");
            assert_eq!(same_winding(&s, 2, i), Some(false), "{i}");
            for j in [0, 1, 3] {
                assert_eq!(same_winding(&s, i, j), Some(true), "{i} {j}");
            }
        }
    }

    /// A long strip of triangles, every second one wound the other way: the parity travels along
    /// the whole strip (deep union-find paths), whatever the order of the triangles.
    #[test]
    fn parity_travels_along_a_strip() {
        let n = 2000;
        let p = |k: usize| Vec3::new((k / 2) as f32, (k % 2) as f32, 0.0);
        let mut tris: Vec<[Vec3; 3]> = (0..n)
            .map(|k| if k % 3 == 0 { [p(k), p(k + 2), p(k + 1)] } else { [p(k), p(k + 1), p(k + 2)] })
            .collect();
        tris.reverse();
        let s = Sheets::build(&tris);
        // Flat and side by side, two triangles are wound alike exactly when their normals agree.
        let normal_z = |t: &[Vec3; 3]| (t[1] - t[0]).cross(t[2] - t[0]).z > 0.0;
        for (i, t) in tris.iter().enumerate() {
            let want = normal_z(t) == normal_z(&tris[0]);
            assert_eq!(same_winding(&s, 0, i as u32), Some(want), "triangle {i}");
        }
    }
}
