//! Geometry primitives shared by the compiler, the runtime and the tools.
//!
//! # Conventions
//! - Units are Quake map units; world coordinates are bounded by [`WORLD_LIMIT`].
//! - A [`Plane`] is `normal · p = dist` with a unit normal. The **front** side is where
//!   `normal · p - dist > 0`; the back side is solid for a brush side.
//! - A [`Winding`] is a convex planar polygon whose points run **clockwise seen from the front** of
//!   its plane (Quake's convention): the plane of `p0, p1, p2` has normal
//!   `normalize((p0 - p1) × (p2 - p1))`, exactly as `.map` sides and `.prt` windings define it.
//! - Epsilons: [`ON_EPSILON`] is the one distance tolerance for "this point is on the plane" in
//!   compile-time clipping and classification; plane identity uses [`NORMAL_EPSILON`] and
//!   [`DIST_EPSILON`]. Callers that must round toward a particular answer (vis rounds toward
//!   *visible*) pass their own epsilon to the `*_eps` functions and say why where they do.

use glam::DVec3;

/// Distance within which a point counts as lying on a plane when clipping and classifying.
pub const ON_EPSILON: f64 = 0.01;
/// Two unit normals are the same when every component differs by less than this.
pub const NORMAL_EPSILON: f64 = 1e-6;
/// Two plane distances are the same when they differ by less than this.
pub const DIST_EPSILON: f64 = 1e-4;
/// Largest absolute coordinate accepted anywhere in a map or level.
pub const WORLD_LIMIT: f64 = 1.0e6;
/// Half-size of the square that [`Winding::base_for_plane`] starts from; well beyond the world.
pub const BASE_WINDING_SIZE: f64 = 4.0 * WORLD_LIMIT;

/// Which way a plane's normal points, as Quake classifies it (used to pick fast paths).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum PlaneKind {
    /// Normal is exactly ±X.
    AxialX,
    /// Normal is exactly ±Y.
    AxialY,
    /// Normal is exactly ±Z.
    AxialZ,
    /// Not axial, largest component along X.
    NearX,
    /// Not axial, largest component along Y.
    NearY,
    /// Not axial, largest component along Z.
    NearZ,
}

impl PlaneKind {
    /// Classify a unit normal.
    pub fn of(normal: DVec3) -> Self {
        if normal.x.abs() == 1.0 {
            return Self::AxialX;
        }
        if normal.y.abs() == 1.0 {
            return Self::AxialY;
        }
        if normal.z.abs() == 1.0 {
            return Self::AxialZ;
        }
        let a = normal.abs();
        if a.x >= a.y && a.x >= a.z {
            Self::NearX
        } else if a.y >= a.z {
            Self::NearY
        } else {
            Self::NearZ
        }
    }

    /// Quake's integer code: 0/1/2 axial X/Y/Z, 3/4/5 nearest X/Y/Z.
    pub fn quake_code(self) -> i32 {
        self as i32
    }

    /// True for the three axial kinds.
    pub fn is_axial(self) -> bool {
        matches!(self, Self::AxialX | Self::AxialY | Self::AxialZ)
    }
}

/// Which side of a plane something is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Side {
    /// Entirely in front (beyond `+eps`).
    Front,
    /// Entirely behind (beyond `-eps`).
    Back,
    /// Every point within `eps` of the plane.
    On,
    /// Points on both sides.
    Cross,
}

/// An oriented plane `normal · p = dist`; see the module docs for the front-side convention.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Plane {
    /// Unit normal, pointing to the front side.
    pub normal: DVec3,
    /// Distance from the origin along `normal`.
    pub dist: f64,
}

impl Plane {
    /// A plane from a normal (normalised here) and a distance; `None` for a zero or non-finite normal.
    pub fn new(normal: DVec3, dist: f64) -> Option<Self> {
        let len = normal.length();
        if !len.is_finite() || len < 1e-12 || !dist.is_finite() {
            return None;
        }
        Some(Self { normal: normal / len, dist: dist / len })
    }

