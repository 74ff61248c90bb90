//! Leafy BSP from brushes (the Quake 2 "brush BSP"): brushes are split down the tree until every
//! brush piece in a node fills the node's whole convex volume, so a leaf's contents are exact.
//!
//! # Splitter choice, in order
//! 1. an unused hint side that cuts the node volume;
//! 2. "midsplit": when the node volume is longer than [`MAX_NODE_SIZE`] on some axis, the unused
//!    axial brush plane on that axis nearest the middle (when within the middle half) — this cuts
//!    big open volumes fast and keeps the tree balanced;
//! 3. otherwise every unused side plane that cuts the volume is scored, visible sides (those that
//!    kept a face after CSG) before invisible ones, structural before detail, as qbsp3 does:
//!    `5·facing − SPLIT_WEIGHT·splits − |front − back|`, plus 5 for axial planes; the highest
//!    score wins and the first one found wins ties (brush order, side order: deterministic). See
//!    [`SPLIT_WEIGHT`] for the weight.
//!
//! A plane "cuts" a volume when corners of the volume lie more than [`ON_EPSILON`] on both sides.
//! Detail brushes take part only once no structural side is left in a node ("detail pass"): the
//! nodes they make are flagged `detail`, and each maximal detail subtree becomes one cluster.
//!
//! A node is a leaf when no unused side of its brushes cuts it; its contents are the highest
//! [`priority`] of its brushes, or empty. Node planes are always the even (positive) plane of a
//! [`PlaneSet`] pair, `children[0]` is in front.

use rayon::prelude::*;
use sightline_formats::geom::ON_EPSILON;
use sightline_formats::{Aabb, Contents, PlaneSet};
use sightline_job::cancel::Cancel;

use crate::brush::Brush;
use crate::contents::priority;

/// Volumes longer than this on an axis are split near their middle first. At 1024 (qbsp's
/// default) building is a third faster but E1M1 gets 6 % more leaves and portals, which costs far
/// more in vis than it saves here, so only huge volumes get midsplits. Without any, the generated
/// cities' flows take half the chains (the tree of `city_20` is then ericw-tools'), but a PVS
/// walk submits 1.9–2.0 times the faces on them and on `arena_32`: the midsplits cut open sky
/// and halls into cells that see less (session 28, `docs/benchmarks.md`).
pub const MAX_NODE_SIZE: f64 = 4096.0;

/// The score a splitter loses per brush it splits (see the module docs); qbsp3 and q3map2 use 5.
///
/// Fewer splits mean fewer, larger leaves, and on open maps longer sight lines through them: the
/// flow's chains there grow with the weight. Our compiles with 10 against 20 (2 threads, AMD EPYC
/// host, 2026-11-30, before `vis::explored` forgot when full): chains ×0.58 on the generated
/// `city_36` (334 M → 195 M), ×0.70 on `city_28`, ×0.75 on `city_20`, ×0.86 on `arena_32`,
/// ×0.87 on `terrain_40`, with the faces a PVS walk submits from random poses (`sightline
/// bench`) 0.96–1.00 times as many; on id's and LibreQuake's maps, whose flows take under a
/// second, leaves +0–11 %, chains ×0.87–1.50 and faces submitted ×0.91–1.11 (over the 23 maps,
/// ×0.99 in geometric mean). 5 gives 10 % more leaves everywhere; 20 gave E1M1 2 % fewer
/// (`docs/benchmarks.md`, session 28). Dropping the midsplit instead halves the chains on the
/// cities but doubles the faces submitted: see [`MAX_NODE_SIZE`].
pub const SPLIT_WEIGHT: i64 = 10;

/// Below this many brushes a node's children are built on the current thread.
const PARALLEL_MIN_BRUSHES: usize = 48;

/// A flat tree: index 0 is the root; interior nodes and leaves share one index space.
#[derive(Debug, Clone, Default)]
pub struct Tree {
    /// Nodes and leaves in pre-order, front child first.
    pub nodes: Vec<TreeNode>,
}

