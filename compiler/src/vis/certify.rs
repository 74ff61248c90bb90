//! Certified sight lines: a segment checked to pass through every winding of a portal chain.
//!
//! When a flow reaches a new cluster, the line from the middle of its clipped source to the middle
//! of its clipped target (and, when that misses, lines through the middle of a clipped pass
//! portal, [`extend`]ed to the source's or the target's plane) is tested exactly against the
//! *original* windings of the chain. If it
//! crosses each of them, in order, from behind to in front, and at least [`CERTIFY_MARGIN`] inside
//! every edge, that line is a sight line of the portal model: the clusters it runs through truly
//! see each other, and every conservative flow keeps those pairs, in either direction. The line
//! is then followed on through the portals it meets, past the target and back behind the source
//! ([`walk`]): the clusters there are on the same sight line (in a ring of leaves round a pillar,
//! this halves the flow's chains). A later flow from a portal the line crosses starts with the
//! clusters the line reaches beyond that portal seen (see [`super::flow::Flow::run`]), so
//! branches that could only find them are not explored. Such seeds change the work, not what is
//! visible through the portal. The PVS can still differ slightly, since the flow's beam cull tests
//! only portals into clusters not yet seen and so depends on the order clusters are found in, and
//! since a flow also starts with what its cluster's other portals saw ([`super::seeds`]): with
//! every seed, 60 pairs more than without on E1M1 (of 219,606) for 41 % fewer chains, 0.5 % more
//! on the generated `arena_32` for 45 % fewer. A line refused here is simply not used.

use glam::DVec3;
use sightline_formats::geom::Plane;

use super::graph::Graph;

/// How far inside every edge of every winding (units) a certified line must cross. Far above the
/// flow's [`super::poly::TOUCH_EPSILON`], so the line has a bundle of sight lines around it.
pub const CERTIFY_MARGIN: f64 = 1e-3;

/// Centroid of the points (their mean; inside for a convex winding).
pub fn centroid(pts: &[DVec3]) -> Option<DVec3> {
    if pts.len() < 3 {
        return None;
    }
    Some(pts.iter().copied().sum::<DVec3>() / pts.len() as f64)
}

/// `x` lies at least [`CERTIFY_MARGIN`] inside every edge line of a winding ([`edge_lines`](super::graph::edge_lines)).
#[inline]
pub fn inside(edges: &[[f64; 4]], x: DVec3) -> bool {
    !edges.is_empty()
        && edges.iter().all(|&[mx, my, mz, offset]| mx * x.x + my * x.y + mz * x.z - offset >= CERTIFY_MARGIN)
}

/// Where the line from `from` through `through` meets `plane`; `None` when it runs (nearly)
/// parallel to the plane. Any point will do as a candidate: [`crosses`] and [`inside`] decide.
pub fn extend(from: DVec3, through: DVec3, plane: &Plane) -> Option<DVec3> {
    let d = through - from;
    let along = plane.normal.dot(d);
    if along.abs() <= 1e-9 * d.length() {
        return None;
    }
    Some(from + d * (-plane.distance(from) / along))
}

/// The segment `a → b` crosses every (plane, winding edge lines) of `chain` in order: each from
/// behind to in front, at increasing parameters strictly between `a` and `b`, inside each winding
/// by the margin.
pub fn crosses<'a>(a: DVec3, b: DVec3, chain: impl IntoIterator<Item = (&'a Plane, &'a [[f64; 4]])>) -> bool {
    let d = b - a;
    let mut last = 0.0;
    for (plane, edges) in chain {
        let along = plane.normal.dot(d);
        if along <= 0.0 {
            return false;
        }
        let t = -plane.distance(a) / along;
        let through = t > last && t < 1.0 && inside(edges, a + d * t);
        if !through {
            return false;
        }
        last = t;
    }
    true
}