    /// The plane through three points with normal `(p0 - p1) × (p2 - p1)`, as `.map` sides and `.prt`
    /// windings define it. `None` when the points are (nearly) collinear or not finite.
    pub fn from_points(p0: DVec3, p1: DVec3, p2: DVec3) -> Option<Self> {
        let n = (p0 - p1).cross(p2 - p1);
        let len = n.length();
        let scale = (p0 - p1).length().max((p2 - p1).length()).max(1.0);
        if !len.is_finite() || len <= 1e-9 * scale * scale {
            return None;
        }
        let normal = n / len;
        Some(Self { normal, dist: normal.dot(p0) })
    }

    /// Signed distance of `p`: positive in front.
    #[inline]
    pub fn distance(&self, p: DVec3) -> f64 {
        self.normal.dot(p) - self.dist
    }

    /// The same plane facing the other way.
    #[inline]
    pub fn flipped(&self) -> Self {
        Self { normal: -self.normal, dist: -self.dist }
    }

    /// The axial classification of the normal.
    pub fn kind(&self) -> PlaneKind {
        PlaneKind::of(self.normal)
    }

    /// Snap a normal within [`NORMAL_EPSILON`] of an axis onto it, and a distance within
    /// [`DIST_EPSILON`] of an integer onto it. Brushes built from integer points stay exact.
    pub fn snapped(&self) -> Self {
        let mut normal = self.normal;
        for axis in 0..3 {
            if (normal[axis].abs() - 1.0).abs() < NORMAL_EPSILON {
                normal = DVec3::ZERO;
                normal[axis] = self.normal[axis].signum();
                break;
            }
        }
        let mut dist = self.dist;
        if (dist - dist.round()).abs() < DIST_EPSILON {
            dist = dist.round();
        }
        Self { normal, dist }
    }

    /// True when both planes are the same oriented plane within the identity epsilons.
    pub fn same_as(&self, other: &Plane) -> bool {
        (self.normal - other.normal).abs().max_element() < NORMAL_EPSILON
            && (self.dist - other.dist).abs() < DIST_EPSILON
    }
}

/// An axis-aligned box. An empty box has `mins > maxs` (see [`Aabb::EMPTY`]).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Aabb {
    /// Smallest corner.
    pub mins: DVec3,
    /// Largest corner.
    pub maxs: DVec3,
}

impl Aabb {
    /// The empty box: adding any point makes it that point.
    pub const EMPTY: Aabb = Aabb { mins: DVec3::splat(f64::INFINITY), maxs: DVec3::splat(f64::NEG_INFINITY) };

    /// A box from its corners.
    pub fn new(mins: DVec3, maxs: DVec3) -> Self {
        Self { mins, maxs }
    }

    /// The smallest box holding every point; [`Aabb::EMPTY`] for none.
    pub fn from_points<I: IntoIterator<Item = DVec3>>(points: I) -> Self {
        let mut b = Self::EMPTY;
        for p in points {
            b.add_point(p);
        }
        b
    }

    /// True when no point has been added.
    pub fn is_empty(&self) -> bool {
        self.mins.x > self.maxs.x || self.mins.y > self.maxs.y || self.mins.z > self.maxs.z
    }

    /// Grow to hold `p`.
    pub fn add_point(&mut self, p: DVec3) {
        self.mins = self.mins.min(p);
        self.maxs = self.maxs.max(p);
    }