/// One entry of a [`Tree`].
#[derive(Debug, Clone)]
pub enum TreeNode {
    /// An interior node.
    Node {
        /// Even plane index; `children[0]` is in front of it.
        plane: u32,
        /// Front then back child indices.
        children: [u32; 2],
        /// Bounds of the node's volume.
        bounds: Aabb,
        /// The plane came from a detail brush: the whole subtree is one cluster.
        detail: bool,
    },
    /// A convex cell.
    Leaf {
        /// What fills it.
        contents: Contents,
        /// Bounds of the cell.
        bounds: Aabb,
    },
}

impl TreeNode {
    /// Bounds of the volume.
    pub fn bounds(&self) -> &Aabb {
        match self {
            TreeNode::Node { bounds, .. } | TreeNode::Leaf { bounds, .. } => bounds,
        }
    }
}

impl Tree {
    /// Contents of every entry: a leaf's own, and `Solid` for interior nodes (which callers
    /// index by node id but never treat as cells).
    pub fn contents_by_node(&self) -> Vec<Contents> {
        self.nodes
            .iter()
            .map(|t| match t {
                TreeNode::Leaf { contents, .. } => *contents,
                TreeNode::Node { .. } => Contents::Solid,
            })
            .collect()
    }

    /// The leaf holding `p` (points on a plane go to the front).
    #[cfg(test)]
    pub fn locate(&self, planes: &PlaneSet, p: glam::DVec3) -> u32 {
        let mut i = 0u32;
        while let Some(TreeNode::Node { plane, children, .. }) = self.nodes.get(i as usize) {
            let d = planes.get(*plane as usize).distance(p);
            i = if d >= 0.0 { children[0] } else { children[1] };
        }
        i
    }

    /// The leaf holding `p` with points on a plane going to the **back**, as Quake's tools place
    /// entities: an entity standing exactly on a brush's outer face counts as inside the brush.
    pub fn locate_back(&self, planes: &PlaneSet, p: glam::DVec3) -> u32 {
        let mut i = 0u32;
        while let Some(TreeNode::Node { plane, children, .. }) = self.nodes.get(i as usize) {
            let d = planes.get(*plane as usize).distance(p);
            i = if d > 0.0 { children[0] } else { children[1] };
        }
        i
    }

    /// True when some node was split by a detail brush.
    pub fn has_detail(&self) -> bool {
        self.nodes.iter().any(|n| matches!(n, TreeNode::Node { detail: true, .. }))
    }

    /// The tree with every maximal detail subtree replaced by one leaf, which is empty when any
    /// leaf below it is non-solid in `contents` (per tree index) and solid otherwise. Also returns,
    /// for each index of the new tree, the index in `self` it stands for. Portals of this tree
    /// are the portals between clusters.
    pub fn collapse_detail(&self, contents: &[Contents]) -> (Tree, Vec<u32>) {
        let mut out = Tree::default();
        let mut origin = Vec::new();
        self.collapse_r(0, contents, &mut out.nodes, &mut origin);
        (out, origin)
    }

    fn collapse_r(
        &self,
        i: u32,
        contents: &[Contents],
        out: &mut Vec<TreeNode>,
        origin: &mut Vec<u32>,
    ) -> u32 {
        let index = out.len() as u32;
        origin.push(i);
        match &self.nodes[i as usize] {
            TreeNode::Leaf { bounds, .. } => {
                out.push(TreeNode::Leaf { contents: contents[i as usize], bounds: *bounds });
            }
            TreeNode::Node { bounds, detail: true, .. } => {
                let open = self.subtree(i).any(|j| {
                    matches!(self.nodes[j as usize], TreeNode::Leaf { .. })
                        && contents[j as usize] != Contents::Solid
                });
                let c = if open { Contents::Empty } else { Contents::Solid };
                out.push(TreeNode::Leaf { contents: c, bounds: *bounds });
            }
            TreeNode::Node { plane, children, bounds, detail: false } => {
                out.push(TreeNode::Node { plane: *plane, children: [0, 0], bounds: *bounds, detail: false });
                let f = self.collapse_r(children[0], contents, out, origin);
                let k = self.collapse_r(children[1], contents, out, origin);
                if let Some(TreeNode::Node { children, .. }) = out.get_mut(index as usize) {
                    *children = [f, k];
                }
            }
        }
        index
    }

