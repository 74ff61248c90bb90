//! Convex brushes as the tree builder sees them: sides with windings on planes of a [`PlaneSet`].
//!
//! A brush is the intersection of the half-spaces **behind** its side planes; every side's plane
//! faces out of the brush and its winding is clockwise seen from outside. Windings are computed by
//! clipping a huge square on each plane by every other side (keeping the part behind it) with
//! [`ON_EPSILON`]; a side left without a winding touches the brush in an edge or a point only and
//! is dropped.
//!
//! A winding whose corners behind another side's plane all lie within [`ON_EPSILON`] of it (a
//! narrow side between sides at small angles, as on a cylinder of thousands of sides: a strip
//! 0.2 units wide lies within 0.001 units of its neighbours' planes) would be dropped by the
//! epsilon test; it is clipped by that plane exactly instead, since dropping it would lose a real
//! face of the brush (and the brush itself once fewer than four sides were left).
//! [`Winding::cleaned`] still drops what is narrower than [`ON_EPSILON`], such as a side that
//! touches the brush along an edge. Building the windings takes time quadratic in the sides of one
//! brush (each side is clipped by every other) and memory linear in them; a map's brushes have at
//! most [`MAX_BRUSH_SIDES`].

use glam::DVec3;
use sightline_formats::geom::ON_EPSILON;
use sightline_formats::{Aabb, Contents, PlaneSet, Winding};

/// Most sides a brush of a `.map` may have; a compile refuses a brush with more, naming it
/// (`file:line`, entity and brush). Building a brush's windings clips each side by every other,
/// and the tree peels a convex brush one side plane at a time, so the work on one brush grows with
/// the square of its sides (a 1,024-sided cylinder compiled in 2.4 s, a 5,000-sided one in 73 s,
/// 2026-11-26). q3map2 has a limit of the same kind (300 to 1,024 sides, by version); the Quake
/// maps in `shared/maps` have at most 33 sides in a brush.
pub const MAX_BRUSH_SIDES: usize = 1024;

/// Marker for a side that has no texture (sides created by splits).
pub const NO_TEXTURE: u32 = u32::MAX;

/// One side of a [`Brush`].
#[derive(Debug, Clone)]
pub struct BrushSide {
    /// Index into the plane set; the plane faces out of the brush.
    pub plane: u32,
    /// The side's polygon, clockwise seen from outside.
    pub winding: Winding,
    /// True once the side's plane is a node plane above (or does not cut the node volume): it is
    /// then never a splitter again below.
    pub used: bool,
    /// A hint side: chosen as a splitter before anything else.
    pub hint: bool,
    /// Part of the side survived face CSG: it borders open space. Visible sides are splitters
    /// before invisible ones (which would only cut open space along buried faces).
    pub visible: bool,
}

/// A convex brush (or a piece of one after splits).
#[derive(Debug, Clone)]
pub struct Brush {
    /// Sides with windings.
    pub sides: Vec<BrushSide>,
    /// Bounds of the windings.
    pub bounds: Aabb,
    /// What fills it ([`Contents::Empty`] for hint brushes).
    pub contents: Contents,
    /// A detail brush: it splits the tree only after every structural side has, so its leaves
    /// group into clusters.
    pub detail: bool,
}

/// Why a set of planes did not make a usable brush.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BrushProblem {
    /// No side kept any area: the planes enclose nothing.
    AllDegenerate,
    /// The planes do not close the brush, or it reaches beyond the world limit.
    Unbounded,
}

/// One side given to [`Brush::from_planes`].
#[derive(Debug, Clone, Copy)]
pub struct SideSpec {
    /// Plane index (facing out of the brush).
    pub plane: u32,
    /// Hint side.
    pub hint: bool,
}