    /// The smallest box holding both.
    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb { mins: self.mins.min(other.mins), maxs: self.maxs.max(other.maxs) }
    }

    /// Grown by `d` on every side.
    pub fn expanded(&self, d: f64) -> Aabb {
        Aabb { mins: self.mins - DVec3::splat(d), maxs: self.maxs + DVec3::splat(d) }
    }

    /// True when `p` is inside or within `eps` of the box.
    pub fn contains_point(&self, p: DVec3, eps: f64) -> bool {
        p.cmpge(self.mins - DVec3::splat(eps)).all() && p.cmple(self.maxs + DVec3::splat(eps)).all()
    }

    /// True when the boxes overlap or touch.
    pub fn intersects(&self, other: &Aabb) -> bool {
        self.mins.cmple(other.maxs).all() && other.mins.cmple(self.maxs).all()
    }

    /// The centre point.
    pub fn center(&self) -> DVec3 {
        (self.mins + self.maxs) * 0.5
    }

    /// `maxs - mins`.
    pub fn size(&self) -> DVec3 {
        self.maxs - self.mins
    }

    /// Which side of `plane` the whole box lies on, with tolerance `eps`.
    pub fn side(&self, plane: &Plane, eps: f64) -> Side {
        let c = self.center();
        let e = self.size() * 0.5;
        let d = plane.distance(c);
        let r = e.dot(plane.normal.abs());
        if d - r > eps {
            Side::Front
        } else if d + r < -eps {
            Side::Back
        } else {
            Side::Cross
        }
    }
}

/// A convex planar polygon; see the module docs for the point order.
#[derive(Debug, Clone, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Winding {
    /// The corners, clockwise seen from the front.
    pub points: Vec<DVec3>,
}

/// The two parts of a winding split by a plane.
#[derive(Debug, Clone, PartialEq)]
pub struct Split {
    /// The part in front of the plane, if any.
    pub front: Option<Winding>,
    /// The part behind the plane, if any.
    pub back: Option<Winding>,
}

impl Winding {
    /// A winding from points already in order.
    pub fn new(points: Vec<DVec3>) -> Self {
        Self { points }
    }

    /// A square of half-size [`BASE_WINDING_SIZE`] lying on `plane`, facing the same way.
    pub fn base_for_plane(plane: &Plane) -> Self {
        let n = plane.normal;
        // Pick the world axis least aligned with the normal as "up" for the square.
        let a = n.abs();
        let up0 = if a.z <= a.x && a.z <= a.y {
            DVec3::Z
        } else if a.x <= a.y {
            DVec3::X
        } else {
            DVec3::Y
        };
        let up = (up0 - n * up0.dot(n)).normalize();
        let right = up.cross(n);
        let org = n * plane.dist;
        let up = up * BASE_WINDING_SIZE;
        let right = right * BASE_WINDING_SIZE;
        // Clockwise seen from the front: with right = up × n, going org-right+up → org+right+up →
        // org+right-up → org-right-up turns clockwise when looking down -n.
        Self { points: vec![org - right + up, org + right + up, org + right - up, org - right - up] }
    }

    /// Number of corners.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True for fewer than three corners (no area).
    pub fn is_empty(&self) -> bool {
        self.points.len() < 3
    }

    /// The winding facing the other way (same points, reversed order).
    pub fn reversed(&self) -> Self {
        let mut points = self.points.clone();
        points.reverse();
        Self { points }
    }

    /// Area normal by Newell's method: direction of the plane normal (for our clockwise order),
    /// length twice the area. Robust for any number of points.
    fn newell(&self) -> DVec3 {
        let mut n = DVec3::ZERO;
        let count = self.points.len();
        for i in 0..count {
            let a = self.points[i];
            let b = self.points[(i + 1) % count];
            n += a.cross(b);
        }
        // a × b summed gives the counter-clockwise normal; our order is clockwise.
        -n
    }

    /// Polygon area.
    pub fn area(&self) -> f64 {
        if self.points.len() < 3 {
            return 0.0;
        }
        self.newell().length() * 0.5
    }

    /// Average of the corners (inside for a convex winding).
    pub fn center(&self) -> DVec3 {
        if self.points.is_empty() {
            return DVec3::ZERO;
        }
        self.points.iter().copied().sum::<DVec3>() / self.points.len() as f64
    }

    /// Bounding box of the corners.
    pub fn bounds(&self) -> Aabb {
        Aabb::from_points(self.points.iter().copied())
    }

