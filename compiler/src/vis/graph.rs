//! One-way portals built from a portal file.
//!
//! A portal line joining clusters `A` (the side its winding faces) and `B` becomes two consecutive
//! one-way portals: the first stored in `A` and leading to `B`, whose plane is the negated winding
//! plane (its normal points into `B`, the neighbour it leads to), and the second stored in `B` and
//! leading to `A`, with the winding reversed and the winding plane (pointing into `A`).
//! "In front of a one-way portal" therefore means "on the side of the cluster it leads to".
//! Lines whose winding has no plane (zero area) or that join a cluster to itself pass no sight
//! line and are dropped (counted in [`Graph::dropped`]).

use glam::DVec3;
use sightline_formats::geom::Plane;
use sightline_formats::prt::PortalFile;

/// A one-way portal.
#[derive(Debug, Clone)]
pub struct OneWay {
    /// Plane whose normal points into [`OneWay::leaf`].
    pub plane: Plane,
    /// The cluster it leads to.
    pub leaf: u32,
    /// The cluster it is stored in.
    pub owner: u32,
    /// Range of its points in [`Graph::points`].
    pub start: u32,
    /// Number of points.
    pub len: u32,
    /// Centre of its bounding sphere.
    pub center: DVec3,
    /// Radius of its bounding sphere.
    pub radius: f64,
}

/// All one-way portals and, per cluster, the portals stored in it.
#[derive(Debug, Clone)]
pub struct Graph {
    /// One-way portals.
    pub portals: Vec<OneWay>,
    /// Winding points of every portal, back to back.
    pub points: Vec<DVec3>,
    /// Per cluster, the indices of the one-way portals leading out of it, largest winding first
    /// (ties in index order): the flow tests a frame's targets in this order, and finding the
    /// clusters behind wide openings first leaves fewer branches with anything new (on the
    /// generated open maps, 5–14 % fewer chains than in index order).
    pub cluster_portals: Vec<Vec<u32>>,
    /// Per cluster, the indices of the one-way portals leading into it.
    pub cluster_incoming: Vec<Vec<u32>>,
    /// Per portal, its bounding sphere as `[x, y, z, radius]`, packed for scans over many portals.
    pub spheres: Vec<[f64; 4]>,
    /// Per portal, the cluster it leads to ([`OneWay::leaf`]), packed for the flow's scans of a
    /// frame's targets: a merged cluster has thousands, and their [`OneWay`]s lie far apart.
    pub leaves: Vec<u32>,
    /// Per winding point, the line of the edge from it to the next point in its portal's plane
    /// ([`edge_lines`]), aligned with [`Graph::points`].
    pub edges: Vec<[f64; 4]>,
    /// Portal lines dropped (no plane, or joining a cluster to itself).
    pub dropped: usize,
    /// Every winding is planar and convex within [`WELL_FORMED_EPSILON`] (as compilers write
    /// them); then every winding clipped from them is too, and separator planes through an edge
    /// need no check that the rest of their winding lies behind them (see [`super::poly`]).
    pub convex: bool,
}

/// How far (units) a winding's points may stray from its plane, or beyond the line of one of its
/// edges, for the winding to count as planar and convex: a tenth of the clip band, so a plane
/// accepted on that assumption cuts at most that much of what a check would have kept.
pub const WELL_FORMED_EPSILON: f64 = 1e-3;

/// True when `pts` lie within [`WELL_FORMED_EPSILON`] of `plane` and inside every edge line.
fn well_formed(pts: &[DVec3], plane: &Plane) -> bool {
    let n = pts.len();
    let centre = pts.iter().copied().sum::<DVec3>() / n.max(1) as f64;
    (0..n).all(|i| {
        let (a, b) = (pts[i], pts[(i + 1) % n]);
        let mut inward = plane.normal.cross(b - a).normalize_or_zero();
        if inward.dot(centre - a) < 0.0 {
            inward = -inward;
        }
        plane.distance(a).abs() <= WELL_FORMED_EPSILON
            && pts.iter().all(|q| inward.dot(*q - a) >= -WELL_FORMED_EPSILON)
    })
}