    /// Indices of the subtree under `i` (itself included): a contiguous pre-order range.
    fn subtree(&self, i: u32) -> std::ops::Range<u32> {
        let mut end = i + 1;
        let mut pending = 1u32;
        // In pre-order a subtree is the shortest run from `i` holding one more leaf than nodes.
        while pending > 0 {
            match self.nodes.get((end - 1) as usize) {
                Some(TreeNode::Node { .. }) => pending += 1,
                Some(TreeNode::Leaf { .. }) => pending -= 1,
                None => break,
            }
            if pending > 0 {
                end += 1;
            }
        }
        i..end
    }

    /// Number of interior nodes.
    #[cfg(test)]
    pub fn num_nodes(&self) -> usize {
        self.nodes.iter().filter(|n| matches!(n, TreeNode::Node { .. })).count()
    }

    /// Number of leaves.
    #[cfg(test)]
    pub fn num_leaves(&self) -> usize {
        self.nodes.len() - self.num_nodes()
    }
}

enum Built {
    Node { plane: u32, children: Box<[Built; 2]>, bounds: Aabb, detail: bool },
    Leaf { contents: Contents, bounds: Aabb },
}

/// Build the tree of `brushes` inside `volume` (a box brush enclosing them all). Once `cancel` is
/// cancelled every node not yet split becomes a leaf at once, so the call returns promptly with a
/// tree that is not the map's: the caller must check `cancel` and discard it.
pub fn build(planes: &PlaneSet, brushes: Vec<Brush>, volume: Brush, cancel: &Cancel) -> Tree {
    let built = build_r(planes, brushes, volume, cancel);
    let mut tree = Tree::default();
    flatten(built, &mut tree.nodes);
    tree
}

fn flatten(b: Built, out: &mut Vec<TreeNode>) -> u32 {
    let index = out.len() as u32;
    match b {
        Built::Leaf { contents, bounds } => out.push(TreeNode::Leaf { contents, bounds }),
        Built::Node { plane, children, bounds, detail } => {
            out.push(TreeNode::Node { plane, children: [0, 0], bounds, detail });
            let [front, back] = *children;
            let f = flatten(front, out);
            let k = flatten(back, out);
            if let Some(TreeNode::Node { children, .. }) = out.get_mut(index as usize) {
                *children = [f, k];
            }
        }
    }
    index
}

fn build_r(planes: &PlaneSet, mut brushes: Vec<Brush>, volume: Brush, cancel: &Cancel) -> Built {
    if cancel.is_cancelled() {
        return Built::Leaf { contents: Contents::Solid, bounds: volume.bounds };
    }
    let corners: Vec<glam::DVec3> = volume.points().collect();
    prune(planes, &mut brushes, &corners);
    let bounds = volume.bounds;
    let Some((plane, detail)) = choose_splitter(planes, &brushes, &bounds) else {
        let contents =
            brushes.iter().map(|b| b.contents).max_by_key(|c| priority(*c)).unwrap_or(Contents::Empty);
        return Built::Leaf { contents, bounds };
    };
    let plane = plane & !1;
    let (vf, vb) = volume.split(planes, plane);
    let (Some(vf), Some(vb)) = (vf, vb) else {
        // Cannot happen for a plane that cuts the volume; treat the plane as used and go on.
        for b in &mut brushes {
            for s in &mut b.sides {
                if s.plane & !1 == plane {
                    s.used = true;
                }
            }
        }
        return build_r(planes, brushes, volume, cancel);
    };
    let mut front = Vec::with_capacity(brushes.len());
    let mut back = Vec::with_capacity(brushes.len());
    for b in brushes {
        let (f, k) = if b.sides.iter().any(|s| s.plane == plane) {
            (None, Some(b))
        } else if b.sides.iter().any(|s| s.plane == plane ^ 1) {
            (Some(b), None)
        } else {
            b.split(planes, plane)
        };
        for (list, part) in [(&mut front, f), (&mut back, k)] {
            if let Some(mut part) = part {
                for s in &mut part.sides {
                    if s.plane & !1 == plane {
                        s.used = true;
                    }
                }
                list.push(part);
            }
        }
    }
    let big = front.len() + back.len() >= PARALLEL_MIN_BRUSHES;
    let (f, k) = if big {
        rayon::join(|| build_r(planes, front, vf, cancel), || build_r(planes, back, vb, cancel))
    } else {
        (build_r(planes, front, vf, cancel), build_r(planes, back, vb, cancel))
    };
    Built::Node { plane, children: Box::new([f, k]), bounds, detail }
}

