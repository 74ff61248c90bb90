//! Whether the triangles on one plane cover a portal's opening on that plane, up to cracks no
//! wider than [`CRACK_WIDTH`].
//!
//! The opening is cut into pieces and each piece is tested against the triangles near it only:
//!
//! - A kd tree over the plane's triangles cuts the opening along world-axis planes first (where
//!   the fewest triangles fall on the fuller side; a triangle crossing a cut goes to both sides),
//!   so each piece meets only the triangles of its cell and the edges of a triangle cut the pieces
//!   of its own cell, not the whole opening. A cut lies at least [`MIN_CELL`] from the earlier
//!   cuts of its cell on its axis, so the cuts never chop a gap into slivers that would pass for
//!   cracks, and leaves at most 7/8 of its cell's triangles on either side, so the tree is
//!   shallow.
//! - In a cell, a piece is cut by the first triangle (in the order of the cell's [`BoxTree`], from
//!   where its parent piece stopped) that overlaps it, into the parts outside that triangle; those
//!   go on from the next triangle. A triangle that misses a piece does not cut it. A piece no
//!   further triangle overlaps is left over, and the first one wider than [`CRACK_WIDTH`] answers
//!   no.
//!
//! So the work grows with the triangles near each piece and the pieces they make, not with the
//! product of the triangles on the plane and the pieces: near-linear in the triangles for
//! scattered, gridded and fanned triangles alike. [`PlaneCover::covers`] counts each
//! triangle-against-piece test.

use glam::DVec3;
use sightline_formats::geom::ON_EPSILON;
use sightline_formats::{Aabb, Plane, Winding};
use sightline_job::cancel::{Cancel, Cancelled};

use super::box_tree::BoxTree;

/// A gap between triangles at most this wide (in units, across its narrowest direction) counts as
/// covered: splitting with [`ON_EPSILON`] already merges points this close, and no bundle of sight
/// lines passes such a crack.
pub const CRACK_WIDTH: f64 = 2.0 * ON_EPSILON;

/// Cuts of the kd tree on one axis lie at least this far apart (units): far wider than a crack,
/// so a gap the cuts divide keeps a part wider than [`CRACK_WIDTH`].
pub const MIN_CELL: f64 = 1.0;

/// A kd cell holding at most this many triangles is not cut further.
const LEAF_TRIANGLES: usize = 8;

/// A cut is chosen by the boxes of at most this many of the cell's triangles.
const CUT_SAMPLE: usize = 256;

#[derive(Debug, Clone)]
enum Node {
    /// Cut by `plane` (a world-axis plane): `children[0]` behind it, `children[1]` in front.
    Cut { plane: Plane, children: [usize; 2] },
    /// The triangles whose boxes meet the cell (indices into the plane's list, ascending), and a
    /// box tree over them.
    Cell { triangles: Vec<usize>, tree: BoxTree },
}

/// The triangles of one plane, indexed for [`PlaneCover::covers`].
#[derive(Debug, Clone)]
pub struct PlaneCover<'a> {
    triangles: &'a [Winding],
    /// Pre-order; the root is node 0.
    nodes: Vec<Node>,
}

impl<'a> PlaneCover<'a> {
    /// The index over `triangles` (convex windings on one plane); stops with [`Cancelled`] once
    /// `cancel` is set.
    pub fn new(triangles: &'a [Winding], cancel: &Cancel) -> Result<Self, Cancelled> {
        let boxes: Vec<Aabb> = triangles.iter().map(Winding::bounds).collect();
        let mut cover = Self { triangles, nodes: Vec::new() };
        let all: Vec<usize> = (0..triangles.len()).collect();
        cover.build(&boxes, all, [(f64::NEG_INFINITY, f64::INFINITY); 3], cancel)?;
        Ok(cover)
    }

