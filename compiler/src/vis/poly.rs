//! Fixed-capacity windings for the flow's inner loop, clipping that rounds toward *visible*, and
//! separating planes (the antipenumbra of two portals).
//!
//! Every clip keeps the part of a winding where `plane.distance(x) >= -CLIP_EPSILON`: the plane is
//! pushed [`CLIP_EPSILON`] units outward before cutting, so a clip can only keep more than the
//! exact answer, never less, except that a winding with no point more than [`TOUCH_EPSILON`] in
//! front of the exact plane is gone: it only touches the plane, and lines that merely graze an
//! edge carry no sight. A clip whose result would not fit [`CAP`] points keeps the input whole
//! (also keeping more).

use glam::DVec3;
use sightline_formats::geom::Plane;

use super::certify::centroid;

/// How far beyond a clipping plane a winding is kept (units). Rounds every clip toward visible.
pub const CLIP_EPSILON: f64 = 0.01;

/// A clip leaves nothing unless some point of the winding lies more than this in front of the
/// exact plane (units). A winding that at most touches the plane passes only lines that graze it
/// (a set of no width, such as a line running exactly through a row of wall corners); the band of
/// [`CLIP_EPSILON`] must not carry those from clip to clip. Openings wider than about ten times this
/// (1e-5 units) still pass sight.
pub const TOUCH_EPSILON: f64 = 1e-6;

/// Distance under which a point counts as lying on a candidate separating plane. Accepting a
/// plane requires every pass point at `>= -SEPARATOR_EPSILON`; a tiny value only makes us reject
/// near-miss planes, and the true supporting plane (through the extreme vertex) is always tried.
pub const SEPARATOR_EPSILON: f64 = 1e-6;

/// A sphere holding a winding (and everything clipped from it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// Centre.
    pub center: DVec3,
    /// Radius.
    pub radius: f64,
}

impl Sphere {
    /// The sphere lies wholly behind `plane` (at most [`TOUCH_EPSILON`] in front): clipping
    /// anything inside it by `plane` leaves nothing ([`Poly::clip_in`]).
    #[inline]
    pub fn behind(&self, plane: &Plane) -> bool {
        plane.distance(self.center) + self.radius <= TOUCH_EPSILON
    }
}

/// Capacity of a [`Poly`]: `.prt` windings have at most 64 points; clips may add a few.
pub const CAP: usize = 72;

/// A convex polygon with at most [`CAP`] points, stored inline (no heap).
#[derive(Debug, Clone)]
pub struct Poly {
    /// Number of points in use.
    pub n: usize,
    /// The points; only `..n` are meaningful. Seen from the side `normal` points to, they run
    /// counter-clockwise.
    pub p: [DVec3; CAP],
    /// Unit normal of the polygon's plane (kept through clips).
    pub normal: DVec3,
    /// Scratch for [`Poly::clip`] when this polygon is its `tmp`: distances of the clipped points.
    dist: [f64; CAP],
}

impl Default for Poly {
    fn default() -> Self {
        Self { n: 0, p: [DVec3::ZERO; CAP], normal: DVec3::Z, dist: [0.0; CAP] }
    }
}

/// What a clip did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Clip {
    /// Nothing is left.
    Gone,
    /// The winding was entirely kept (unchanged).
    Whole,
    /// The winding was cut.
    Cut,
}

impl Poly {
    /// Load points (at most [`CAP`]; callers pass `.prt` windings of at most 64 points) running
    /// counter-clockwise around the unit `normal`.
    pub fn load(&mut self, pts: &[DVec3], normal: DVec3) {
        let n = pts.len().min(CAP);
        self.p[..n].copy_from_slice(&pts[..n]);
        self.n = n;
        self.normal = normal;
    }

    /// Copy another polygon's used points and normal.
    pub fn copy_from(&mut self, other: &Poly) {
        self.p[..other.n].copy_from_slice(&other.p[..other.n]);
        self.n = other.n;
        self.normal = other.normal;
    }