    /// The winding's plane from all its points; `None` for a degenerate winding.
    pub fn plane(&self) -> Option<Plane> {
        if self.points.len() < 3 {
            return None;
        }
        let n = self.newell();
        let len = n.length();
        if !len.is_finite() || len < 1e-12 {
            return None;
        }
        let normal = n / len;
        Some(Plane { normal, dist: normal.dot(self.center()) })
    }

    /// Which side of `plane` the winding lies on, with tolerance `eps`.
    pub fn side(&self, plane: &Plane, eps: f64) -> Side {
        let (mut front, mut back) = (false, false);
        for &p in &self.points {
            let d = plane.distance(p);
            if d > eps {
                front = true;
            } else if d < -eps {
                back = true;
            }
        }
        match (front, back) {
            (true, true) => Side::Cross,
            (true, false) => Side::Front,
            (false, true) => Side::Back,
            (false, false) => Side::On,
        }
    }

    /// Split by `plane`; points within `eps` of it go to both parts. A winding lying on the plane
    /// goes to the side its own normal faces.
    pub fn split(&self, plane: &Plane, eps: f64) -> Split {
        let count = self.points.len();
        let dists: Vec<f64> = self.points.iter().map(|&p| plane.distance(p)).collect();
        let sides: Vec<Side> = dists
            .iter()
            .map(|&d| {
                if d > eps {
                    Side::Front
                } else if d < -eps {
                    Side::Back
                } else {
                    Side::On
                }
            })
            .collect();
        let has_front = sides.contains(&Side::Front);
        let has_back = sides.contains(&Side::Back);
        if !has_front && !has_back {
            let facing = self.plane().map(|p| p.normal.dot(plane.normal)).unwrap_or(1.0);
            return if facing >= 0.0 {
                Split { front: Some(self.clone()), back: None }
            } else {
                Split { front: None, back: Some(self.clone()) }
            };
        }
        if !has_back {
            return Split { front: Some(self.clone()), back: None };
        }
        if !has_front {
            return Split { front: None, back: Some(self.clone()) };
        }
        let mut front = Vec::with_capacity(count + 4);
        let mut back = Vec::with_capacity(count + 4);
        for i in 0..count {
            let p = self.points[i];
            match sides[i] {
                Side::On => {
                    front.push(p);
                    back.push(p);
                    continue;
                }
                Side::Front => front.push(p),
                _ => back.push(p),
            }
            let j = (i + 1) % count;
            if sides[j] == Side::On || sides[j] == sides[i] {
                continue;
            }
            let mid = intersect(p, self.points[j], dists[i], dists[j], plane);
            front.push(mid);
            back.push(mid);
        }
        Split { front: nonempty(front), back: nonempty(back) }
    }

    /// Keep only the part in front of `plane` (points within `eps` kept). A winding lying on the
    /// plane is kept when `keep_on` is true.
    pub fn clip(&self, plane: &Plane, eps: f64, keep_on: bool) -> Option<Winding> {
        match self.side(plane, eps) {
            Side::Front => Some(self.clone()),
            Side::Back => None,
            Side::On => keep_on.then(|| self.clone()),
            Side::Cross => self.split(plane, eps).front,
        }
    }

    /// Remove consecutive points closer than `eps` and points collinear with their neighbours.
    pub fn cleaned(&self, eps: f64) -> Winding {
        let mut pts: Vec<DVec3> = Vec::with_capacity(self.points.len());
        for &p in &self.points {
            if pts.last().is_none_or(|q: &DVec3| q.distance(p) > eps) {
                pts.push(p);
            }
        }
        while pts.len() > 1 && pts[0].distance(pts[pts.len() - 1]) <= eps {
            pts.pop();
        }
        let mut i = 0;
        while pts.len() > 3 && i < pts.len() {
            let n = pts.len();
            let a = pts[(i + n - 1) % n];
            let b = pts[i];
            let c = pts[(i + 1) % n];
            let ab = b - a;
            let ac = c - a;
            let len = ac.length();
            if len > 0.0 && ab.cross(ac).length() / len <= eps * 0.1 {
                pts.remove(i);
            } else {
                i += 1;
            }
        }
        Winding { points: pts }
    }