fn extent(planes: &PlaneSet, plane: u32, corners: &[glam::DVec3]) -> (f64, f64) {
    let p = planes.get(plane as usize);
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for &c in corners {
        let d = p.distance(c);
        lo = lo.min(d);
        hi = hi.max(d);
    }
    (lo, hi)
}

/// Drop brushes that do not reach into the volume and mark sides that do not cut it as used.
fn prune(planes: &PlaneSet, brushes: &mut Vec<Brush>, corners: &[glam::DVec3]) {
    brushes.retain_mut(|b| {
        for s in &mut b.sides {
            if s.used {
                continue;
            }
            let (lo, hi) = extent(planes, s.plane, corners);
            if lo >= -ON_EPSILON {
                // The whole volume is outside this side: the brush is not here.
                return false;
            }
            if hi <= ON_EPSILON {
                s.used = true;
            }
        }
        true
    });
}

/// The splitter and whether it comes from the detail pass.
fn choose_splitter(planes: &PlaneSet, brushes: &[Brush], bounds: &Aabb) -> Option<(u32, bool)> {
    // Unused sides all cut the volume after `prune`.
    if let Some(s) = brushes.iter().filter(|b| !b.detail).flat_map(|b| &b.sides).find(|s| s.hint && !s.used) {
        return Some((s.plane, false));
    }
    for (detail, visible) in [(false, true), (false, false), (true, true), (true, false)] {
        let sides = brushes.iter().filter(|b| b.detail == detail).flat_map(|b| &b.sides);
        let candidates: Vec<u32> =
            sides.filter(|s| !s.used && s.visible == visible).map(|s| s.plane & !1).collect();
        if !candidates.is_empty() {
            return Some((choose_among(planes, brushes, bounds, candidates, !detail), detail));
        }
    }
    None
}