    /// The used points.
    #[cfg(test)]
    pub fn points(&self) -> &[DVec3] {
        &self.p[..self.n]
    }

    /// As [`Poly::clip`], deciding first from a sphere (`center`, `radius`) known to hold the
    /// winding: one dot product when the sphere lies on one side.
    #[inline]
    pub fn clip_in(&mut self, bound: &Sphere, plane: &Plane, eps: f64, tmp: &mut Poly) -> Clip {
        let c = plane.distance(bound.center);
        if c + eps >= bound.radius {
            return Clip::Whole;
        }
        if bound.behind(plane) {
            self.n = 0;
            return Clip::Gone;
        }
        self.clip(plane, eps, tmp)
    }

    /// Keep the part with `plane.distance(x) >= -eps` (the plane pushed outward by `eps`);
    /// nothing when no point lies more than [`TOUCH_EPSILON`] in front of the exact plane.
    /// `tmp` is scratch space.
    pub fn clip(&mut self, plane: &Plane, eps: f64, tmp: &mut Poly) -> Clip {
        let n = self.n;
        let dist = &mut tmp.dist;
        let (mut front, mut back) = (false, false);
        for (d, q) in dist.iter_mut().zip(&self.p[..n]) {
            let exact = plane.distance(*q);
            *d = exact + eps;
            front |= exact > TOUCH_EPSILON;
            back |= *d < 0.0;
        }
        if !back {
            return Clip::Whole;
        }
        if !front {
            self.n = 0;
            return Clip::Gone;
        }
        let mut out = 0usize;
        for i in 0..n {
            let pi = self.p[i];
            let j = if i + 1 == n { 0 } else { i + 1 };
            let (di, dj) = (tmp.dist[i], tmp.dist[j]);
            if di >= 0.0 {
                if out == CAP {
                    return Clip::Whole;
                }
                tmp.p[out] = pi;
                out += 1;
            }
            if (di > 0.0 && dj < 0.0) || (di < 0.0 && dj > 0.0) {
                if out == CAP {
                    return Clip::Whole;
                }
                let t = di / (di - dj);
                tmp.p[out] = pi + (self.p[j] - pi) * t;
                out += 1;
            }
        }
        if out < 3 {
            self.n = 0;
            return Clip::Gone;
        }
        self.p[..out].copy_from_slice(&tmp.p[..out]);
        self.n = out;
        Clip::Cut
    }
}

impl Poly {
    /// Fewer points, keeping more: while the winding has more than `max` points, the edge whose
    /// removal adds the least area goes, its two neighbours extended to where they meet. A
    /// removal is made only when it adds at most `share` of the winding's area and the meeting
    /// point lies inside `bound` (which must hold the winding, and so still does). The result
    /// holds the input and stays convex, so clipping by it only keeps more.
    pub fn simplify(&mut self, max: usize, share: f64, bound: &Sphere) {
        let (normal, max) = (self.normal, max.max(3));
        if self.n <= max {
            return;
        }
        // Twice the area (grown by each removal), and twice the area each removal would add.
        let pts = &self.p[..self.n];
        let mut area =
            (1..pts.len() - 1).map(|i| (pts[i] - pts[0]).cross(pts[i + 1] - pts[0]).dot(normal)).sum::<f64>();
        while self.n > max {
            let n = self.n;
            let pts = &self.p[..n];
            let mut best: Option<(f64, usize, DVec3)> = None;
            for i in 0..n {
                let (a, u) = (pts[(i + n - 1) % n], pts[i]);
                let (v, b) = (pts[(i + 1) % n], pts[(i + 2) % n]);
                // Edge `u v` goes; `a u` and `b v`, extended beyond `u` and `v`, meet at `u + (u - a) s`.
                let (du, dv, e) = (u - a, b - v, v - u);
                let turn = du.cross(dv).dot(normal);
                if turn <= 0.0 {
                    continue; // the extensions diverge
                }
                let (s, t) = (e.cross(dv).dot(normal) / turn, du.cross(e).dot(normal) / turn);
                if !(s >= 0.0 && t >= 0.0) {
                    continue;
                }
                let x = u + du * s;
                if !x.is_finite() || x.distance_squared(bound.center) >= bound.radius * bound.radius {
                    continue;
                }
                let added = e.cross(x - u).dot(normal).abs();
                if best.is_none_or(|(least, _, _)| added < least) {
                    best = Some((added, i, x));
                }
            }
            let Some((added, i, x)) = best else { return };
            let limit = share * area;
            if limit.is_nan() || added > limit {
                return;
            }
            // Points `i` and `i + 1` become `x`.
            let j = (i + 1) % n;
            self.p[i] = x;
            self.p.copy_within(j + 1..n, j);
            self.n = n - 1;
            area += added;
        }
    }
}