impl Brush {
    /// Build the windings of a brush from its side planes. Repeated planes are kept once. Returns
    /// the brush and, for each entry of `specs`, the index of its side in `brush.sides` (or `None`
    /// when that side was dropped).
    pub fn from_planes(
        planes: &PlaneSet,
        specs: &[SideSpec],
        contents: Contents,
    ) -> Result<(Brush, Vec<Option<usize>>), BrushProblem> {
        let (brush, map) = Self::from_planes_unbounded(planes, specs, contents)?;
        if brush.bounds.mins.min_element() < -sightline_formats::geom::WORLD_LIMIT
            || brush.bounds.maxs.max_element() > sightline_formats::geom::WORLD_LIMIT
        {
            return Err(BrushProblem::Unbounded);
        }
        Ok((brush, map))
    }

    /// [`Brush::from_planes`] without the [`WORLD_LIMIT`](sightline_formats::geom::WORLD_LIMIT)
    /// check: for the compiler's own boxes, which reach a margin beyond the world's bounds (so
    /// beyond the limit when the world touches it).
    fn from_planes_unbounded(
        planes: &PlaneSet,
        specs: &[SideSpec],
        contents: Contents,
    ) -> Result<(Brush, Vec<Option<usize>>), BrushProblem> {
        let mut sides = Vec::with_capacity(specs.len());
        let mut map = vec![None; specs.len()];
        for (i, spec) in specs.iter().enumerate() {
            if specs[..i].iter().any(|s| s.plane == spec.plane) {
                continue;
            }
            if specs.iter().any(|s| s.plane == spec.plane ^ 1) {
                // Two opposite sides on one plane: the brush is flat.
                return Err(BrushProblem::AllDegenerate);
            }
            let mut w = Some(Winding::base_for_plane(planes.get(spec.plane as usize)));
            for (j, other) in specs.iter().enumerate() {
                if j == i || other.plane == spec.plane {
                    continue;
                }
                let Some(cur) = w else { break };
                w = clip_behind(&cur, planes.get(other.plane as usize));
            }
            if let Some(w) = w.map(|w| w.cleaned(ON_EPSILON)).filter(|w| !w.is_empty()) {
                map[i] = Some(sides.len());
                sides.push(BrushSide {
                    plane: spec.plane,
                    winding: w,
                    used: false,
                    hint: spec.hint,
                    visible: false,
                });
            }
        }
        if sides.is_empty() {
            return Err(BrushProblem::AllDegenerate);
        }
        Ok((Brush { bounds: bounds_of(&sides), sides, contents, detail: false }, map))
    }

    /// An axis-aligned box brush.
    pub fn from_box(planes: &mut PlaneSet, bounds: &Aabb, contents: Contents) -> Brush {
        let mut specs = Vec::with_capacity(6);
        for axis in 0..3 {
            let mut n = DVec3::ZERO;
            n[axis] = 1.0;
            let max = sightline_formats::Plane { normal: n, dist: bounds.maxs[axis] };
            let min = sightline_formats::Plane { normal: -n, dist: -bounds.mins[axis] };
            specs.push(SideSpec { plane: planes.insert(max) as u32, hint: false });
            specs.push(SideSpec { plane: planes.insert(min) as u32, hint: false });
        }
        // Not `from_planes`: the outside volume reaches a margin beyond the world, which may lie
        // beyond the coordinate limit; refusing it left an empty volume and a false leak.
        let mut b = match Brush::from_planes_unbounded(planes, &specs, contents) {
            Ok((b, _)) => b,
            // A box always closes; an empty box yields an empty brush.
            Err(_) => Brush { sides: Vec::new(), bounds: *bounds, contents, detail: false },
        };
        for s in &mut b.sides {
            s.used = true;
        }
        b
    }