    /// True when the winding is planar within `eps`, convex, and has non-zero area.
    pub fn is_valid(&self, eps: f64) -> bool {
        let Some(plane) = self.plane() else { return false };
        if self.points.iter().any(|p| !p.is_finite() || plane.distance(*p).abs() > eps) {
            return false;
        }
        let n = self.points.len();
        for i in 0..n {
            let a = self.points[i];
            let b = self.points[(i + 1) % n];
            let edge = b - a;
            // Inward edge normal for a clockwise-from-front polygon.
            let inward = edge.cross(plane.normal);
            let Some(inward) = inward.try_normalize() else { return false };
            let dist = inward.dot(a);
            if self.points.iter().any(|&p| inward.dot(p) - dist < -eps) {
                return false;
            }
        }
        true
    }
}

fn intersect(a: DVec3, b: DVec3, da: f64, db: f64, plane: &Plane) -> DVec3 {
    let t = da / (da - db);
    let mut mid = a + (b - a) * t;
    // Keep exact coordinates on axial planes so that axial splits introduce no drift.
    for axis in 0..3 {
        if plane.normal[axis] == 1.0 {
            mid[axis] = plane.dist;
        } else if plane.normal[axis] == -1.0 {
            mid[axis] = -plane.dist;
        }
    }
    mid
}

fn nonempty(points: Vec<DVec3>) -> Option<Winding> {
    (points.len() >= 3).then_some(Winding { points })
}

/// Planes deduplicated within the identity epsilons, stored in pairs: index `2k` faces the
/// positive direction of its largest normal component and `2k + 1` is its flip, so `i ^ 1` is
/// always the opposite plane.
#[derive(Debug, Clone, Default)]
pub struct PlaneSet {
    planes: Vec<Plane>,
    buckets: std::collections::HashMap<i64, Vec<u32>>,
}

impl PlaneSet {
    /// An empty set.
    pub fn new() -> Self {
        Self::default()
    }

    /// The planes, in pairs.
    pub fn planes(&self) -> &[Plane] {
        &self.planes
    }

    /// Plane `i`.
    pub fn get(&self, i: usize) -> &Plane {
        &self.planes[i]
    }

    /// Number of planes (always even).
    pub fn len(&self) -> usize {
        self.planes.len()
    }

    /// True when no plane was added.
    pub fn is_empty(&self) -> bool {
        self.planes.is_empty()
    }