/// Visit the separating planes through the edges of `a` and vertices of `b`, oriented with `a`
/// behind and `b` in front (then negated when `flip`), until `f` returns `false`.
///
/// For each edge of `a`, the planes through it form a pencil; seen along the edge, `a` is a ray
/// and `b` a set of directions. The separating plane is the one through the vertex of `b` turned
/// farthest toward `a`'s outside, so one pass over `b` finds it; the reference tools try every
/// vertex and test each plane against both windings. (Another separating plane exists only when
/// `b` crosses `a`'s plane; skipping it keeps more.) The plane is kept only when all of `b` is in
/// front (none beyond `-SEPARATOR_EPSILON`, some beyond `+SEPARATOR_EPSILON`) and, unless `a` is
/// known `convex` (then a plane through its edge leaning away from it has it behind), all of `a`
/// behind (none beyond `+SEPARATOR_EPSILON`, some beyond `-SEPARATOR_EPSILON`). Skipping a plane
/// is always safe: it only keeps more. When every point of `b` lies more than `SEPARATOR_EPSILON`
/// above `a`'s plane (the usual case), the vertex turned farthest has every other point of `b` on
/// its front side by construction (their angles from +x all lie between 0 and π), so only "some
/// point in front" is checked, and the first point found ends the check.
#[inline]
pub fn for_each_separator(a: &Poly, b: &Poly, flip: bool, convex: bool, f: impl FnMut(&Plane) -> bool) {
    // The heights of `b` go in an array on the stack, zeroed first: one of `SMALL` entries for
    // the usual winding, rather than [`CAP`] (0.7 % of vis's instructions on the generated
    // 4 × 4 × 2 rooms and on dm1).
    const SMALL: usize = 16;
    if b.n <= SMALL {
        separators::<SMALL>(a, b, flip, convex, f);
    } else {
        separators::<CAP>(a, b, flip, convex, f);
    }
}