impl Graph {
    /// Build the one-way portals; cluster numbers must already be checked against
    /// `prt.num_clusters` (the `.prt` reader does).
    pub fn new(prt: &PortalFile) -> Self {
        let num_clusters = prt.num_clusters as usize;
        // Sized from the file once (each portal line gives two one-way portals), not grown.
        let points: usize = prt.portals.iter().map(|l| l.winding.points.len()).sum();
        let mut g = Graph {
            portals: Vec::with_capacity(prt.portals.len() * 2),
            points: Vec::with_capacity(points * 2),
            cluster_portals: vec![Vec::new(); num_clusters],
            cluster_incoming: vec![Vec::new(); num_clusters],
            spheres: Vec::with_capacity(prt.portals.len() * 2),
            leaves: Vec::with_capacity(prt.portals.len() * 2),
            edges: Vec::with_capacity(points * 2),
            dropped: 0,
            convex: true,
        };
        let mut reversed = Vec::new();
        let mut areas = Vec::with_capacity(prt.portals.len() * 2);
        for line in &prt.portals {
            let [a, b] = line.leaves;
            let plane = line.winding.plane();
            let (Some(plane), true) =
                (plane, a != b && (a as usize) < num_clusters && (b as usize) < num_clusters)
            else {
                g.dropped += 1;
                continue;
            };
            let pts = &line.winding.points;
            g.convex &= well_formed(pts, &plane);
            reversed.clear();
            reversed.extend(pts.iter().rev());
            g.push(plane.flipped(), b, a, pts);
            g.push(plane, a, b, &reversed);
            let area = line.winding.area();
            areas.extend([area, area]);
        }
        for list in &mut g.cluster_portals {
            list.sort_by(|&x, &y| areas[y as usize].total_cmp(&areas[x as usize]));
        }
        g
    }

    fn push(&mut self, plane: Plane, leaf: u32, owner: u32, pts: &[DVec3]) {
        let center = pts.iter().copied().sum::<DVec3>() / pts.len().max(1) as f64;
        let radius = pts.iter().map(|p| p.distance(center)).fold(0.0, f64::max);
        let index = self.portals.len() as u32;
        self.spheres.push([center.x, center.y, center.z, radius]);
        self.leaves.push(leaf);
        self.portals.push(OneWay {
            plane,
            leaf,
            owner,
            start: self.points.len() as u32,
            len: pts.len() as u32,
            center,
            radius,
        });
        self.points.extend_from_slice(pts);
        edge_lines(pts, plane.normal, &mut self.edges);
        if let Some(list) = self.cluster_portals.get_mut(owner as usize) {
            list.push(index);
        }
        if let Some(list) = self.cluster_incoming.get_mut(leaf as usize) {
            list.push(index);
        }
    }

    /// Number of clusters.
    pub fn num_clusters(&self) -> usize {
        self.cluster_portals.len()
    }

    /// The winding points of a portal.
    #[inline]
    pub fn winding(&self, p: &OneWay) -> &[DVec3] {
        &self.points[p.start as usize..(p.start + p.len) as usize]
    }

    /// The edge lines of a portal's winding ([`Graph::edges`]).
    #[inline]
    pub fn edges(&self, p: &OneWay) -> &[[f64; 4]] {
        &self.edges[p.start as usize..(p.start + p.len) as usize]
    }
}

/// The edge lines of the convex winding `pts`, lying in a plane of unit normal `normal` (either
/// turning direction), appended to `out`, one per point: edge `i` runs from point `i` to point
/// `i + 1` and is `[m.x, m.y, m.z, offset]`, where `m · x - offset` is how far `x` lies inside
/// that edge (`m` the unit normal of the edge in the plane, pointing into the winding). A
/// zero-length edge constrains nothing; a winding of no area (or under 3 points) contains nothing.
pub fn edge_lines(pts: &[DVec3], normal: DVec3, out: &mut Vec<[f64; 4]>) {
    let n = pts.len();
    // Newell's area vector: its side of the plane gives the turning direction.
    let area: DVec3 = (0..n).map(|i| pts[i].cross(pts[(i + 1) % n])).sum();
    let turn = area.dot(normal);
    for i in 0..n {
        let a = pts[i];
        let e = pts[(i + 1) % n] - a;
        let len = e.length();
        out.push(if n < 3 || turn == 0.0 || !turn.is_finite() {
            [0.0, 0.0, 0.0, f64::INFINITY]
        } else if len == 0.0 {
            [0.0, 0.0, 0.0, f64::NEG_INFINITY]
        } else {
            let m = normal.cross(e) * (turn.signum() / len);
            [m.x, m.y, m.z, m.dot(a)]
        });
    }
}