    /// The index of `plane` (snapped first), adding it and its flip when new.
    pub fn insert(&mut self, plane: Plane) -> usize {
        let plane = plane.snapped();
        let key = (plane.dist.abs() / (DIST_EPSILON * 8.0)).floor() as i64;
        for k in [key - 1, key, key + 1] {
            if let Some(list) = self.buckets.get(&k) {
                for &i in list {
                    let i = i as usize;
                    if self.planes[i].same_as(&plane) {
                        return i;
                    }
                    if self.planes[i ^ 1].same_as(&plane) {
                        return i ^ 1;
                    }
                }
            }
        }
        let a = plane.normal.abs();
        let major = if a.x >= a.y && a.x >= a.z {
            plane.normal.x
        } else if a.y >= a.z {
            plane.normal.y
        } else {
            plane.normal.z
        };
        let index = self.planes.len();
        let (first, second) = if major >= 0.0 { (plane, plane.flipped()) } else { (plane.flipped(), plane) };
        self.planes.push(first);
        self.planes.push(second);
        self.buckets.entry(key).or_default().push(index as u32);
        if major >= 0.0 { index } else { index + 1 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base_winding_faces_its_plane() {
        for n in [DVec3::X, -DVec3::Y, DVec3::new(1.0, 2.0, 3.0).normalize(), -DVec3::Z] {
            let p = Plane { normal: n, dist: 5.0 };
            let w = Winding::base_for_plane(&p);
            let wp = w.plane().expect("base winding has a plane");
            assert!(wp.normal.dot(n) > 0.999, "{n:?} -> {wp:?}");
            assert!((wp.dist - 5.0).abs() < 1e-6);
            let q = Plane::from_points(w.points[0], w.points[1], w.points[2]).expect("plane");
            assert!(q.normal.dot(n) > 0.999);
            assert!(w.is_valid(1e-6));
        }
    }

    #[test]
    fn split_square_in_half() {
        let p = Plane { normal: DVec3::Z, dist: 0.0 };
        let w = Winding::base_for_plane(&p);
        let cut = Plane { normal: DVec3::X, dist: 0.0 };
        let s = w.split(&cut, ON_EPSILON);
        let (f, b) = (s.front.expect("front"), s.back.expect("back"));
        assert!((f.area() + b.area() - w.area()).abs() / w.area() < 1e-9);
        assert_eq!(f.side(&cut, ON_EPSILON), Side::Front);
        assert_eq!(b.side(&cut, ON_EPSILON), Side::Back);
    }

    #[test]
    fn plane_set_pairs_and_dedups() {
        let mut set = PlaneSet::new();
        let a = set.insert(Plane { normal: DVec3::X, dist: 16.0 });
        let b = set.insert(Plane { normal: -DVec3::X, dist: -16.0 });
        let c = set.insert(Plane { normal: DVec3::new(1.0, 1e-8, 0.0).normalize(), dist: 16.00001 });
        assert_eq!(a ^ 1, b);
        assert_eq!(a, c);
        assert_eq!(set.len(), 2);
    }

    fn unit(v: (f64, f64, f64)) -> Option<DVec3> {
        DVec3::new(v.0, v.1, v.2).try_normalize()
    }

    proptest::proptest! {
        /// Splitting a convex winding by any plane gives pieces whose areas sum to the original's
        /// and that lie on their own side of the plane (within the epsilon).
        #[test]
        fn split_pieces_cover_the_original(
            n in (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0),
            d in -300.0f64..300.0,
            cut_n in (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0),
            cut_d in -300.0f64..300.0,
            clip_n in (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0),
        ) {
            let (Some(n), Some(cut_n), Some(clip_n)) = (unit(n), unit(cut_n), unit(clip_n)) else {
                return Ok(());
            };
            // A bounded polygon: a base winding on (n, d) cut down by a box of half-size 512.
            let mut w = Winding::base_for_plane(&Plane { normal: n, dist: d });
            for axis in 0..3 {
                for sign in [1.0, -1.0] {
                    let mut normal = DVec3::ZERO;
                    normal[axis] = -sign;
                    match w.clip(&Plane { normal, dist: -512.0 }, ON_EPSILON, true) {
                        Some(c) => w = c,
                        None => return Ok(()),
                    }
                }
            }
            // An extra oblique clip so the pieces are not only box-shaped.
            if let Some(c) = w.clip(&Plane { normal: clip_n, dist: -100.0 }, ON_EPSILON, true) {
                w = c;
            }
            proptest::prop_assume!(w.area() > 1.0);
            let cut = Plane { normal: cut_n, dist: cut_d };
            let s = w.split(&cut, ON_EPSILON);
            let area = |p: &Option<Winding>| p.as_ref().map_or(0.0, Winding::area);
            let total = area(&s.front) + area(&s.back);
            // Points within the epsilon go to both sides, so a sliver may be counted twice.
            let slack = 1e-9 * w.area() + 4.0 * ON_EPSILON * w.bounds().size().length();
            proptest::prop_assert!((total - w.area()).abs() <= slack, "{} vs {}", total, w.area());
            if let Some(f) = &s.front {
                proptest::prop_assert!(f.points.iter().all(|&p| cut.distance(p) >= -ON_EPSILON * 1.0001));
            }
            if let Some(b) = &s.back {
                proptest::prop_assert!(b.points.iter().all(|&p| cut.distance(p) <= ON_EPSILON * 1.0001));
            }
        }
    }

    #[test]
    fn collinear_points_make_no_plane() {
        assert!(Plane::from_points(DVec3::ZERO, DVec3::X, DVec3::X * 2.0).is_none());
    }
}