/// [`for_each_separator`] for a `b` of at most `N` points.
#[inline]
fn separators<const N: usize>(
    a: &Poly,
    b: &Poly,
    flip: bool,
    convex: bool,
    mut f: impl FnMut(&Plane) -> bool,
) {
    let (an, bn) = (a.n, b.n.min(N));
    if an < 3 || bn == 0 {
        return;
    }
    let a_pts = &a.p[..an];
    let b_pts = &b.p[..bn];
    // Heights of `b` above `a`'s plane (the same for every edge of `a`).
    let mut y = a.normal;
    let ya = y.dot(a_pts[0]);
    let mut heights = [0.0f64; N];
    let mut sum = 0.0;
    for (h, q) in heights.iter_mut().zip(b_pts) {
        *h = y.dot(*q) - ya;
        sum += *h;
    }
    // `a` turns counter-clockwise about its normal, so `edge × normal` points out of `a`; facing
    // `y` toward `b` may flip that.
    let outward = if sum < 0.0 {
        y = -y;
        for h in &mut heights[..bn] {
            *h = -*h;
        }
        -1.0
    } else {
        1.0
    };
    let heights = &heights[..bn];
    let clear = heights.iter().all(|&h| h > SEPARATOR_EPSILON);
    for i in 0..an {
        let ai = a_pts[i];
        let e = a_pts[if i + 1 == an { 0 } else { i + 1 }] - ai;
        // Outward normal of the edge within `a`'s plane, unnormalised: angles only need its
        // direction, and the plane normal below is normalised at the end.
        let x = e.cross(y) * outward;
        let xa = x.dot(ai);
        // The vertex of `b` at the largest angle from +x toward +y (toward `a`'s outside).
        let (mut bx, mut by) = (x.dot(b_pts[0]) - xa, heights[0]);
        for (q, &qy) in b_pts[1..].iter().zip(&heights[1..]) {
            let qx = x.dot(*q) - xa;
            let turn = bx * qy - by * qx > 0.0;
            bx = if turn { qx } else { bx };
            by = if turn { qy } else { by };
        }
        // Unless the chosen vertex rises above `a`'s plane, the plane through the edge leans
        // over `a`, which then is not behind it beyond rounding: the check below would refuse
        // it, and skipping a plane only keeps more anyway. This spares the normalisation.
        if by <= 0.0 {
            continue;
        }
        let Some(normal) = (x * by - y * bx).try_normalize() else { continue };
        let dist = normal.dot(ai);
        let front = if clear { any_in_front(normal, dist, b_pts) } else { in_front(normal, dist, b_pts) };
        if !front || (!convex && !behind(normal, dist, a_pts)) {
            continue;
        }
        let plane = if flip { Plane { normal: -normal, dist: -dist } } else { Plane { normal, dist } };
        if !f(&plane) {
            return;
        }
    }
}

/// True when no point of `b` lies behind the plane beyond [`SEPARATOR_EPSILON`] and some lies in
/// front beyond it.
#[inline]
fn in_front(normal: DVec3, dist: f64, b: &[DVec3]) -> bool {
    let mut front = false;
    for q in b {
        let d = normal.dot(*q) - dist;
        if d < -SEPARATOR_EPSILON {
            return false;
        }
        front |= d > SEPARATOR_EPSILON;
    }
    front
}

/// True when some point of `b` lies in front of the plane beyond [`SEPARATOR_EPSILON`].
#[inline]
fn any_in_front(normal: DVec3, dist: f64, b: &[DVec3]) -> bool {
    b.iter().any(|q| normal.dot(*q) - dist > SEPARATOR_EPSILON)
}

/// True when no point of `a` lies in front of the plane beyond [`SEPARATOR_EPSILON`] and some
/// lies behind beyond it.
#[inline]
fn behind(normal: DVec3, dist: f64, a: &[DVec3]) -> bool {
    in_front(-normal, -dist, a)
}

/// Clip `target` by every separating plane of (`a`, `b`) (see [`for_each_separator`]); returns
/// `false` as soon as nothing is left.
/// `bound` holds `target`.
pub fn clip_to_separators(
    a: &Poly,
    b: &Poly,
    flip: bool,
    convex: bool,
    target: &mut Poly,
    bound: &Sphere,
    tmp: &mut Poly,
) -> bool {
    let mut alive = true;
    for_each_separator(a, b, flip, convex, |plane| {
        alive = target.clip_in(bound, plane, CLIP_EPSILON, tmp) != Clip::Gone;
        alive
    });
    alive
}