    /// Append the node over `items` in a cell whose earlier cuts on each axis lie at `cuts`.
    fn build(
        &mut self,
        boxes: &[Aabb],
        items: Vec<usize>,
        cuts: [(f64, f64); 3],
        cancel: &Cancel,
    ) -> Result<usize, Cancelled> {
        cancel.check()?;
        let index = self.nodes.len();
        if let Some((axis, value, back, front)) = cut(boxes, &items, &cuts) {
            let plane = Plane { normal: DVec3::AXES[axis], dist: value };
            self.nodes.push(Node::Cut { plane, children: [0, 0] });
            let mut back_cuts = cuts;
            back_cuts[axis].1 = value;
            let mut front_cuts = cuts;
            front_cuts[axis].0 = value;
            let b = self.build(boxes, back, back_cuts, cancel)?;
            let f = self.build(boxes, front, front_cuts, cancel)?;
            if let Some(Node::Cut { children, .. }) = self.nodes.get_mut(index) {
                *children = [b, f];
            }
        } else {
            let cell_boxes: Vec<Aabb> = items.iter().map(|&i| boxes[i]).collect();
            self.nodes.push(Node::Cell { tree: BoxTree::build(&cell_boxes), triangles: items });
        }
        Ok(index)
    }

    /// True when the triangles cover `opening` (a convex winding on their plane, whose normal is
    /// `normal`) up to cracks no wider than [`CRACK_WIDTH`]. Each triangle-against-piece test is
    /// counted in `tests`; stops with [`Cancelled`] once `cancel` is set.
    pub fn covers(
        &self,
        opening: &Winding,
        normal: DVec3,
        tests: &mut u64,
        cancel: &Cancel,
    ) -> Result<bool, Cancelled> {
        if self.nodes.is_empty() {
            return Ok(false);
        }
        // (piece, kd node, first position of the cell's box tree still to try)
        let mut stack = vec![(opening.clone(), 0usize, 0usize)];
        while let Some((piece, node, from)) = stack.pop() {
            cancel.check()?;
            if is_crack(&piece) {
                // Every part of a crack is a crack: nothing to cut further.
                continue;
            }
            let (triangles, tree) = match &self.nodes[node] {
                Node::Cut { plane, children } => {
                    let split = piece.split(plane, ON_EPSILON);
                    // The back part is looked at first.
                    stack.extend(split.front.map(|w| (w, children[1], 0)));
                    stack.extend(split.back.map(|w| (w, children[0], 0)));
                    continue;
                }
                Node::Cell { triangles, tree } => (triangles, tree),
            };
            let near = piece.bounds().expanded(ON_EPSILON);
            let mut parts = Vec::new();
            let hit = tree.first_from(from, &near, |pos| {
                *tests += 1;
                match subtract(&piece, &self.triangles[triangles[tree.item(pos)]], normal) {
                    Some(outside) => {
                        parts = outside;
                        true
                    }
                    None => false,
                }
            });
            match hit {
                // The first part is cut on first.
                Some(pos) => stack.extend(parts.into_iter().rev().map(|w| (w, node, pos + 1))),
                None => return Ok(false),
            }
        }
        Ok(true)
    }
}