    /// Every corner of every side.
    pub fn points(&self) -> impl Iterator<Item = DVec3> + '_ {
        self.sides.iter().flat_map(|s| s.winding.points.iter().copied())
    }

    /// Signed distances of the farthest corners behind and in front of `plane`: `(min, max)`.
    pub fn extent_along(&self, plane: &sightline_formats::Plane) -> (f64, f64) {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for p in self.points() {
            let d = plane.distance(p);
            lo = lo.min(d);
            hi = hi.max(d);
        }
        (lo, hi)
    }

    /// Volume by pyramids from one corner (the tests check splits with it).
    #[cfg(test)]
    pub fn volume(&self, planes: &PlaneSet) -> f64 {
        let Some(corner) = self.points().next() else { return 0.0 };
        self.sides
            .iter()
            .map(|s| -planes.get(s.plane as usize).distance(corner) * s.winding.area() / 3.0)
            .sum()
    }

    /// Split by plane `plane` (an index of `planes`). Returns the parts in front and behind;
    /// parts are `None` when the brush does not reach beyond [`ON_EPSILON`] on that side. The new
    /// sides on the split plane are marked used.
    pub fn split(&self, planes: &PlaneSet, plane: u32) -> (Option<Brush>, Option<Brush>) {
        let p = planes.get(plane as usize);
        let (lo, hi) = self.extent_along(p);
        if hi <= ON_EPSILON {
            return (None, Some(self.clone()));
        }
        if lo >= -ON_EPSILON {
            return (Some(self.clone()), None);
        }
        // The polygon where the plane cuts the brush.
        let mut mid = Some(Winding::base_for_plane(p));
        for s in &self.sides {
            let Some(w) = mid else { break };
            mid = w.clip(&planes.get(s.plane as usize).flipped(), ON_EPSILON, false);
        }
        let Some(mid) = mid.map(|w| w.cleaned(ON_EPSILON)).filter(|w| !w.is_empty()) else {
            // The plane only grazes the brush: keep it whole on the side it reaches further.
            return if hi > -lo { (Some(self.clone()), None) } else { (None, Some(self.clone())) };
        };
        let mut front = Vec::with_capacity(self.sides.len() + 1);
        let mut back = Vec::with_capacity(self.sides.len() + 1);
        for s in &self.sides {
            let split = s.winding.split(p, ON_EPSILON);
            if let Some(w) = split.front {
                front.push(BrushSide { winding: w, ..s.clone() });
            }
            if let Some(w) = split.back {
                back.push(BrushSide { winding: w, ..s.clone() });
            }
        }
        front.push(BrushSide {
            plane: plane ^ 1,
            winding: mid.reversed(),
            used: true,
            hint: false,
            visible: false,
        });
        back.push(BrushSide { plane, winding: mid, used: true, hint: false, visible: false });
        let make = |sides: Vec<BrushSide>| {
            (sides.len() >= 4).then(|| Brush { bounds: bounds_of(&sides), sides, ..*self })
        };
        (make(front), make(back))
    }
}

/// The part of `w` behind `plane`, clipped with [`ON_EPSILON`]; when that leaves nothing, the
/// part strictly behind `plane`, clipped exactly (see the module docs).
fn clip_behind(w: &Winding, plane: &sightline_formats::Plane) -> Option<Winding> {
    let behind = plane.flipped();
    w.clip(&behind, ON_EPSILON, false).or_else(|| w.clip(&behind, 0.0, false))
}