/// Shows, cheaply and only sometimes, that clipping a winding `s` by the separating planes of two
/// windings `a` and `b` would keep all of it; reused from call to call (no allocation once warm).
///
/// If a point `v` of `s` lies on a line that runs from a point `x` of `a` through a point `y`
/// of `b` on to `v` (in that order), every plane with `a` behind and `b` in front has `v` in
/// front, since the distance along the line is linear: so `v` is kept by every separator of
/// ([`for_each_separator`]) `a` and `b`, in either order, oriented toward `b`. The lines tried
/// per point are the one through `b`'s vertex average, and the one toward `a`'s: the average of a
/// convex winding lies in it. A `false` answer says nothing (the clip then decides); a wrong
/// `true` could only keep more than the clip would, which rounds toward visible anyway.
#[derive(Debug, Default)]
pub struct Sight {
    /// Edge lines of `a` and of `b`: `[m.x, m.y, m.z, m · p]` per edge from `p`, with `m` the
    /// normal cross the edge, pointing into the winding (counter-clockwise about its normal).
    a: Vec<[f64; 4]>,
    b: Vec<[f64; 4]>,
}

impl Sight {
    /// True when every point of `s` is shown to lie on a line from `a` through `b` (see
    /// [`Sight`]).
    pub fn all_through(&mut self, s: &Poly, b: &Poly, a: &Poly) -> bool {
        let (Some(am), Some(bm)) = (centroid(&a.p[..a.n]), centroid(&b.p[..b.n])) else {
            return false;
        };
        let (a_dist, b_dist) = (a.normal.dot(a.p[0]), b.normal.dot(b.p[0]));
        self.a.clear();
        self.b.clear();
        for &v in &s.p[..s.n] {
            // From `v` through `b`'s middle on to `a`, then from `v` toward `a`'s middle across `b`.
            let via_b = meet(v, bm, a.normal, a_dist)
                .is_some_and(|t| t >= 1.0 && inside(&mut self.a, a, v + (bm - v) * t));
            if !via_b
                && !meet(v, am, b.normal, b_dist)
                    .is_some_and(|t| t <= 1.0 && inside(&mut self.b, b, v + (am - v) * t))
            {
                return false;
            }
        }
        true
    }
}

/// The parameter `t > 0` at which the line `v + (m - v) t` meets the plane (`normal`, `dist`);
/// `None` when it meets it at `t <= 0` or never.
#[inline]
fn meet(v: DVec3, m: DVec3, normal: DVec3, dist: f64) -> Option<f64> {
    let t = (dist - normal.dot(v)) / normal.dot(m - v);
    (t > 0.0 && t.is_finite()).then_some(t)
}