/// Where to cut a cell holding `items`, with the axis, the position and the items behind and in
/// front of it (those within [`ON_EPSILON`] of it on both sides). Positions tried: on each axis,
/// just before a triangle's box starts or just after one ends, at least [`MIN_CELL`] from the
/// cell's earlier cuts on that axis, for the triangles of an evenly spaced sample of at most
/// [`CUT_SAMPLE`] items; the one leaving the fewest sampled items on its fuller side (then the
/// fewest crossing it) wins. `None` when the cell holds few items, or the cut leaves more than
/// 7/8 of them on a side, or more than half of them cross it.
fn cut(
    boxes: &[Aabb],
    items: &[usize],
    cuts: &[(f64, f64); 3],
) -> Option<(usize, f64, Vec<usize>, Vec<usize>)> {
    let n = items.len();
    if n <= LEAF_TRIANGLES {
        return None;
    }
    let sample: Vec<&Aabb> = items.iter().step_by(n.div_ceil(CUT_SAMPLE)).map(|&i| &boxes[i]).collect();
    let step = 2.0 * ON_EPSILON;
    let mut best: Option<((usize, usize), usize, f64)> = None;
    for (axis, &(before, after)) in cuts.iter().enumerate() {
        let (lo, hi) = (before + MIN_CELL, after - MIN_CELL);
        let mut mins: Vec<f64> = sample.iter().map(|b| b.mins[axis]).collect();
        let mut maxs: Vec<f64> = sample.iter().map(|b| b.maxs[axis]).collect();
        mins.sort_unstable_by(f64::total_cmp);
        maxs.sort_unstable_by(f64::total_cmp);
        // Candidates in increasing order (the two sorted lists merged), so the counts behind and
        // in front of them follow with two pointers.
        let (mut next_min, mut next_max) = (0, 0);
        let (mut behind, mut before) = (0, 0);
        while next_min < mins.len() || next_max < maxs.len() {
            let value = match (mins.get(next_min), maxs.get(next_max)) {
                (Some(&a), Some(&b)) if a - step <= b + step => {
                    next_min += 1;
                    a - step
                }
                (_, Some(&b)) => {
                    next_max += 1;
                    b + step
                }
                (Some(&a), None) => {
                    next_min += 1;
                    a - step
                }
                (None, None) => break,
            };
            if !(lo..=hi).contains(&value) {
                continue;
            }
            while mins.get(behind).is_some_and(|&m| m <= value + ON_EPSILON) {
                behind += 1;
            }
            while maxs.get(before).is_some_and(|&m| m < value - ON_EPSILON) {
                before += 1;
            }
            let (back, front) = (behind, maxs.len() - before);
            let score = (back.max(front), back + front);
            if best.is_none_or(|(s, _, _)| score < s) {
                best = Some((score, axis, value));
            }
        }
    }
    let (_, axis, value) = best?;
    let back: Vec<usize> =
        items.iter().copied().filter(|&i| boxes[i].mins[axis] <= value + ON_EPSILON).collect();
    let front: Vec<usize> =
        items.iter().copied().filter(|&i| boxes[i].maxs[axis] >= value - ON_EPSILON).collect();
    let most = n - n / 8;
    (back.len() <= most && front.len() <= most && back.len() + front.len() <= n + n / 2)
        .then_some((axis, value, back, front))
}

/// The parts of `piece` outside the convex winding `t` (both on the plane with `normal`), or
/// `None` when `t` misses `piece` (no part of it lies inside `t`, up to [`ON_EPSILON`]): cut by
/// each of `t`'s edges in turn, the part beyond an edge is kept, the rest goes on to the next.
fn subtract(piece: &Winding, t: &Winding, normal: DVec3) -> Option<Vec<Winding>> {
    let mut out = Vec::new();
    let centre = t.center();
    let mut inside = piece.clone();
    for (i, &a) in t.points.iter().enumerate() {
        let b = t.points[(i + 1) % t.points.len()];
        let Some(edge) = Plane::new((b - a).cross(normal), 0.0) else { continue };
        let mut edge = Plane { dist: edge.normal.dot(a), ..edge };
        if edge.distance(centre) > 0.0 {
            edge = edge.flipped();
        }
        let split = inside.split(&edge, ON_EPSILON);
        out.extend(split.front);
        inside = split.back?;
    }
    Some(out)
}

/// True when `w` is no wider than [`CRACK_WIDTH`]. A convex winding's area is at most its width
/// times its diameter (at most its box's diagonal), so one with more area than that allows is
/// wider, without measuring [`width`] (whose work grows with the square of the corners).
fn is_crack(w: &Winding) -> bool {
    let diagonal = w.bounds().size().length();
    w.area() <= CRACK_WIDTH * diagonal && width(w) <= CRACK_WIDTH
}