fn bounds_of(sides: &[BrushSide]) -> Aabb {
    Aabb::from_points(sides.iter().flat_map(|s| s.winding.points.iter().copied()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_formats::Plane;

    fn cube(planes: &mut PlaneSet, lo: f64, hi: f64) -> Brush {
        Brush::from_box(planes, &Aabb::new(DVec3::splat(lo), DVec3::splat(hi)), Contents::Solid)
    }

    #[test]
    fn box_brush_has_six_faces_and_volume() {
        let mut planes = PlaneSet::new();
        let b = cube(&mut planes, 0.0, 64.0);
        assert_eq!(b.sides.len(), 6);
        assert!((b.volume(&planes) - 64.0f64.powi(3)).abs() < 1e-6);
        for s in &b.sides {
            let wp = s.winding.plane().expect("plane");
            assert!(
                wp.same_as(planes.get(s.plane as usize))
                    || wp.normal.dot(planes.get(s.plane as usize).normal) > 0.999
            );
        }
    }

    #[test]
    fn split_conserves_volume() {
        let mut planes = PlaneSet::new();
        let b = cube(&mut planes, 0.0, 64.0);
        let cut = planes.insert(Plane::new(DVec3::new(1.0, 1.0, 0.0), 40.0).expect("plane")) as u32;
        let (f, k) = b.split(&planes, cut);
        let (f, k) = (f.expect("front"), k.expect("back"));
        let total = f.volume(&planes) + k.volume(&planes);
        assert!((total - 64.0f64.powi(3)).abs() < 1e-3, "{total}");
        // The cut takes a corner off: five box sides and the cut remain on the far part.
        assert_eq!(f.sides.len(), 7);
    }

    /// A prism over a regular `n`-gon of radius `r` around the z axis, from z = 0 to z = 64.
    fn prism(planes: &mut PlaneSet, n: usize, r: f64) -> Vec<SideSpec> {
        let mut specs = Vec::with_capacity(n + 2);
        for i in 0..n {
            let a = std::f64::consts::TAU * (i as f64 + 0.5) / n as f64;
            let normal = DVec3::new(a.cos(), a.sin(), 0.0);
            let dist = r * (std::f64::consts::PI / n as f64).cos();
            specs.push(SideSpec { plane: planes.insert(Plane { normal, dist }) as u32, hint: false });
        }
        for plane in [Plane { normal: DVec3::Z, dist: 64.0 }, Plane { normal: DVec3::NEG_Z, dist: 0.0 }] {
            specs.push(SideSpec { plane: planes.insert(plane) as u32, hint: false });
        }
        specs
    }

    #[test]
    fn thousands_of_narrow_sides_all_keep_their_windings() {
        // Sides 0.2 units wide whose neighbours turn by 0.002 radians: every side's strip lies
        // within ON_EPSILON of the next planes, which must clip it, not drop it.
        for n in [8, 3000] {
            let mut planes = PlaneSet::new();
            let specs = prism(&mut planes, n, 100.0);
            let (brush, map) = Brush::from_planes(&planes, &specs, Contents::Solid).expect("a prism");
            // The plane set snaps normals within NORMAL_EPSILON of an axis onto it, which can make
            // two sides next to an axis one plane: every distinct plane keeps its side.
            let distinct: std::collections::HashSet<u32> = specs.iter().map(|s| s.plane).collect();
            assert!(distinct.len() + 4 >= n + 2, "{n}: {} distinct planes", distinct.len());
            assert_eq!(brush.sides.len(), distinct.len(), "{n} sides");
            assert_eq!(map.iter().flatten().count(), distinct.len());
            // Each winding covers its side (a strip as wide as the n-gon's edge, 64 high) and lies
            // behind every other plane within ON_EPSILON.
            let edge = 2.0 * 100.0 * (std::f64::consts::PI / n as f64).sin();
            for s in &brush.sides[..brush.sides.len() - 2] {
                assert!(s.winding.area() >= edge * 64.0 * (1.0 - 1e-6), "{n}: {}", s.winding.area());
            }
            for s in &brush.sides {
                for other in &brush.sides {
                    let plane = planes.get(other.plane as usize);
                    assert!(s.winding.points.iter().all(|&p| plane.distance(p) <= ON_EPSILON * 1.01));
                }
            }
            let area = n as f64 / 2.0 * 100.0f64.powi(2) * (std::f64::consts::TAU / n as f64).sin();
            let cap = brush.sides[brush.sides.len() - 1].winding.area();
            assert!((cap - area).abs() < 1e-3 * area, "{n}: cap area {cap} vs {area}");
        }
    }

    #[test]
    fn flat_and_open_brushes_are_rejected() {
        let mut planes = PlaneSet::new();
        let a = planes.insert(Plane { normal: DVec3::X, dist: 0.0 }) as u32;
        let b = planes.insert(Plane { normal: DVec3::Y, dist: 0.0 }) as u32;
        let specs = [SideSpec { plane: a, hint: false }, SideSpec { plane: b, hint: false }];
        assert_eq!(Brush::from_planes(&planes, &specs, Contents::Solid).err(), Some(BrushProblem::Unbounded));
        let flat = [SideSpec { plane: a, hint: false }, SideSpec { plane: a ^ 1, hint: false }];
        assert_eq!(
            Brush::from_planes(&planes, &flat, Contents::Solid).err(),
            Some(BrushProblem::AllDegenerate)
        );
    }
}