/// `x`, a point of `w`'s plane, lies within `w` or on its edges; `lines` caches `w`'s edge lines
/// (filled on first use, see [`Sight`]).
#[inline]
fn inside(lines: &mut Vec<[f64; 4]>, w: &Poly, x: DVec3) -> bool {
    if lines.is_empty() {
        let pts = &w.p[..w.n];
        let mut p = pts[pts.len() - 1];
        for &q in pts {
            let m = w.normal.cross(q - p);
            lines.push([m.x, m.y, m.z, m.dot(p)]);
            p = q;
        }
    }
    lines.iter().all(|&[mx, my, mz, off]| mx * x.x + my * x.y + mz * x.z >= off)
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    const HUGE: Sphere = Sphere { center: DVec3::ZERO, radius: 1e9 };

    /// A polygon from points, with the normal they turn counter-clockwise about (Newell).
    fn poly(pts: &[DVec3]) -> Poly {
        let mut normal = DVec3::ZERO;
        for (i, a) in pts.iter().enumerate() {
            normal += a.cross(pts[(i + 1) % pts.len()]);
        }
        let mut p = Poly::default();
        p.load(pts, normal.normalize());
        p
    }

    fn square(x: f64, size: f64) -> Poly {
        poly(&[
            DVec3::new(x, 0.0, 0.0),
            DVec3::new(x, size, 0.0),
            DVec3::new(x, size, size),
            DVec3::new(x, 0.0, size),
        ])
    }

    #[test]
    fn clip_keeps_a_band_beyond_the_plane() {
        let mut tmp = Poly::default();
        let mut w = square(0.0, 64.0);
        let plane = Plane { normal: DVec3::Y, dist: 32.0 };
        assert_eq!(w.clip(&plane, CLIP_EPSILON, &mut tmp), Clip::Cut);
        let min_y = w.points().iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
        assert!((min_y - (32.0 - CLIP_EPSILON)).abs() < 1e-9);
        let mut w = square(0.0, 31.0);
        assert_eq!(w.clip(&plane, CLIP_EPSILON, &mut tmp), Clip::Gone);
    }

    #[test]
    fn a_winding_that_only_touches_the_plane_is_gone() {
        let mut tmp = Poly::default();
        let plane = Plane { normal: DVec3::Y, dist: 32.0 };
        // Touching from behind along an edge: only grazing lines, gone.
        let mut w = square(0.0, 32.0);
        assert_eq!(w.clip(&plane, CLIP_EPSILON, &mut tmp), Clip::Gone);
        // Reaching 1e-4 beyond the plane: a real (thin) opening, kept with the band behind it.
        let mut w = square(0.0, 32.0001);
        assert_eq!(w.clip(&plane, CLIP_EPSILON, &mut tmp), Clip::Cut);
        let min_y = w.points().iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
        assert!((min_y - (32.0 - CLIP_EPSILON)).abs() < 1e-9);
        // The sphere shortcut agrees.
        let mut w = square(0.0, 32.0);
        let bound = Sphere { center: DVec3::new(0.0, 16.0, 16.0), radius: 16.0 * 2f64.sqrt() };
        assert_eq!(w.clip_in(&bound, &plane, CLIP_EPSILON, &mut tmp), Clip::Gone);
    }

    #[test]
    fn separators_of_parallel_squares_bound_the_beam() {
        // Source at x=0 and pass at x=64, both [0,64]²: a target at x=128 keeps [0,64]² ± eps
        // after the full beam of separators, and a target off to the side is cut away.
        let (a, b) = (square(0.0, 64.0), square(64.0, 64.0));
        let mut planes = Vec::new();
        for_each_separator(&a, &b, false, false, |p| {
            planes.push(*p);
            true
        });
        assert!(!planes.is_empty());
        let mut tmp = Poly::default();
        let mut t = square(128.0, 64.0);
        assert!(clip_to_separators(&a, &b, false, false, &mut t, &HUGE, &mut tmp));
        let mut far = poly(&[
            DVec3::new(128.0, 200.0, 0.0),
            DVec3::new(128.0, 264.0, 0.0),
            DVec3::new(128.0, 264.0, 64.0),
            DVec3::new(128.0, 200.0, 64.0),
        ]);
        assert!(!clip_to_separators(&a, &b, false, false, &mut far, &HUGE, &mut tmp));
    }

    #[test]
    fn sight_through_aligned_openings_and_not_past_them() {
        let mut sight = Sight::default();
        // A 64² source behind a 64² pass behind a 64² target, all aligned: every point of the
        // target sees the source through the pass (and the other way round).
        let (a, b, s) = (square(0.0, 64.0), square(64.0, 64.0), square(128.0, 64.0));
        assert!(sight.all_through(&s, &b, &a));
        assert!(sight.all_through(&a, &b, &s));
        // A target twice as wide: its far corners see no part of the source through the pass.
        let wide = poly(&[
            DVec3::new(128.0, -64.0, -64.0),
            DVec3::new(128.0, 128.0, -64.0),
            DVec3::new(128.0, 128.0, 128.0),
            DVec3::new(128.0, -64.0, 128.0),
        ]);
        assert!(!sight.all_through(&wide, &b, &a));
        // Degenerate windings show nothing.
        let mut empty = square(64.0, 64.0);
        empty.n = 0;
        assert!(!sight.all_through(&s, &empty, &a));
    }

    proptest! {
        /// Whenever [`Sight::all_through`] says a winding lies on lines from `a` through `b`,
        /// clipping it by every separator of `a` and `b` (both orders, oriented toward `b`)
        /// keeps all of it, so the clip it stands in for may be skipped.
        #[test]
        fn sight_only_skips_clips_that_keep_everything(
            ys in prop::collection::vec(-50.0f64..50.0, 2),
            near in prop::collection::vec(-25.0f64..25.0, 4),
            gaps in prop::collection::vec(0.5f64..100.0, 2),
            size in 1.0f64..60.0,
        ) {
            let mk = |x: f64, y: f64, z: f64, w: f64| {
                poly(&[DVec3::new(x, y, z), DVec3::new(x, y + w, z), DVec3::new(x, y + w, z + w), DVec3::new(x, y, z + w)])
            };
            // The windings near each other, so that a fair share of the cases see through.
            let a = mk(0.0, ys[0] + near[2], ys[1] + near[3], 40.0);
            let b = mk(gaps[0], ys[0], ys[1], 30.0);
            let s = mk(gaps[0] + gaps[1], ys[0] + near[0], ys[1] + near[1], size);
            let mut sight = Sight::default();
            if sight.all_through(&s, &b, &a) {
                for (x, y, flip) in [(&a, &b, false), (&b, &a, true)] {
                    let mut kept = s.clone();
                    let mut tmp = Poly::default();
                    let bound = Sphere { center: DVec3::ZERO, radius: 1e9 };
                    let mut clips = Vec::new();
                    for_each_separator(x, y, flip, true, |plane| {
                        clips.push(kept.clip_in(&bound, plane, CLIP_EPSILON, &mut tmp));
                        true
                    });
                    prop_assert!(clips.iter().all(|&c| c == Clip::Whole), "{clips:?}");
                }
            }
        }

        /// A simplified winding holds the input, stays convex and inside the bound, and has
        /// no more points than the input: any convex polygon (points on an ellipse), limits
        /// and shares from none to all of the area.
        #[test]
        fn simplify_keeps_more_and_stays_convex(
            angles in prop::collection::vec(0.0f64..std::f64::consts::TAU, 3..40),
            radii in prop::collection::vec(0.01f64..500.0, 2),
            max in 3usize..10,
            share in 0.0f64..1.0,
            tight in any::<bool>(),
        ) {
            let mut sorted = angles.clone();
            sorted.sort_by(f64::total_cmp);
            sorted.dedup_by(|x, y| (*x - *y).abs() < 1e-3);
            prop_assume!(sorted.len() >= 3);
            let pts: Vec<DVec3> =
                sorted.iter().map(|&t| DVec3::new(7.0, radii[0] * t.cos(), radii[1] * t.sin())).collect();
            let w = poly(&pts);
            prop_assume!(w.normal.is_finite());
            // A bound just holding the input, or one that never refuses a point.
            let radius = if tight { radii[0].max(radii[1]) * 1.01 } else { 1e9 };
            let bound = Sphere { center: DVec3::new(7.0, 0.0, 0.0), radius };
            let mut s = w.clone();
            s.simplify(max, share, &bound);
            prop_assert!(s.n <= w.n && s.n >= 3);
            // Unbounded, a winding of five or more points always has an edge whose neighbours
            // meet beyond it (its turns add up to a full turn).
            let mut all = w.clone();
            all.simplify(max, f64::INFINITY, &Sphere { center: bound.center, radius: f64::INFINITY });
            prop_assert!(all.n <= max.max(4), "{} points left of {}", all.n, w.n);
            let scale = radii[0].max(radii[1]);
            let out = &s.p[..s.n];
            for (i, &p) in out.iter().enumerate() {
                prop_assert!(p.distance(bound.center) < bound.radius);
                let q = out[(i + 1) % s.n];
                let inward = w.normal.cross(q - p).normalize();
                // Every input point lies within the simplified winding (left of each edge).
                for &x in w.points() {
                    prop_assert!(inward.dot(x - p) >= -1e-9 * scale, "{x} outside edge {p} {q}");
                }
                // Convex: the next point turns the same way.
                let r = out[(i + 2) % s.n];
                prop_assert!(inward.dot(r - q) >= -1e-9 * scale);
            }
        }

        /// Every plane kept has `b` wholly in front and some of it beyond the epsilon, as the full
        /// check demands, also where that check is skipped because `b` lies above `a`'s plane:
        /// `b` a random convex polygon (points on an ellipse) at any height and tilt, from well
        /// above `a` to crossing its plane.
        #[test]
        fn every_separator_has_the_pass_in_front(
            angles in prop::collection::vec(0.0f64..std::f64::consts::TAU, 3..9),
            center in prop::collection::vec(-80.0f64..80.0, 2),
            radii in prop::collection::vec(0.5f64..60.0, 2),
            height in -5.0f64..120.0,
            tilt in prop::collection::vec(-1.5f64..1.5, 2),
            flip in any::<bool>(),
        ) {
            let a = square(0.0, 64.0);
            let mut sorted = angles.clone();
            sorted.sort_by(f64::total_cmp);
            sorted.dedup_by(|x, y| (*x - *y).abs() < 1e-3);
            prop_assume!(sorted.len() >= 3);
            // On an ellipse in a plane tilted about the y and z axes, at `height` beyond x = 0.
            let pts: Vec<DVec3> = sorted
                .iter()
                .map(|&t| {
                    let (y, z) = (center[0] + radii[0] * t.cos(), center[1] + radii[1] * t.sin());
                    DVec3::new(height + tilt[0] * y + tilt[1] * z, y, z)
                })
                .collect();
            let b = poly(&pts);
            for_each_separator(&a, &b, flip, true, |plane| {
                let (normal, dist) = if flip { (-plane.normal, -plane.dist) } else { (plane.normal, plane.dist) };
                assert!(in_front(normal, dist, &b.p[..b.n]), "b not in front of {plane:?}");
                true
            });
        }

        /// Any segment from a point of `a` through a point of `b` continues, beyond `b`, into the
        /// kept side of every separating plane: clipping never removes a point a ray reaches.
        #[test]
        fn separators_keep_every_ray(
            ys in prop::collection::vec(-50.0f64..50.0, 4),
            gap in 0.01f64..100.0,
            s in 0.0f64..1.0, t in 0.0f64..1.0, u in 0.0f64..1.0, v in 0.0f64..1.0,
            far in 1.0f64..10.0,
        ) {
            let mk = |x: f64, y0: f64, y1: f64| {
                let (lo, hi) = (y0.min(y1), y0.max(y1) + 1.0);
                poly(&[DVec3::new(x, lo, lo), DVec3::new(x, hi, lo), DVec3::new(x, hi, hi + 3.0), DVec3::new(x, lo, hi)])
            };
            let a = mk(0.0, ys[0], ys[1]);
            let b = mk(gap, ys[2], ys[3]);
            let pick = |w: &Poly, s: f64, t: f64| {
                let e = w.p[0].lerp(w.p[1], s);
                let f = w.p[3].lerp(w.p[2], s);
                e.lerp(f, t)
            };
            let pa = pick(&a, s, t);
            let pb = pick(&b, u, v);
            let beyond = pa + (pb - pa) * far;
            for flip in [false, true] {
                let (x, y) = if flip { (&b, &a) } else { (&a, &b) };
                for_each_separator(x, y, flip, true, |plane| {
                    // Normal order keeps the far side (with b); flipped keeps the `a` side... of x=b.
                    let d = plane.distance(beyond);
                    assert!(d >= -1e-6, "ray end cut by a separator: {d}");
                    true
                });
            }
        }
    }
}
