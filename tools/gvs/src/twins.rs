//! Twins: triangles that overlap another triangle in one plane with positive area, such as a
//! level's two-sided liquid surfaces (one face wound up, one down, split along different
//! diagonals) or a brush face lying on another. A ray through the shared area meets both at the
//! same distance, and which one it reports is a matter of rounding and lane order, so the error
//! metric ([`super::error`]) counts a pixel as shown when either twin is in the PVS.
//!
//! Coplanar means: each triangle's corners lie within `FLAT` × (1 + the largest coordinate of
//! the two) of the other's plane (computed in `f64`, so only the corners' own rounding to `f32`
//! counts). Overlap is tested in the plane's projection onto its two non-dominant axes, by
//! separating edges: touching along an edge or at a corner (within the same tolerance) is not
//! overlap. The relation is symmetric (but for the caps on crowded triangles, below).

use glam::{DVec2, DVec3, Vec3};
use rayon::prelude::*;
use sightline_raycast::Bvh;

use super::neighbours::touching_box;

/// Most distance of a twin's corner from the other's plane, relative to `1 +` the largest
/// coordinate of the two triangles (about 16 ulps of it).
const FLAT: f64 = 1e-6;
/// Triangles per parallel work item of the build.
const CHUNK: usize = 4096;
/// Most triangles whose boxes touch a triangle's box that the build examines for it (the first in
/// BVH order), and most twins it keeps: the build stays linear in the scene on any input (a
/// soup of many copies of one triangle, or long slivers all crossing one box). A crowded
/// triangle's pixels may then miss a twin, which only counts them wrong.
const MAX_CANDIDATES: usize = 256;
const MAX_TWINS: usize = 16;

/// Per triangle, its twins (compressed rows, ascending, at most `MAX_TWINS`; most triangles
/// have none).
#[derive(Debug, Clone, Default)]
pub struct Twins {
    /// Triangle `t`'s twins are `list[start[t]..start[t + 1]]`.
    start: Vec<u32>,
    list: Vec<u32>,
}

impl Twins {
    /// The twins of every triangle of `tris`, found through `bvh` (built over `tris`); in parallel,
    /// the same table for any thread count.
    pub fn build(tris: &[[Vec3; 3]], bvh: &Bvh) -> Twins {
        let rows: Vec<Vec<(u32, Vec<u32>)>> = (0..tris.len())
            .collect::<Vec<_>>()
            .par_chunks(CHUNK)
            .map(|chunk| {
                let mut rows = Vec::new();
                let mut found = Vec::new();
                for &t in chunk {
                    found.clear();
                    let tri = &tris[t];
                    let (lo, hi) = touching_box(tri);
                    let mut seen = 0;
                    bvh.overlapping(lo, hi, |u| {
                        if u as usize != t && tris.get(u as usize).is_some_and(|o| twins(tri, o)) {
                            found.push(u);
                        }
                        seen += 1;
                        seen < MAX_CANDIDATES && found.len() < MAX_TWINS
                    });
                    if !found.is_empty() {
                        found.sort_unstable();
                        rows.push((t as u32, found.clone()));
                    }
                }
                rows
            })
            .collect();
        let mut table = Twins { start: Vec::with_capacity(tris.len() + 1), list: Vec::new() };
        table.start.push(0);
        let mut rows = rows.into_iter().flatten().peekable();
        for t in 0..tris.len() as u32 {
            if let Some((_, row)) = rows.next_if(|(r, _)| *r == t) {
                table.list.extend_from_slice(&row);
            }
            table.start.push(table.list.len() as u32);
        }
        table
    }

    /// The twins of triangle `t` (none when out of range or not built).
    pub fn of(&self, t: u32) -> &[u32] {
        let t = t as usize;
        match (self.start.get(t), self.start.get(t + 1)) {
            (Some(&a), Some(&b)) => self.list.get(a as usize..b as usize).unwrap_or_default(),
            _ => &[],
        }
    }

    /// Number of triangles with at least one twin.
    pub fn count(&self) -> usize {
        self.start.windows(2).filter(|w| w[0] != w[1]).count()
    }
}