fn choose_among(
    planes: &PlaneSet,
    brushes: &[Brush],
    bounds: &Aabb,
    mut candidates: Vec<u32>,
    midsplit: bool,
) -> u32 {
    // First-appearance order, without repeats.
    let mut seen = std::collections::HashSet::with_capacity(candidates.len());
    candidates.retain(|p| seen.insert(*p));

    let size = bounds.size();
    let axis = if size.x >= size.y && size.x >= size.z {
        0
    } else if size.y >= size.z {
        1
    } else {
        2
    };
    if midsplit && size[axis] > MAX_NODE_SIZE {
        let mid = bounds.center()[axis];
        let best = candidates
            .iter()
            .filter(|&&p| planes.get(p as usize).normal[axis] == 1.0)
            .map(|&p| (p, (planes.get(p as usize).dist - mid).abs()))
            .filter(|&(_, d)| d < size[axis] * 0.25)
            .min_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((p, _)) = best {
            return p;
        }
    }
    let score = |&p: &u32| -> i64 {
        let plane = planes.get(p as usize);
        let (mut front, mut back, mut splits, mut facing) = (0i64, 0i64, 0i64, 0i64);
        for b in brushes {
            if b.sides.iter().any(|s| s.plane & !1 == p) {
                facing += 1;
                if b.sides.iter().any(|s| s.plane == p) {
                    back += 1;
                } else {
                    front += 1;
                }
                continue;
            }
            match b.bounds.side(plane, ON_EPSILON) {
                sightline_formats::Side::Front => front += 1,
                sightline_formats::Side::Back => back += 1,
                _ => {
                    let (lo, hi) = b.extent_along(plane);
                    if lo >= -ON_EPSILON {
                        front += 1;
                    } else if hi <= ON_EPSILON {
                        back += 1;
                    } else {
                        splits += 1;
                        front += 1;
                        back += 1;
                    }
                }
            }
        }
        let axial = if plane.kind().is_axial() { 5 } else { 0 };
        5 * facing - SPLIT_WEIGHT * splits - (front - back).abs() + axial
    };
    let scores: Vec<i64> = if candidates.len() * brushes.len() > 20_000 {
        candidates.par_iter().map(score).collect()
    } else {
        candidates.iter().map(score).collect()
    };
    let mut best = 0;
    for (i, s) in scores.iter().enumerate() {
        if *s > scores[best] {
            best = i;
        }
    }
    candidates[best]
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn boxb(planes: &mut PlaneSet, lo: [f64; 3], hi: [f64; 3]) -> Brush {
        let mut b = Brush::from_box(planes, &Aabb::new(DVec3::from(lo), DVec3::from(hi)), Contents::Solid);
        for s in &mut b.sides {
            s.used = false;
        }
        b
    }

    #[test]
    fn single_box_makes_one_solid_leaf_and_empty_around() {
        let mut planes = PlaneSet::new();
        let b = boxb(&mut planes, [0.0; 3], [64.0; 3]);
        let vol = Brush::from_box(
            &mut planes,
            &Aabb::new(DVec3::splat(-64.0), DVec3::splat(128.0)),
            Contents::Empty,
        );
        let tree = build(&planes, vec![b], vol, &Cancel::new());
        assert_eq!(tree.num_nodes(), 6);
        assert_eq!(tree.num_leaves(), 7);
        let solid = tree.locate(&planes, DVec3::splat(32.0));
        assert!(matches!(tree.nodes[solid as usize], TreeNode::Leaf { contents: Contents::Solid, .. }));
        let empty = tree.locate(&planes, DVec3::splat(100.0));
        assert!(matches!(tree.nodes[empty as usize], TreeNode::Leaf { contents: Contents::Empty, .. }));
    }
}

#[cfg(test)]
mod proptests {
    use super::*;
    use glam::DVec3;
    use proptest::prelude::*;

    fn boxes() -> impl Strategy<Value = Vec<([i32; 3], [i32; 3])>> {
        prop::collection::vec(
            (prop::array::uniform3(0i32..6), prop::array::uniform3(1i32..4))
                .prop_map(|(lo, size)| (lo, [lo[0] + size[0], lo[1] + size[1], lo[2] + size[2]])),
            1..7,
        )
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// Leaf contents are exact: a point is in a solid leaf exactly when it is inside a box.
        #[test]
        fn leaf_contents_match_the_brushes(list in boxes()) {
            let mut planes = PlaneSet::new();
            let scale = 16.0;
            let mut brushes = Vec::new();
            for (lo, hi) in &list {
                let bounds = Aabb::new(DVec3::from(lo.map(f64::from)) * scale, DVec3::from(hi.map(f64::from)) * scale);
                let mut b = Brush::from_box(&mut planes, &bounds, Contents::Solid);
                for s in &mut b.sides {
                    s.used = false;
                }
                brushes.push(b);
            }
            let world = Aabb::new(DVec3::splat(-16.0), DVec3::splat(160.0));
            let volume = Brush::from_box(&mut planes, &world, Contents::Empty);
            let tree = build(&planes, brushes, volume, &Cancel::new());
            for x in 0..18 {
                for y in 0..18 {
                    for z in 0..18 {
                        // Cell centres never lie on a plane.
                        let p = DVec3::new(x as f64 + 0.5, y as f64 + 0.5, z as f64 + 0.5) * 8.0 - DVec3::splat(8.0);
                        let inside = list.iter().any(|(lo, hi)| {
                            (0..3).all(|a| p[a] > lo[a] as f64 * scale && p[a] < hi[a] as f64 * scale)
                        });
                        let leaf = tree.locate(&planes, p);
                        let TreeNode::Leaf { contents, bounds } = &tree.nodes[leaf as usize] else {
                            panic!("locate ends in a leaf");
                        };
                        prop_assert_eq!(*contents == Contents::Solid, inside, "at {}", p);
                        prop_assert!(bounds.contains_point(p, 1e-9));
                    }
                }
            }
        }
    }
}