/// Follows the line from `a` through `b` beyond `b`, where it enters cluster `c` (through a
/// portal it crossed there): in each cluster, the nearest portal out of it that the line crosses
/// ahead, from behind to in front and [`CERTIFY_MARGIN`] inside its edges, leads to the next.
/// Appends the one-way portals so crossed (each leading into the next cluster), in order, until
/// the line meets no portal, or `limit` of them. Where the line from `a` to `b` is certified, the
/// line so extended is a sight line of the portal model too: every cluster it runs through sees
/// every other, each through the portal by which the line leaves it towards the other.
pub fn walk(g: &Graph, a: DVec3, b: DVec3, mut c: u32, limit: usize, out: &mut Vec<u32>) {
    let d = b - a;
    let mut last = 1.0;
    for _ in 0..limit {
        let mut next: Option<(f64, u32)> = None;
        for &qi in &g.cluster_portals[c as usize] {
            let q = &g.portals[qi as usize];
            let along = q.plane.normal.dot(d);
            if along <= 0.0 {
                continue;
            }
            let t = -q.plane.distance(a) / along;
            if t > last && next.is_none_or(|(nearest, _)| t < nearest) && inside(g.edges(q), a + d * t) {
                next = Some((t, qi));
            }
        }
        let Some((t, qi)) = next else { return };
        last = t;
        c = g.portals[qi as usize].leaf;
        out.push(qi);
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;
    use crate::vis::graph::edge_lines;

    fn square(x: f64, y0: f64, size: f64) -> Vec<DVec3> {
        vec![
            DVec3::new(x, y0, 0.0),
            DVec3::new(x, y0 + size, 0.0),
            DVec3::new(x, y0 + size, size),
            DVec3::new(x, y0, size),
        ]
    }

    fn edges(pts: &[DVec3], normal: DVec3) -> Vec<[f64; 4]> {
        let mut out = Vec::new();
        edge_lines(pts, normal, &mut out);
        out
    }

    #[test]
    fn a_straight_line_through_aligned_openings_is_certified() {
        let plane = |x: f64| Plane { normal: DVec3::X, dist: x };
        let (w1, w2) = (edges(&square(10.0, 0.0, 8.0), DVec3::X), edges(&square(20.0, 0.0, 8.0), DVec3::X));
        let chain = [(plane(10.0), w1.as_slice()), (plane(20.0), w2.as_slice())];
        let (a, b) = (DVec3::new(0.0, 4.0, 4.0), DVec3::new(30.0, 4.0, 4.0));
        assert!(crosses(a, b, chain.iter().map(|(p, w)| (p, *w))));
        // Backwards, the planes face the wrong way.
        assert!(!crosses(b, a, chain.iter().map(|(p, w)| (p, *w))));
        // Out of order: the second opening before the first.
        assert!(!crosses(a, b, chain.iter().rev().map(|(p, w)| (p, *w))));
        // Missing an opening, or grazing its edge within the margin.
        let w3 = edges(&square(20.0, 9.0, 8.0), DVec3::X);
        let off = [(plane(10.0), w1.as_slice()), (plane(20.0), w3.as_slice())];
        assert!(!crosses(a, b, off.iter().map(|(p, w)| (p, *w))));
        let graze = (DVec3::new(0.0, 8.0 - 1e-4, 4.0), DVec3::new(30.0, 8.0 - 1e-4, 4.0));
        assert!(!crosses(graze.0, graze.1, chain.iter().map(|(p, w)| (p, *w))));
        // A segment ending before the last opening.
        assert!(!crosses(a, DVec3::new(15.0, 4.0, 4.0), chain.iter().map(|(p, w)| (p, *w))));
    }

    #[test]
    fn extend_meets_the_plane_along_the_line_or_gives_none_when_parallel() {
        let plane = Plane { normal: DVec3::X, dist: 4.0 };
        let p = extend(DVec3::ZERO, DVec3::new(1.0, 1.0, 0.5), &plane).expect("meets");
        assert!((p - DVec3::new(4.0, 4.0, 2.0)).length() < 1e-12, "{p}");
        // Backwards too: from beyond the plane through a point further beyond.
        let q = extend(DVec3::new(8.0, 0.0, 0.0), DVec3::new(6.0, 1.0, 0.0), &plane).expect("meets");
        assert!((q - DVec3::new(4.0, 2.0, 0.0)).length() < 1e-12, "{q}");
        assert_eq!(extend(DVec3::ZERO, DVec3::new(0.0, 1.0, 1.0), &plane), None);
    }

    #[test]
    fn inside_accepts_either_turning_direction_and_refuses_degenerate_windings() {
        let mut w = square(0.0, 0.0, 8.0);
        let c = DVec3::new(0.0, 4.0, 4.0);
        assert!(inside(&edges(&w, DVec3::X), c));
        assert!(inside(&edges(&w, -DVec3::X), c), "the plane's normal either way");
        w.reverse();
        assert!(inside(&edges(&w, DVec3::X), c));
        assert!(!inside(&edges(&w, DVec3::X), DVec3::new(0.0, 9.0, 4.0)));
        // Within the margin of an edge is not inside; just beyond it is.
        assert!(!inside(&edges(&w, DVec3::X), DVec3::new(0.0, 8.0 - CERTIFY_MARGIN / 2.0, 4.0)));
        assert!(inside(&edges(&w, DVec3::X), DVec3::new(0.0, 8.0 - 2.0 * CERTIFY_MARGIN, 4.0)));
        assert!(!inside(&edges(&w[..2], DVec3::X), c));
        assert!(!inside(&[], c));
        // A repeated point (a zero-length edge) changes nothing; a winding of no area holds nothing.
        let mut doubled = w.clone();
        doubled.insert(1, w[1]);
        assert!(inside(&edges(&doubled, DVec3::X), c));
        let flat = [DVec3::ZERO, DVec3::new(0.0, 4.0, 0.0), DVec3::new(0.0, 8.0, 0.0)];
        assert!(!inside(&edges(&flat, DVec3::X), DVec3::new(0.0, 4.0, 0.0)));
        assert_eq!(centroid(&w), Some(c));
    }

    proptest! {
        /// On a regular polygon in any plane, either turning direction and either normal, a point
        /// is inside exactly when its distance to the nearest edge (computed apart, from the
        /// polygon's inradius) is at least the margin. Half the points are anywhere near the
        /// polygon, half within a few margins of an edge; points within 1e-9 of the margin may go
        /// either way.
        #[test]
        fn inside_is_the_distance_to_the_nearest_edge(
            sides in 3usize..12,
            radius in 0.1f64..5000.0,
            turn in 0.0f64..std::f64::consts::TAU,
            (ax, ay, az) in (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0),
            (px, py) in (-1.5f64..1.5, -1.5f64..1.5),
            (edge, along, depth_near) in (0usize..12, -0.3f64..0.3, -4.0f64..4.0),
            near: bool,
            offset in -1.0e4f64..1.0e4,
            reverse: bool,
            flip: bool,
        ) {
            let axis = DVec3::new(ax, ay, az);
            prop_assume!(axis.length() > 0.1);
            let n = axis.normalize();
            let u = n.any_orthonormal_vector();
            let v = n.cross(u);
            let origin = n * offset + u * 17.0 - v * 3.0;
            let at = |x: f64, y: f64| origin + u * x + v * y;
            let step = std::f64::consts::TAU / sides as f64;
            let mut pts: Vec<DVec3> = (0..sides)
                .map(|i| {
                    let a = turn + step * i as f64;
                    at(radius * a.cos(), radius * a.sin())
                })
                .collect();
            if reverse {
                pts.reverse();
            }
            // Edge `i` (between corners `i` and `i + 1`) has its outward normal at angle
            // `turn + step * (i + 0.5)`, at the inradius from the centre.
            let inradius = radius * (step / 2.0).cos();
            let half_edge = radius * (step / 2.0).sin();
            let (x, y) = if near {
                let a = turn + step * ((edge % sides) as f64 + 0.5);
                let r = inradius - depth_near * CERTIFY_MARGIN;
                let t = along * half_edge;
                (r * a.cos() - t * a.sin(), r * a.sin() + t * a.cos())
            } else {
                (px * radius, py * radius)
            };
            let depth = (0..sides)
                .map(|i| {
                    let a = turn + step * (i as f64 + 0.5);
                    inradius - (x * a.cos() + y * a.sin())
                })
                .fold(f64::INFINITY, f64::min);
            let tolerance = 1e-12 * (radius + offset.abs()) * 64.0;
            prop_assume!((depth - CERTIFY_MARGIN).abs() > tolerance);
            let normal = if flip { -n } else { n };
            let edges = edges(&pts, normal);
            prop_assert_eq!(inside(&edges, at(x, y)), depth >= CERTIFY_MARGIN, "depth {}", depth);
        }
    }
}