/// True when `a` and `b` lie in one plane and overlap there with positive area.
fn twins(a: &[Vec3; 3], b: &[Vec3; 3]) -> bool {
    let (a, b) = (a.map(|p| p.as_dvec3()), b.map(|p| p.as_dvec3()));
    let scale = 1.0 + a.iter().chain(&b).map(|p| p.abs().max_element()).fold(0.0, f64::max);
    let tol = FLAT * scale;
    let (Some(na), Some(nb)) = (normal(&a), normal(&b)) else {
        return false;
    };
    let within = |n: DVec3, on: DVec3, pts: &[DVec3; 3]| pts.iter().all(|p| n.dot(*p - on).abs() <= tol);
    if !within(na, a[0], &b) || !within(nb, b[0], &a) {
        return false;
    }
    // Project onto the two axes other than the normal's dominant one.
    let m = na.abs();
    let flat = |p: DVec3| {
        if m.x >= m.y && m.x >= m.z {
            DVec2::new(p.y, p.z)
        } else if m.y >= m.z {
            DVec2::new(p.z, p.x)
        } else {
            DVec2::new(p.x, p.y)
        }
    };
    let (pa, pb) = (a.map(flat), b.map(flat));
    !separated(&pa, &pb, tol) && !separated(&pb, &pa, tol)
}

/// Unit normal of `t` (`None` for a degenerate or non-finite triangle).
fn normal(t: &[DVec3; 3]) -> Option<DVec3> {
    (t[1] - t[0]).cross(t[2] - t[0]).try_normalize()
}

/// True when an edge of `a` has all of `b` on its outer side or within `tol` of its line.
fn separated(a: &[DVec2; 3], b: &[DVec2; 3], tol: f64) -> bool {
    let area = (a[1] - a[0]).perp_dot(a[2] - a[0]);
    if area == 0.0 {
        return true;
    }
    (0..3).any(|i| {
        let (p, q) = (a[i], a[(i + 1) % 3]);
        let edge = q - p;
        // Inside is where `area × (edge ⊥ · (x − p)) > 0`.
        b.iter().all(|x| area.signum() * edge.perp_dot(*x - p) <= tol * edge.length())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(z: f32, up: bool, diagonal: bool) -> Vec<[Vec3; 3]> {
        let p =
            [Vec3::new(0.0, 0.0, z), Vec3::new(2.0, 0.0, z), Vec3::new(2.0, 2.0, z), Vec3::new(0.0, 2.0, z)];
        let tris = if diagonal {
            [[p[0], p[1], p[2]], [p[0], p[2], p[3]]]
        } else {
            [[p[0], p[1], p[3]], [p[1], p[2], p[3]]]
        };
        tris.into_iter().map(|[a, b, c]| if up { [a, b, c] } else { [a, c, b] }).collect()
    }

    #[test]
    fn a_two_sided_surface_split_two_ways_is_twinned_and_edge_neighbours_are_not() {
        // Triangles 0, 1: a square wound up; 2, 3: the same square wound down along the other
        // diagonal; 4, 5: the square beside it (sharing an edge), 6, 7: the first square lifted.
        let mut tris = square(1.0, true, true);
        tris.extend(square(1.0, false, false));
        tris.extend(square(1.0, true, true).into_iter().map(|t| t.map(|p| p + Vec3::X * 2.0)));
        tris.extend(square(1.01, true, true));
        let bvh = Bvh::build(&tris);
        let t = Twins::build(&tris, &bvh);
        assert_eq!(t.of(0), &[2, 3]);
        assert_eq!(t.of(1), &[2, 3]);
        assert_eq!(t.of(2), &[0, 1]);
        assert_eq!(t.of(3), &[0, 1]);
        for k in 4..8 {
            assert!(t.of(k).is_empty(), "{k}: {:?}", t.of(k));
        }
        assert_eq!(t.count(), 4);
        assert!(t.of(99).is_empty());
    }

    #[test]
    fn a_soup_of_copies_keeps_bounded_rows() {
        let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let tris = vec![tri; 5000];
        let t = Twins::build(&tris, &Bvh::build(&tris));
        assert_eq!(t.count(), 5000);
        assert!((0..5000).all(|i| (1..=MAX_TWINS).contains(&t.of(i).len())));
    }

    #[test]
    fn degenerate_and_non_finite_triangles_have_no_twins() {
        let flat = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
        let nan = [Vec3::NAN, Vec3::X, Vec3::Y];
        let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let tris = [flat, nan, tri, tri];
        let t = Twins::build(&tris, &Bvh::build(&tris));
        assert!(t.of(0).is_empty() && t.of(1).is_empty());
        // Two copies of one triangle are twins.
        assert_eq!((t.of(2), t.of(3)), (&[3][..], &[2][..]));
    }
}