/// The narrowest extent of a convex winding: over its edges, the farthest corner from the edge's
/// line, at the edge where that is least (0 for fewer than three corners).
fn width(w: &Winding) -> f64 {
    let n = w.points.len();
    if n < 3 {
        return 0.0;
    }
    let mut least = f64::INFINITY;
    for i in 0..n {
        let a = w.points[i];
        let dir = w.points[(i + 1) % n] - a;
        let len = dir.length();
        if len <= f64::EPSILON {
            continue;
        }
        let far = w.points.iter().map(|&p| (p - a).cross(dir).length() / len).fold(0.0, f64::max);
        least = least.min(far);
    }
    if least.is_finite() { least } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(x0: f64, y0: f64, x1: f64, y1: f64) -> Winding {
        Winding::new(vec![
            DVec3::new(x0, y0, 0.0),
            DVec3::new(x0, y1, 0.0),
            DVec3::new(x1, y1, 0.0),
            DVec3::new(x1, y0, 0.0),
        ])
    }

    fn remainder(piece: &Winding, cover: &[Winding]) -> Vec<Winding> {
        let mut rest = vec![piece.clone()];
        for t in cover {
            rest = rest.into_iter().flat_map(|p| subtract(&p, t, DVec3::Z).unwrap_or(vec![p])).collect();
        }
        rest
    }

    #[test]
    fn two_triangles_of_a_square_cover_it_and_a_gap_does_not() {
        let portal = square(0.0, 0.0, 64.0, 64.0);
        let a = Winding::new(vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(0.0, 64.0, 0.0),
            DVec3::new(64.0, 64.0, 0.0),
        ]);
        let b = Winding::new(vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(64.0, 64.0, 0.0),
            DVec3::new(64.0, 0.0, 0.0),
        ]);
        let rest = remainder(&portal, &[a.clone(), b]);
        assert!(rest.iter().all(|p| width(p) <= CRACK_WIDTH), "{rest:?}");
        let rest = remainder(&portal, &[a]);
        let area: f64 = rest.iter().map(Winding::area).sum();
        assert!((area - 2048.0).abs() < 1e-6, "{area}");
        // Two halves 1 unit apart leave a crack that counts; 0.005 apart one that does not.
        for (gap, open) in [(1.0, true), (0.005, false)] {
            let rest =
                remainder(&portal, &[square(0.0, 0.0, 32.0, 64.0), square(32.0 + gap, 0.0, 64.0, 64.0)]);
            assert_eq!(rest.iter().any(|p| width(p) > CRACK_WIDTH), open, "gap {gap}: {rest:?}");
        }
    }

    #[test]
    fn width_is_the_narrow_extent() {
        assert!((width(&square(0.0, 0.0, 100.0, 0.5)) - 0.5).abs() < 1e-9);
        let sliver =
            Winding::new(vec![DVec3::ZERO, DVec3::new(50.0, 0.001, 0.0), DVec3::new(100.0, 0.0, 0.0)]);
        assert!(width(&sliver) < 0.002);
        assert_eq!(width(&Winding::default()), 0.0);
    }

    /// The squares of a `side` × `side` grid of `step`-unit squares, two triangles each, in an
    /// order `seed` shuffles; the square at `(dx, dy)` (in squares) moved by `shift` along x.
    fn grid(side: u32, step: f64, seed: u64, shifted: Option<((u32, u32), f64)>) -> Vec<Winding> {
        let mut tris = Vec::new();
        for j in 0..side {
            for i in 0..side {
                let dx = match shifted {
                    Some((at, shift)) if at == (i, j) => shift,
                    _ => 0.0,
                };
                let (x0, y0) = (f64::from(i) * step + dx, f64::from(j) * step);
                let p = |x: f64, y: f64| DVec3::new(x, y, 0.0);
                tris.push(Winding::new(vec![p(x0, y0), p(x0, y0 + step), p(x0 + step, y0 + step)]));
                tris.push(Winding::new(vec![p(x0, y0), p(x0 + step, y0 + step), p(x0 + step, y0)]));
            }
        }
        let mut rng = sightline_job::rng::SplitMix64::new(seed);
        for i in (1..tris.len()).rev() {
            tris.swap(i, (rng.next_u64() % (i as u64 + 1)) as usize);
        }
        tris
    }

    fn covered(triangles: &[Winding], opening: &Winding) -> (bool, u64) {
        let cancel = Cancel::new();
        let cover = PlaneCover::new(triangles, &cancel).expect("not cancelled");
        let mut tests = 0;
        (cover.covers(opening, DVec3::Z, &mut tests, &cancel).expect("not cancelled"), tests)
    }

    #[test]
    fn a_shuffled_tiling_covers_and_a_hole_or_gap_does_not() {
        let (side, step) = (16, 16.0);
        let opening = square(0.0, 0.0, 256.0, 256.0);
        for seed in 0..4 {
            let tiles = grid(side, step, seed, None);
            let cancel = Cancel::new();
            assert!(PlaneCover::new(&tiles, &cancel).expect("built").nodes.len() > 1, "the kd tree cuts");
            let (yes, tests) = covered(&tiles, &opening);
            assert!(yes, "seed {seed}");
            assert!(tests <= 8 * tiles.len() as u64, "seed {seed}: {tests} tests");
            // Any one triangle missing leaves a hole.
            for missing in [0, 100, 511] {
                let mut holed = tiles.clone();
                holed.remove(missing);
                assert!(!covered(&holed, &opening).0, "seed {seed}, without {missing}");
            }
            // A square moved by a crack still covers; moved by a unit it leaves a gap.
            for (shift, yes) in [(0.005, true), (1.0, false)] {
                let moved = grid(side, step, seed, Some(((7, 9), shift)));
                assert_eq!(covered(&moved, &opening).0, yes, "seed {seed}, shift {shift}");
            }
            // An opening reaching past the tiles is not covered; one inside them is.
            assert!(!covered(&tiles, &square(-8.0, 0.0, 256.0, 256.0)).0);
            assert!(covered(&tiles, &square(3.0, 5.0, 200.0, 31.0)).0);
        }
    }

    #[test]
    fn a_fan_of_thin_triangles_covers_its_polygon() {
        // A fan from one corner of a square to 400 points along the far sides.
        let p = |x: f64, y: f64| DVec3::new(x, y, 0.0);
        let mut rim: Vec<DVec3> = (0..=200).map(|k| p(256.0, 256.0 * f64::from(k) / 200.0)).collect();
        rim.extend((1..=200).map(|k| p(256.0 - 256.0 * f64::from(k) / 200.0, 256.0)));
        let fan: Vec<Winding> = rim.windows(2).map(|w| Winding::new(vec![p(0.0, 0.0), w[1], w[0]])).collect();
        let (yes, tests) = covered(&fan, &square(0.0, 0.0, 256.0, 256.0));
        assert!(yes);
        assert!(tests <= 8 * fan.len() as u64, "{tests} tests");
        let mut holed = fan.clone();
        holed.remove(150);
        assert!(!covered(&holed, &square(0.0, 0.0, 256.0, 256.0)).0);
    }

    #[test]
    fn a_cancelled_check_stops() {
        let tiles = grid(16, 16.0, 1, None);
        let cancel = Cancel::new();
        let cover = PlaneCover::new(&tiles, &cancel).expect("built");
        cancel.cancel();
        assert_eq!(PlaneCover::new(&tiles, &cancel).err(), Some(Cancelled));
        let mut tests = 0;
        assert_eq!(
            cover.covers(&square(0.0, 0.0, 256.0, 256.0), DVec3::Z, &mut tests, &cancel),
            Err(Cancelled)
        );
    }

    /// Depth of the kd tree below node `at` (a cell is 0).
    fn depth(cover: &PlaneCover<'_>, at: usize) -> usize {
        match &cover.nodes[at] {
            Node::Cut { children, .. } => 1 + children.iter().map(|&c| depth(cover, c)).max().unwrap_or(0),
            Node::Cell { .. } => 0,
        }
    }

    #[test]
    fn the_kd_tree_stays_shallow_and_every_triangle_is_in_a_cell() {
        let p = |x: f64, y: f64| DVec3::new(x, y, 0.0);
        // Nested triangles (each one inside the last, a unit smaller on every side) and a grid.
        let nested: Vec<Winding> = (0..2000)
            .map(|k| {
                let d = f64::from(k);
                Winding::new(vec![p(d, d), p(d, 8000.0 - 2.0 * d), p(8000.0 - 2.0 * d, d)])
            })
            .collect();
        for tris in [nested, grid(64, 4.0, 9, None)] {
            let cover = PlaneCover::new(&tris, &Cancel::new()).expect("built");
            let bound = (tris.len() as f64).ln() / (8.0f64 / 7.0).ln();
            assert!(depth(&cover, 0) as f64 <= bound + 1.0, "depth {} for {}", depth(&cover, 0), tris.len());
            let mut seen = vec![false; tris.len()];
            for node in &cover.nodes {
                if let Node::Cell { triangles, .. } = node {
                    triangles.iter().for_each(|&t| seen[t] = true);
                }
            }
            assert!(seen.iter().all(|&s| s));
        }
    }
}
