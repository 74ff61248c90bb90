//! Bounding volume hierarchy over triangles for ray casting.
//!
//! A binary BVH built top-down with a binned surface-area heuristic (16 bins per axis, leaves of at
//! most [`MAX_LEAF`] triangles), stored as a flat array of 32-byte nodes (the two children of an
//! interior node are adjacent) for the build and `groups`; rays traverse the tree collapsed to
//! 4-wide nodes (four children's boxes in SIMD lanes, tested at once; subtrees of at most
//! `MERGE_LEAF` triangles become one leaf) with a small explicit stack,
//! entered children nearest first, and test a leaf's triangles four at a time (one triangle per
//! SIMD lane, the same arithmetic as the one-triangle test, so the same hits). Box queries
//! (`overlapping`) walk the same 4-wide tree.
//!
//! # Conventions
//! - Rays are `origin + t * dir` with `dir` not necessarily normalised; `t` is in units of `dir`.
//!   A hit counts when `0 < t < t_max` (the origin itself is excluded, so a ray leaving a surface
//!   does not hit it at `t = 0`).
//! - Triangles are two-sided. `u`, `v` are barycentric coordinates: the hit point is
//!   `v0 + u * (v1 - v0) + v * (v2 - v0)`.
//! - `triangle` in a [`Hit`] is the index into the slice given to [`Bvh::build`].
//! - The triangle test is watertight (Woop et al. 2013) in `f32`: a ray through a shared edge or
//!   corner of a closed mesh cannot slip between its triangles. Degenerate (zero-area) triangles
//!   never hit.
//! - Results are deterministic: among hits at exactly equal `t` the one found first in the fixed
//!   traversal order wins.

use glam::{Vec3, Vec3A, Vec4};

mod packet;
mod stack;
pub use packet::LANES;
use stack::Stack;

/// Most triangles in one leaf.
pub const MAX_LEAF: usize = 4;
/// A child of a 4-wide node whose subtree holds at most this many triangles becomes one leaf (its
/// triangles in consecutive blocks) rather than a node of its own: a second block test costs less
/// than another node's box tests (+1.3 % GVS rays per second on the sphere cloud, the city's GVS
/// unchanged, ID-buffer rays +1 %: paired runs). 44 % of the 4-wide nodes had only two children,
/// mostly two leaves.
const MERGE_LEAF: u32 = 2 * MAX_LEAF as u32;
/// SAH bins per axis.
const BINS: usize = 16;
/// Cost of one node traversal relative to one triangle test. The triangles of a leaf are tested
/// four at a time ([`Block`]), so a node costs about as much as four triangles: every node of at
/// most [`MAX_LEAF`] triangles becomes a leaf (measured against 0.6 with one-at-a-time tests:
/// +9–14 % GVS rays per second on the sphere cloud, the city's GVS unchanged, its very coherent
/// ID-buffer rays 10 % slower).
const TRAVERSAL_COST: f32 = 4.0;
/// Deepest tree the traversal stack holds; the build makes a (large) leaf rather than go deeper.
const STACK: usize = 96;
/// Factor widening a box's far distance (a few ulps), so that rounding in the slab test never culls
/// a box holding a hit the watertight triangle test reports.
const WIDEN: f32 = 1.0 + 4.0 * f32::EPSILON;
/// Traversal stack of the 4-wide tree for trees whose deepest path needs at most this many entries
/// (nearly all: a smaller stack is faster to set up per ray).
const STACK_SMALL: usize = 40;
/// Traversal stack of any 4-wide tree: it is no deeper than the binary tree, and a quad pushes at
/// most three children.
const STACK_DEEP: usize = 3 * STACK;

/// A ray hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit (`origin + t * dir`).
    pub t: f32,
    /// Index of the triangle in the build slice.
    pub triangle: u32,
    /// Barycentric coordinate along `v1 - v0`.
    pub u: f32,
    /// Barycentric coordinate along `v2 - v0`.
    pub v: f32,
}

/// A node while building: a box, then either the first child (interior, `count == 0`; the second
/// child is `first + 1`) or the first triangle of a leaf (`count > 0`).
#[derive(Debug, Clone, Copy)]
struct BuildNode {
    min: Vec3,
    first: u32,
    max: Vec3,
    count: u32,
}

/// A node as traversed: 32 bytes, two SIMD lanes sets; the `w` lanes carry the bits of `first`
/// (in `lo`) and `count` (in `hi`), as in [`BuildNode`].
#[derive(Debug, Clone, Copy)]
struct Node {
    lo: Vec4,
    hi: Vec4,
}

impl Node {
    fn pack(b: &BuildNode) -> Node {
        Node { lo: b.min.extend(f32::from_bits(b.first)), hi: b.max.extend(f32::from_bits(b.count)) }
    }

    #[inline(always)]
    fn first(&self) -> u32 {
        self.lo.w.to_bits()
    }

    #[inline(always)]
    fn count(&self) -> u32 {
        self.hi.w.to_bits()
    }
}

/// What traversal needs of up to four children of a node of the 4-wide traversal tree (the binary
/// tree collapsed: a node's children are replaced by theirs, largest surface area first, until it
/// has four), in two 64-byte cache lines. Boxes are stored one plane per vector with one lane per
/// child, so one SIMD slab test covers all four; unused lanes hold the empty box (min +∞, max −∞),
/// which no ray enters. A child is a quad (`count == 0`, `first` is its index in `quads`) or a
/// leaf (`first` is its first [`Block`], `count` its triangles).
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct Quad {
    /// `[min x, max x, min y, max y, min z, max z]`, lane `i` for child `i`.
    planes: [Vec4; 6],
    first: [u32; 4],
    count: [u32; 4],
}

impl Quad {
    const EMPTY: Quad = Quad {
        planes: [
            Vec4::INFINITY,
            Vec4::NEG_INFINITY,
            Vec4::INFINITY,
            Vec4::NEG_INFINITY,
            Vec4::INFINITY,
            Vec4::NEG_INFINITY,
        ],
        first: [0; 4],
        count: [0; 4],
    };
}

/// Every node's triangles as `first..end` build positions (a subtree's triangles are contiguous);
/// children come after their parent, so one backward pass finds them all.
fn subtree_ranges(nodes: &[Node]) -> Vec<(u32, u32)> {
    let mut range = vec![(0u32, 0u32); nodes.len()];
    for i in (0..nodes.len()).rev() {
        let n = &nodes[i];
        range[i] = if n.count() > 0 {
            (n.first(), n.first() + n.count())
        } else {
            let l = n.first() as usize;
            match (range.get(l), range.get(l + 1)) {
                (Some(a), Some(b)) => (a.0, b.1),
                _ => (0, 0),
            }
        };
    }
    range
}

/// Collapse the binary tree into [`Quad`]s (root quad first; empty when the root is a leaf), and
/// the most traversal stack entries a ray can need (a quad pushes all its children but one).
fn collapse(nodes: &[Node], tris: &[Prepared]) -> (Vec<Quad>, Vec<Block>, usize) {
    let half_area = |n: &Node| {
        let d = (n.hi - n.lo).truncate().max(Vec3::ZERO);
        d.x * d.y + d.y * d.z + d.z * d.x
    };
    let mut quads = Vec::new();
    let mut blocks = Vec::new();
    // A leaf root, or the empty tree (a root without triangles or children).
    if nodes.len() < 3 || nodes[0].count() > 0 {
        if let Some(root) = nodes.first() {
            blocks.extend(Block::of_leaf(tris, root.first(), root.count()));
        }
        return (quads, blocks, 0);
    }
    let range = subtree_ranges(nodes);
    quads.push(Quad::EMPTY);
    // Per quad: the most entries on the stack when a ray enters it.
    let mut stack_need = vec![0usize];
    let mut need = 0;
    let mut work = vec![(0usize, 0usize)];
    while let Some((bi, qi)) = work.pop() {
        let f = nodes[bi].first() as usize;
        let mut kids = [f, f + 1, 0, 0];
        let mut n = 2;
        while n < 4 {
            // The interior child with the largest box (the first of equals) opens.
            let mut open: Option<(usize, f32)> = None;
            for (i, &k) in kids[..n].iter().enumerate() {
                if nodes[k].count() == 0 && open.is_none_or(|(_, a)| half_area(&nodes[k]) > a) {
                    open = Some((i, half_area(&nodes[k])));
                }
            }
            let Some((i, _)) = open else { break };
            let g = nodes[kids[i]].first() as usize;
            kids.copy_within(i + 1..n, i + 2);
            kids[i] = g;
            kids[i + 1] = g + 1;
            n += 1;
        }
        let mut q = Quad::EMPTY;
        for (lane, &k) in kids[..n].iter().enumerate() {
            let node = &nodes[k];
            for axis in 0..3 {
                q.planes[2 * axis][lane] = node.lo[axis];
                q.planes[2 * axis + 1][lane] = node.hi[axis];
            }
            // A leaf, or a small subtree merged into one (its triangles are contiguous).
            let (a, b) = range[k];
            if node.count() > 0 || b - a <= MERGE_LEAF {
                (q.first[lane], q.count[lane]) = (blocks.len() as u32, b - a);
                blocks.extend(Block::of_leaf(tris, a, b - a));
            } else {
                q.first[lane] = quads.len() as u32;
                work.push((k, quads.len()));
                quads.push(Quad::EMPTY);
                stack_need.push(stack_need[qi] + n - 1);
            }
        }
        need = need.max(stack_need[qi] + n - 1);
        quads[qi] = q;
    }
    (quads, blocks, need)
}

/// A triangle's corners, exactly as given (watertightness needs shared corners bit-identical).
#[derive(Debug, Clone, Copy)]
struct Prepared {
    v0: Vec3,
    v1: Vec3,
    v2: Vec3,
}

/// Up to four triangles of a leaf, for one SIMD watertight test: `p[vertex][axis]`, lane `i` for
/// the `i`-th of the triangles at build positions `first..first + n` (as in `Bvh::ids`); unused
/// lanes are NaN, which never hits.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(16))]
struct Block {
    p: [[Vec4; 3]; 3],
    first: u32,
    n: u32,
}

impl Block {
    /// The blocks of the triangles `first..first + count` of `tris`.
    fn of_leaf(tris: &[Prepared], first: u32, count: u32) -> impl Iterator<Item = Block> + '_ {
        (first..first + count).step_by(4).map(move |f| {
            let n = (first + count - f).min(4);
            let mut p = [[Vec4::NAN; 3]; 3];
            for lane in 0..n as usize {
                let t = &tris[f as usize + lane];
                for (k, v) in [t.v0, t.v1, t.v2].into_iter().enumerate() {
                    for axis in 0..3 {
                        p[k][axis][lane] = v[axis];
                    }
                }
            }
            Block { p, first: f, n }
        })
    }

    /// The triangle in `lane`.
    fn tri(&self, lane: usize) -> Prepared {
        let v = |k: usize| Vec3::new(self.p[k][0][lane], self.p[k][1][lane], self.p[k][2][lane]);
        Prepared { v0: v(0), v1: v(1), v2: v(2) }
    }
}

/// A ray prepared for the watertight test: the axis permutation and shear that map `dir` to +z.
#[derive(Debug, Clone, Copy)]
struct Ray {
    origin: Vec3,
    /// The dominant axis; the other two are `(kz + 1) % 3` and `(kz + 2) % 3`. (Woop et al. swap
    /// those two when `dir[kz] < 0` to keep the winding; that only negates u, v, w, det and the
    /// scaled t exactly, so the test is the same without it.)
    kz: usize,
    sx: f32,
    sy: f32,
    sz: f32,
}

impl Ray {
    fn new(origin: Vec3, dir: Vec3) -> Ray {
        let kz = dominant_axis(dir);
        let (kx, ky) = ((kz + 1) % 3, (kz + 2) % 3);
        Ray { origin, kz, sx: dir[kx] / dir[kz], sy: dir[ky] / dir[kz], sz: 1.0 / dir[kz] }
    }
}

/// The axis of `dir`'s largest component (the first of equals; 2 when any is NaN).
#[inline(always)]
fn dominant_axis(dir: Vec3) -> usize {
    let a = dir.abs();
    if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    }
}

/// A BVH over a triangle soup.
#[derive(Debug, Clone)]
pub struct Bvh {
    nodes: Vec<Node>,
    /// The 4-wide traversal tree, see [`Quad`].
    quads: Vec<Quad>,
    /// True when a ray may need more than [`STACK_SMALL`] stack entries.
    deep: bool,
    /// The leaves' triangles in [`Block`]s (the only copy of the geometry); leaf children of quads
    /// (and a leaf root) index these.
    blocks: Vec<Block>,
    ids: Vec<u32>,
}

#[derive(Debug, Clone, Copy)]
struct Bounds {
    min: Vec3,
    max: Vec3,
}

impl Bounds {
    const EMPTY: Bounds = Bounds { min: Vec3::INFINITY, max: Vec3::NEG_INFINITY };

    fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    fn join(&mut self, o: &Bounds) {
        self.min = self.min.min(o.min);
        self.max = self.max.max(o.max);
    }

    fn half_area(&self) -> f32 {
        let d = (self.max - self.min).max(Vec3::ZERO);
        d.x * d.y + d.y * d.z + d.z * d.x
    }
}

/// Per-triangle build data.
#[derive(Debug, Clone, Copy)]
struct Item {
    bounds: Bounds,
    centre: Vec3,
}

impl Bvh {
    /// Build over `triangles`. Non-finite triangles are kept in the index space but never hit.
    pub fn build(triangles: &[[Vec3; 3]]) -> Bvh {
        let mut items = Vec::with_capacity(triangles.len());
        let mut order = Vec::with_capacity(triangles.len());
        for (i, t) in triangles.iter().enumerate() {
            if !t.iter().all(|p| p.is_finite()) {
                continue;
            }
            let mut b = Bounds::EMPTY;
            t.iter().for_each(|&p| b.grow(p));
            items.push(Item { bounds: b, centre: (b.min + b.max) * 0.5 });
            order.push(i as u32);
        }
        let mut nodes = Vec::with_capacity(2 * order.len() / MAX_LEAF + 1);
        let mut root_bounds = Bounds::EMPTY;
        items.iter().for_each(|it| root_bounds.join(&it.bounds));
        if items.is_empty() {
            root_bounds = Bounds { min: Vec3::ZERO, max: Vec3::ZERO };
        }
        nodes.push(BuildNode {
            min: root_bounds.min,
            first: 0,
            max: root_bounds.max,
            count: items.len() as u32,
        });
        // Index permutation into `items`, partitioned in place.
        let mut perm: Vec<u32> = (0..items.len() as u32).collect();
        let mut work = vec![(0usize, 0usize)];
        while let Some((ni, depth)) = work.pop() {
            let BuildNode { first, count, .. } = nodes[ni];
            let (lo, hi) = (first as usize, first as usize + count as usize);
            if depth + 1 >= STACK {
                continue;
            }
            let Some(mid) = split(&items, &mut perm[lo..hi], &nodes[ni]) else {
                continue;
            };
            let mid = lo + mid;
            let left = nodes.len();
            for (a, b) in [(lo, mid), (mid, hi)] {
                let mut bb = Bounds::EMPTY;
                perm[a..b].iter().for_each(|&k| bb.join(&items[k as usize].bounds));
                nodes.push(BuildNode { min: bb.min, first: a as u32, max: bb.max, count: (b - a) as u32 });
            }
            nodes[ni].first = left as u32;
            nodes[ni].count = 0;
            work.push((left + 1, depth + 1));
            work.push((left, depth + 1));
        }
        let ids: Vec<u32> = perm.iter().map(|&k| order[k as usize]).collect();
        let tris: Vec<Prepared> = ids
            .iter()
            .map(|&id| {
                let [a, b, c] = triangles[id as usize];
                Prepared { v0: a, v1: b, v2: c }
            })
            .collect();
        let nodes: Vec<Node> = nodes.iter().map(Node::pack).collect();
        let (quads, blocks, need) = collapse(&nodes, &tris);
        Bvh { nodes, quads, deep: need > STACK_SMALL, blocks, ids }
    }

    /// Number of triangles the tree holds (non-finite input triangles are left out).
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// True when the tree holds no triangle.
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// Number of nodes (for statistics).
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Closest hit with `0 < t < t_max`, if any.
    pub fn intersect(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Option<Hit> {
        self.traverse::<false>(origin, dir, t_max)
    }

    /// True when anything is hit with `0 < t < t_max`.
    pub fn occluded(&self, origin: Vec3, dir: Vec3, t_max: f32) -> bool {
        self.traverse::<true>(origin, dir, t_max).is_some()
    }

    /// Split the triangles into spatially coherent groups: call `f` once per largest subtree that
    /// holds at most `max` triangles (or per leaf, when a leaf holds more), with the indices (in
    /// the build slice) of its triangles, in a fixed order. Every triangle is in exactly one group.
    pub fn groups(&self, max: usize, mut f: impl FnMut(&[u32])) {
        if self.ids.is_empty() {
            return;
        }
        let range = subtree_ranges(&self.nodes);
        let mut stack = [0u32; STACK];
        let mut sp = 1usize;
        while sp > 0 {
            sp -= 1;
            let ni = stack[sp] as usize;
            let (a, b) = (range[ni].0 as usize, range[ni].1 as usize);
            let node = &self.nodes[ni];
            if node.count() > 0 || b - a <= max || sp + 2 > STACK {
                f(&self.ids[a..b]);
            } else {
                stack[sp] = node.first() + 1;
                stack[sp + 1] = node.first();
                sp += 2;
            }
        }
    }

    /// Call `f` with the index (in the build slice) of every triangle whose bounding box overlaps
    /// the box `min..max` (closed boxes: touching counts), in a fixed order, until `f` returns
    /// false.
    pub fn overlapping(&self, min: Vec3, max: Vec3, f: impl FnMut(u32) -> bool) {
        if self.deep {
            self.overlapping_in::<STACK_DEEP>(min, max, f);
        } else {
            self.overlapping_in::<STACK_SMALL>(min, max, f);
        }
    }

    /// [`Bvh::overlapping`] through the 4-wide tree (four child boxes, then four triangle boxes, per
    /// SIMD test), children in lane order: the binary tree's left-to-right order, so triangles come
    /// in build order. `N` is a stack of at least the tree's need (as in `walk`).
    fn overlapping_in<const N: usize>(&self, min: Vec3, max: Vec3, mut f: impl FnMut(u32) -> bool) {
        let Some(root) = self.nodes.first() else {
            return;
        };
        let (x0, y0, z0) = (Vec4::splat(min.x), Vec4::splat(min.y), Vec4::splat(min.z));
        let (x1, y1, z1) = (Vec4::splat(max.x), Vec4::splat(max.y), Vec4::splat(max.z));
        // Lanes whose box `[lo, hi]` (one plane per vector) meets the query box; NaN never does.
        let meets = |lo: [Vec4; 3], hi: [Vec4; 3]| {
            (lo[0].cmple(x1)
                & lo[1].cmple(y1)
                & lo[2].cmple(z1)
                & hi[0].cmpge(x0)
                & hi[1].cmpge(y0)
                & hi[2].cmpge(z0))
            .bitmask()
        };
        let mut stack = Stack::<(u32, u32), N>::new();
        // The root: a leaf (its blocks start at 0), or quad 0.
        let (mut first, mut count) = (0, root.count());
        loop {
            if count > 0 {
                let first = first as usize;
                for b in self.blocks.get(first..first + count.div_ceil(4) as usize).unwrap_or_default() {
                    let p = &b.p;
                    let lo = std::array::from_fn(|k| p[0][k].min(p[1][k]).min(p[2][k]));
                    let hi = std::array::from_fn(|k| p[0][k].max(p[1][k]).max(p[2][k]));
                    let mut mask = meets(lo, hi) & ((1 << b.n) - 1);
                    while mask != 0 {
                        let k = b.first as usize + mask.trailing_zeros() as usize;
                        if let Some(&id) = self.ids.get(k)
                            && !f(id)
                        {
                            return;
                        }
                        mask &= mask - 1;
                    }
                }
            } else if let Some(q) = self.quads.get(first as usize) {
                let p = &q.planes;
                let mask = meets([p[0], p[2], p[4]], [p[1], p[3], p[5]]);
                if mask != 0 {
                    // The first lane now, the others (last lane deepest) later.
                    for i in (mask.trailing_zeros() as usize + 1..4).rev() {
                        if mask & (1 << i) != 0 {
                            stack.push((q.first[i], q.count[i]));
                        }
                    }
                    let i = mask.trailing_zeros() as usize;
                    (first, count) = (q.first[i], q.count[i]);
                    continue;
                }
            }
            let Some(next) = stack.pop() else {
                return;
            };
            (first, count) = next;
        }
    }

    fn traverse<const ANY: bool>(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Option<Hit> {
        // A non-finite ray hits nothing (and could enter the empty lanes of a quad, which would
        // lead back to the root).
        if self.ids.is_empty() || t_max.is_nan() || t_max <= 0.0 || !(origin.is_finite() && dir.is_finite()) {
            return None;
        }
        let ray = Ray::new(origin, dir);
        // One traversal per dominant axis, so that the triangle test indexes by constants.
        // and one per stack size.
        match (ray.kz, self.deep) {
            (0, false) => self.walk::<ANY, 0, STACK_SMALL>(&ray, dir, t_max),
            (1, false) => self.walk::<ANY, 1, STACK_SMALL>(&ray, dir, t_max),
            (_, false) => self.walk::<ANY, 2, STACK_SMALL>(&ray, dir, t_max),
            (0, true) => self.walk::<ANY, 0, STACK_DEEP>(&ray, dir, t_max),
            (1, true) => self.walk::<ANY, 1, STACK_DEEP>(&ray, dir, t_max),
            (_, true) => self.walk::<ANY, 2, STACK_DEEP>(&ray, dir, t_max),
        }
    }

    fn walk<const ANY: bool, const KZ: usize, const N: usize>(
        &self,
        ray: &Ray,
        dir: Vec3,
        t_max: f32,
    ) -> Option<Hit> {
        let origin = ray.origin;
        // Direction components smaller than the smallest normal float become it (same sign), so
        // that `inv` is finite and non-zero: slab distances are never 0 × ∞ = NaN, and the near
        // plane of a box is its min plane on an axis where `inv > 0`, its max plane otherwise.
        let safe = |d: f32| if d.abs() < f32::MIN_POSITIVE { f32::MIN_POSITIVE.copysign(d) } else { d };
        let inv = Vec3A::new(safe(dir.x), safe(dir.y), safe(dir.z)).recip();
        let o = Vec3A::from(origin);
        let (ox, oy, oz) = (Vec4::splat(o.x), Vec4::splat(o.y), Vec4::splat(o.z));
        let (ix, iy, iz) = (Vec4::splat(inv.x), Vec4::splat(inv.y), Vec4::splat(inv.z));
        // Far distances are widened by a few ulps so that boxes never cull a hit the watertight
        // test reports: through the reciprocal (and the current best distance), which keeps the
        // widening off each node's critical path (a few per cent faster than widening the result).
        let (wx, wy, wz) = (ix * WIDEN, iy * WIDEN, iz * WIDEN);
        let mut t_wide = Vec4::splat(t_max * WIDEN);
        let side = |i: f32, axis: usize| 2 * axis + usize::from(i < 0.0);
        let (nx, ny, nz) = (side(inv.x, 0), side(inv.y, 1), side(inv.z, 2));
        let (fx, fy, fz) = (nx ^ 1, ny ^ 1, nz ^ 1);
        let mut best: Option<Hit> = None;
        let mut t_best = t_max;
        // Stack of (first, count, entry distance) of children still to visit.
        let mut stack = Stack::<(u32, u32, f32), N>::new();
        box_hit(&self.nodes[0], o, inv, t_best)?;
        // The root: a leaf (its blocks start at 0), or quad 0.
        let (mut first, mut count) = (0, self.nodes[0].count());
        let wray = WideRay::new::<KZ>(ray);
        loop {
            if count > 0 {
                let first = first as usize;
                for b in &self.blocks[first..first + count.div_ceil(4) as usize] {
                    if let Some((k, t, u, v)) = b.hit::<KZ>(&wray, ray, t_best) {
                        t_best = t;
                        t_wide = Vec4::splat(t * WIDEN);
                        best = Some(Hit { t, triangle: self.ids[k], u, v });
                        if ANY {
                            return best;
                        }
                    }
                }
            } else {
                let q = &self.quads[first as usize];
                let p = &q.planes;
                let near = ((p[nx] - ox) * ix).max((p[ny] - oy) * iy).max((p[nz] - oz) * iz).max(Vec4::ZERO);
                let far = ((p[fx] - ox) * wx).min((p[fy] - oy) * wy).min((p[fz] - oz) * wz).min(t_wide);
                let mask = near.cmple(far).bitmask();
                if mask != 0 {
                    let d: [f32; 4] = near.into();
                    // Entered children nearest first (lane order among equal distances).
                    let mut lanes = [0usize; 4];
                    let mut n = 0;
                    for i in 0..4 {
                        if mask & (1 << i) != 0 {
                            let mut j = n;
                            while j > 0 && d[lanes[j - 1]] > d[i] {
                                lanes[j] = lanes[j - 1];
                                j -= 1;
                            }
                            lanes[j] = i;
                            n += 1;
                        }
                    }
                    for &i in lanes[1..n].iter().rev() {
                        // `N` is at least the tree's need (`collapse`).
                        stack.push((q.first[i], q.count[i], d[i]));
                    }
                    (first, count) = (q.first[lanes[0]], q.count[lanes[0]]);
                    continue;
                }
            }
            // Pop, skipping children that the current best hit already rules out.
            loop {
                let Some((f, c, t_enter)) = stack.pop() else {
                    return best;
                };
                if t_enter <= t_best {
                    (first, count) = (f, c);
                    break;
                }
            }
        }
    }
}

/// A ray's origin and shear (see [`Ray`]) in the permuted axes `kx, ky, kz`, in all SIMD lanes.
#[derive(Debug, Clone, Copy)]
struct WideRay {
    o: [Vec4; 3],
    s: [Vec4; 3],
}

impl WideRay {
    #[inline(always)]
    fn new<const KZ: usize>(ray: &Ray) -> WideRay {
        let (kx, ky) = ((KZ + 1) % 3, (KZ + 2) % 3);
        let o = ray.origin;
        WideRay {
            o: [Vec4::splat(o[kx]), Vec4::splat(o[ky]), Vec4::splat(o[KZ])],
            s: [Vec4::splat(ray.sx), Vec4::splat(ray.sy), Vec4::splat(ray.sz)],
        }
    }
}

impl Block {
    /// [`tri_hit`] on the (up to four) triangles of the block at once: the nearest hit with
    /// `0 < t < t_max` as `(build position, t, u, v)`, the first of equals in lane order, exactly
    /// as testing them one after the other would give. Blocks where an edge function comes out
    /// exactly zero go through [`tri_hit`] (its `f64` recomputation).
    #[inline(always)]
    fn hit<const KZ: usize>(&self, r: &WideRay, ray: &Ray, t_max: f32) -> Option<(usize, f32, f32, f32)> {
        let b = self;
        let (kx, ky, kz) = ((KZ + 1) % 3, (KZ + 2) % 3, KZ);
        let [ox, oy, oz] = r.o;
        let [sx, sy, sz] = r.s;
        let p = &b.p;
        let (az, bz, cz) = (p[0][kz] - oz, p[1][kz] - oz, p[2][kz] - oz);
        let ax = (p[0][kx] - ox) - sx * az;
        let ay = (p[0][ky] - oy) - sy * az;
        let bx = (p[1][kx] - ox) - sx * bz;
        let by = (p[1][ky] - oy) - sy * bz;
        let cx = (p[2][kx] - ox) - sx * cz;
        let cy = (p[2][ky] - oy) - sy * cz;
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        let zero = Vec4::ZERO;
        if (u.cmpeq(zero) | v.cmpeq(zero) | w.cmpeq(zero)).any() {
            return b.hit_scalar::<KZ>(ray, t_max);
        }
        let neg = u.cmplt(zero) | v.cmplt(zero) | w.cmplt(zero);
        let pos = u.cmpgt(zero) | v.cmpgt(zero) | w.cmpgt(zero);
        let det = u + v + w;
        let t_scaled = u * (sz * az) + v * (sz * bz) + w * (sz * cz);
        let inv = Vec4::ONE / det;
        let t = t_scaled * inv;
        let hit = !(neg & pos)
            & det.cmpne(zero)
            & det.abs().cmplt(Vec4::INFINITY)
            & t.cmpgt(zero)
            & t.cmplt(Vec4::splat(t_max));
        let mask = hit.bitmask();
        if mask == 0 {
            return None;
        }
        let ts: [f32; 4] = t.into();
        let mut lane = mask.trailing_zeros() as usize;
        for i in lane + 1..4 {
            if mask & (1 << i) != 0 && ts[i] < ts[lane] {
                lane = i;
            }
        }
        Some((b.first as usize + lane, ts[lane], v[lane] * inv[lane], w[lane] * inv[lane]))
    }

    /// [`tri_hit`] on the block's triangles one after the other.
    fn hit_scalar<const KZ: usize>(&self, ray: &Ray, t_max: f32) -> Option<(usize, f32, f32, f32)> {
        let mut best = None;
        let mut t_best = t_max;
        for lane in 0..self.n as usize {
            if let Some((t, u, v)) = tri_hit::<KZ>(&self.tri(lane), ray, t_best) {
                t_best = t;
                best = Some((self.first as usize + lane, t, u, v));
            }
        }
        best
    }
}

/// Choose a split of `perm` (the triangles of `node`) by binned SAH; returns the count of the left
/// part, or `None` for a leaf.
fn split(items: &[Item], perm: &mut [u32], node: &BuildNode) -> Option<usize> {
    let n = perm.len();
    if n <= 1 {
        return None;
    }
    let mut cb = Bounds::EMPTY;
    perm.iter().for_each(|&k| cb.grow(items[k as usize].centre));
    let extent = cb.max - cb.min;
    let parent = Bounds { min: node.min, max: node.max };
    let leaf_cost = n as f32;
    let mut best: Option<(f32, usize, usize)> = None; // cost, axis, split bin
    for axis in 0..3 {
        let ext = extent[axis];
        if ext.is_nan() || ext <= 0.0 {
            continue;
        }
        let scale = BINS as f32 / ext;
        let mut bins = [(Bounds::EMPTY, 0u32); BINS];
        for &k in perm.iter() {
            let it = &items[k as usize];
            let b = bin_of(it.centre[axis], cb.min[axis], scale);
            bins[b].0.join(&it.bounds);
            bins[b].1 += 1;
        }
        let mut right_area = [0.0f32; BINS];
        let mut right_count = [0u32; BINS];
        let mut acc = Bounds::EMPTY;
        let mut cnt = 0;
        for i in (1..BINS).rev() {
            acc.join(&bins[i].0);
            cnt += bins[i].1;
            right_area[i] = acc.half_area();
            right_count[i] = cnt;
        }
        let mut acc = Bounds::EMPTY;
        let mut cnt = 0;
        for i in 0..BINS - 1 {
            acc.join(&bins[i].0);
            cnt += bins[i].1;
            if cnt == 0 || right_count[i + 1] == 0 {
                continue;
            }
            let cost = TRAVERSAL_COST
                + (acc.half_area() * cnt as f32 + right_area[i + 1] * right_count[i + 1] as f32)
                    / parent.half_area().max(f32::MIN_POSITIVE);
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, i + 1));
            }
        }
    }
    match best {
        Some((cost, axis, bin)) if cost < leaf_cost || n > MAX_LEAF => {
            let scale = BINS as f32 / extent[axis];
            let lo = cb.min[axis];
            let mid = partition(perm, |k| bin_of(items[k as usize].centre[axis], lo, scale) < bin);
            (mid > 0 && mid < n).then_some(mid)
        }
        Some(_) => None,
        // All centres coincide: split in the middle of the list when the leaf is too big.
        None => (n > MAX_LEAF).then_some(n / 2),
    }
}

fn bin_of(c: f32, lo: f32, scale: f32) -> usize {
    (((c - lo) * scale) as usize).min(BINS - 1)
}

/// Move the elements satisfying `pred` to the front; returns how many they are.
fn partition(s: &mut [u32], pred: impl Fn(u32) -> bool) -> usize {
    let mut i = 0;
    for j in 0..s.len() {
        if pred(s[j]) {
            s.swap(i, j);
            i += 1;
        }
    }
    i
}

/// Entry distance of the ray into the node's box when it enters before `t_max`.
#[inline(always)]
fn box_hit(node: &Node, origin: Vec3A, inv: Vec3A, t_max: f32) -> Option<f32> {
    let t0 = (Vec3A::from_vec4(node.lo) - origin) * inv;
    let t1 = (Vec3A::from_vec4(node.hi) - origin) * inv;
    let tnear = t0.min(t1).max_element().max(0.0);
    let tfar = t0.max(t1).min_element().min(t_max) * WIDEN;
    (tnear <= tfar).then_some(tnear)
}

/// Watertight ray/triangle test (Woop, Benthin and Wald 2013): `(t, u, v)` when the ray hits the
/// triangle with `0 < t < t_max`. Rays through a shared edge or corner hit at least one of the
/// triangles sharing it, so nothing leaks through the seams of a closed mesh; edge functions that
/// come out exactly zero are recomputed in `f64`.
#[inline(always)]
fn tri_hit<const KZ: usize>(tri: &Prepared, ray: &Ray, t_max: f32) -> Option<(f32, f32, f32)> {
    let a = tri.v0 - ray.origin;
    let b = tri.v1 - ray.origin;
    let c = tri.v2 - ray.origin;
    let (kx, ky, kz) = ((KZ + 1) % 3, (KZ + 2) % 3, KZ);
    let ax = a[kx] - ray.sx * a[kz];
    let ay = a[ky] - ray.sy * a[kz];
    let bx = b[kx] - ray.sx * b[kz];
    let by = b[ky] - ray.sy * b[kz];
    let cx = c[kx] - ray.sx * c[kz];
    let cy = c[ky] - ray.sy * c[kz];
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        let d = |p: f32, q: f32, r: f32, s: f32| {
            (f64::from(p) * f64::from(q) - f64::from(r) * f64::from(s)) as f32
        };
        u = d(cx, by, cy, bx);
        v = d(ax, cy, ay, cx);
        w = d(bx, ay, by, ax);
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let az = ray.sz * a[kz];
    let bz = ray.sz * b[kz];
    let cz = ray.sz * c[kz];
    let t_scaled = u * az + v * bz + w * cz;
    let inv = 1.0 / det;
    let t = t_scaled * inv;
    (t > 0.0 && t < t_max).then_some((t, v * inv, w * inv))
}

/// Brute-force closest hit over all `triangles`, with the same triangle test as the tree (a
/// reference for tests and for tiny scenes).
pub fn intersect_brute(triangles: &[[Vec3; 3]], origin: Vec3, dir: Vec3, t_max: f32) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    let mut t_best = t_max;
    let ray = Ray::new(origin, dir);
    for (i, &[a, b, c]) in triangles.iter().enumerate() {
        if !(a.is_finite() && b.is_finite() && c.is_finite()) {
            continue;
        }
        let tri = Prepared { v0: a, v1: b, v2: c };
        let hit = match ray.kz {
            0 => tri_hit::<0>(&tri, &ray, t_best),
            1 => tri_hit::<1>(&tri, &ray, t_best),
            _ => tri_hit::<2>(&tri, &ray, t_best),
        };
        if let Some((t, u, v)) = hit {
            t_best = t;
            best = Some(Hit { t, triangle: i as u32, u, v });
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn quad_wall(x: f32) -> Vec<[Vec3; 3]> {
        let a = Vec3::new(x, -1.0, -1.0);
        let b = Vec3::new(x, 1.0, -1.0);
        let c = Vec3::new(x, 1.0, 1.0);
        let d = Vec3::new(x, -1.0, 1.0);
        vec![[a, b, c], [a, c, d]]
    }

    #[test]
    fn nearest_wall_wins_and_occlusion_respects_t_max() {
        let mut tris = quad_wall(5.0);
        tris.extend(quad_wall(2.0));
        let bvh = Bvh::build(&tris);
        let hit = bvh.intersect(Vec3::ZERO, Vec3::X, f32::INFINITY).expect("hit");
        assert!((hit.t - 2.0).abs() < 1e-6);
        assert!(hit.triangle >= 2);
        assert!(bvh.occluded(Vec3::ZERO, Vec3::X, 2.5));
        assert!(!bvh.occluded(Vec3::ZERO, Vec3::X, 1.5));
        assert!(bvh.intersect(Vec3::ZERO, -Vec3::X, f32::INFINITY).is_none());
    }

    #[test]
    fn non_finite_rays_hit_nothing() {
        let bvh = Bvh::build(&sphere_cloud(7));
        let bad = [
            Vec3::NAN,
            Vec3::new(1.0, f32::NAN, 0.0),
            Vec3::INFINITY,
            Vec3::new(0.0, f32::NEG_INFINITY, 1.0),
        ];
        for v in bad {
            assert!(bvh.intersect(Vec3::ZERO, v, 1e30).is_none(), "direction {v}");
            assert!(bvh.intersect(v, Vec3::X, 1e30).is_none(), "origin {v}");
            assert!(!bvh.occluded(Vec3::ZERO, v, 1e30), "direction {v}");
        }
        assert!(bvh.intersect(Vec3::ZERO, Vec3::ZERO, 1e30).is_none());
    }

    #[test]
    fn empty_and_degenerate_input() {
        let bvh = Bvh::build(&[]);
        assert!(bvh.is_empty());
        assert!(bvh.intersect(Vec3::ZERO, Vec3::X, 1.0).is_none());
        let nan = Vec3::splat(f32::NAN);
        let bvh = Bvh::build(&[[nan, Vec3::X, Vec3::Y], [Vec3::ZERO, Vec3::X, Vec3::X]]);
        assert_eq!(bvh.len(), 1);
        assert!(bvh.intersect(Vec3::new(0.5, -1.0, 0.0), Vec3::Y, 10.0).is_none());
    }

    proptest! {
        #[test]
        fn rays_through_a_shared_edge_never_leak(
            k in 0.0f32..1.0,
            (ox, oy, oz) in (-30.0f32..30.0, -30.0f32..30.0, 1.0f32..30.0),
        ) {
            // A flat fan of triangles sharing edges; aim at points on the seams.
            let c = Vec3::new(0.3, -0.2, 0.0);
            let ring: Vec<Vec3> = (0..7)
                .map(|i| {
                    let a = i as f32 * std::f32::consts::TAU / 7.0;
                    Vec3::new(a.cos() * 3.0, a.sin() * 3.0, 0.0)
                })
                .collect();
            let tris: Vec<[Vec3; 3]> = (0..7).map(|i| [c, ring[i], ring[(i + 1) % 7]]).collect();
            let bvh = Bvh::build(&tris);
            let o = Vec3::new(ox, oy, oz);
            for r in &ring {
                let target = c + (*r - c) * k;
                prop_assert!(bvh.intersect(o, target - o, 10.0).is_some(), "leak at {target}");
            }
        }
    }

    fn tri_strategy() -> impl Strategy<Value = [Vec3; 3]> {
        let p = || (-10.0f32..10.0, -10.0f32..10.0, -10.0f32..10.0).prop_map(|(x, y, z)| Vec3::new(x, y, z));
        (p(), p(), p()).prop_map(|(a, d1, d2)| [a, a + d1 * 0.3, a + d2 * 0.3])
    }

    proptest! {
        #[test]
        fn overlapping_lists_exactly_the_overlapping_boxes(
            tris in prop::collection::vec(tri_strategy(), 1..200),
            (cx, cy, cz, r) in (-10.0f32..10.0, -10.0f32..10.0, -10.0f32..10.0, 0.0f32..4.0),
        ) {
            let bvh = Bvh::build(&tris);
            let (lo, hi) = (Vec3::new(cx, cy, cz) - r, Vec3::new(cx, cy, cz) + r);
            let mut all = Vec::new();
            bvh.overlapping(lo, hi, |t| {
                all.push(t);
                true
            });
            // Stopping early gives a prefix of the same order.
            let mut first = Vec::new();
            bvh.overlapping(lo, hi, |t| {
                first.push(t);
                first.len() < 3
            });
            prop_assert_eq!(&first[..], &all[..all.len().min(3)]);
            let mut got = all;
            got.sort_unstable();
            let want: Vec<u32> = (0..tris.len() as u32)
                .filter(|&i| {
                    let t = tris[i as usize];
                    let (a, b) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
                    a.cmple(hi).all() && b.cmpge(lo).all()
                })
                .collect();
            prop_assert_eq!(got, want);
        }

        #[test]
        fn groups_partition_the_triangles(
            tris in prop::collection::vec(tri_strategy(), 1..300),
            max in 1usize..40,
        ) {
            let bvh = Bvh::build(&tris);
            let mut all = Vec::new();
            let mut sizes = Vec::new();
            bvh.groups(max, |g| {
                sizes.push(g.len());
                all.extend_from_slice(g);
            });
            prop_assert!(sizes.iter().all(|&n| n > 0 && n <= max.max(MAX_LEAF)), "{sizes:?}");
            all.sort_unstable();
            prop_assert_eq!(all, (0..tris.len() as u32).collect::<Vec<_>>());
        }

        #[test]
        fn agrees_with_brute_force(
            tris in prop::collection::vec(tri_strategy(), 1..300),
            rays in prop::collection::vec(
                ((-12.0f32..12.0, -12.0f32..12.0, -12.0f32..12.0), (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0)),
                1..40,
            ),
        ) {
            let bvh = Bvh::build(&tris);
            for ((ox, oy, oz), (dx, dy, dz)) in rays {
                let o = Vec3::new(ox, oy, oz);
                let d = Vec3::new(dx, dy, dz);
                let a = bvh.intersect(o, d, 1e30);
                let b = intersect_brute(&tris, o, d, 1e30);
                prop_assert!(same_hit(&tris, o, d, a, b), "bvh {a:?} brute {b:?}");
                prop_assert_eq!(bvh.occluded(o, d, 1e30), b.is_some());
            }
        }
    }

    proptest! {
        #[test]
        fn packets_agree_with_one_ray_at_a_time(
            tris in prop::collection::vec(tri_strategy(), 1..300),
            (ox, oy, oz) in (-12.0f32..12.0, -12.0f32..12.0, -12.0f32..12.0),
            (bx, by, bz) in (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0),
            spread in prop_oneof![Just(0.0f32), 0.0f32..0.05, 0.0f32..2.0],
            jitter in prop::collection::vec((-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0), 1..90),
            t_max in prop_oneof![Just(1e30f32), 0.1f32..20.0],
        ) {
            // A cone of rays from one origin (coherent at small spreads), every fifth ray from
            // elsewhere: packets of mixed axes and octants, partial and full packets, more than
            // one 64-ray chunk.
            let bvh = Bvh::build(&tris);
            let o = Vec3::new(ox, oy, oz);
            let base = Vec3::new(bx, by, bz);
            let rays: Vec<(Vec3, Vec3)> = jitter
                .iter()
                .enumerate()
                .map(|(i, &(x, y, z))| {
                    let j = Vec3::new(x, y, z);
                    if i % 5 == 4 { (o + j * 10.0, Vec3::new(j.y, j.z, j.x)) } else { (o, base + j * spread) }
                })
                .collect();
            let mut hits = vec![None; 3];
            bvh.intersect_many(&rays, t_max, &mut hits);
            prop_assert_eq!(hits.len(), rays.len());
            for (&(o, d), &a) in rays.iter().zip(&hits) {
                let b = bvh.intersect(o, d, t_max);
                prop_assert!(same_hit(&tris, o, d, a, b), "packet {a:?} one ray {b:?}");
            }
        }
    }

    #[test]
    fn pixel_tiles_of_a_sphere_cloud_equal_brute_force() {
        let tris = sphere_cloud(7);
        let bvh = Bvh::build(&tris);
        let mut rng = unit_rng(11);
        let mut hits = Vec::new();
        for view in 0..8 {
            let eye = Vec3::new(rng(), rng(), rng()) * 50.0 - 25.0;
            let forward = (Vec3::new(rng(), rng(), rng()) * 2.0 - 1.0).normalize_or(Vec3::X);
            let right = forward.cross(Vec3::Z).normalize_or(Vec3::Y);
            let up = right.cross(forward);
            // 4×4 tiles of a 40×40 image at 60°, and some rays that are no rays at all.
            for tile in 0..100 {
                let (tx, ty) = (tile % 10 * 4, tile / 10 * 4);
                let mut rays: Vec<(Vec3, Vec3)> = (0..16)
                    .map(|k| {
                        let u = ((tx + k % 4) as f32 / 20.0 - 1.0) * 0.577;
                        let v = ((ty + k / 4) as f32 / 20.0 - 1.0) * 0.577;
                        (eye, forward + right * u + up * v)
                    })
                    .collect();
                if tile == view {
                    rays[3].1 = Vec3::ZERO;
                    rays[7].1 = Vec3::NAN;
                    rays[9].0 = Vec3::NAN;
                }
                bvh.intersect_many(&rays, 1e30, &mut hits);
                for (&(o, d), &a) in rays.iter().zip(&hits) {
                    let b = intersect_brute(&tris, o, d, 1e30);
                    assert!(same_hit(&tris, o, d, a, b), "view {view} tile {tile}: packet {a:?} brute {b:?}");
                }
            }
        }
    }

    #[test]
    fn packets_on_trees_without_quads() {
        for tris in [Vec::new(), quad_wall(2.0)] {
            let bvh = Bvh::build(&tris);
            let rays =
                [(Vec3::ZERO, Vec3::X), (Vec3::ZERO, Vec3::new(1.0, 0.1, 0.1)), (Vec3::ZERO, -Vec3::X)];
            let mut hits = Vec::new();
            bvh.intersect_many(&rays, f32::INFINITY, &mut hits);
            let one: Vec<Option<Hit>> =
                rays.iter().map(|&(o, d)| bvh.intersect(o, d, f32::INFINITY)).collect();
            assert_eq!(hits, one);
            assert_eq!(hits[0].is_some(), !tris.is_empty());
        }
    }

    /// The tree's hit is the brute-force hit exactly (`t`, triangle, `u`, `v`), or a different
    /// triangle hit at exactly the same `t` (a tie, which the traversal order decides).
    fn same_hit(tris: &[[Vec3; 3]], o: Vec3, d: Vec3, a: Option<Hit>, b: Option<Hit>) -> bool {
        match (a, b) {
            (None, None) => true,
            (Some(a), Some(b)) if a.t.to_bits() == b.t.to_bits() => {
                a == b
                    || intersect_brute(&tris[a.triangle as usize..=a.triangle as usize], o, d, 1e30)
                        .is_some_and(|h| h.t.to_bits() == a.t.to_bits() && h.u == a.u && h.v == a.v)
            }
            _ => false,
        }
    }

    /// Random closed spheres (shared edges) scattered in a box, rays from inside and outside in
    /// every direction, some with a finite `t_max`.
    /// 60 tessellated spheres (120 triangles each) in a 40-unit box.
    fn sphere_cloud(seed: u64) -> Vec<[Vec3; 3]> {
        let mut rng = unit_rng(seed);
        let mut tris = Vec::new();
        for _ in 0..60 {
            let c = Vec3::new(rng(), rng(), rng()) * 40.0 - 20.0;
            let r = 0.5 + 2.0 * rng();
            let (nu, nv) = (10, 6);
            let p = |i: usize, j: usize| {
                let (a, b) = (
                    i as f32 * std::f32::consts::TAU / nu as f32,
                    j as f32 * std::f32::consts::PI / nv as f32,
                );
                c + r * Vec3::new(a.cos() * b.sin(), a.sin() * b.sin(), b.cos())
            };
            for i in 0..nu {
                for j in 0..nv {
                    let (a, b, cc, dd) = (p(i, j), p((i + 1) % nu, j), p((i + 1) % nu, j + 1), p(i, j + 1));
                    tris.push([a, b, cc]);
                    tris.push([a, cc, dd]);
                }
            }
        }
        tris
    }

    #[test]
    fn sphere_cloud_hits_equal_brute_force() {
        let tris = sphere_cloud(7);
        let mut rng = unit_rng(8);
        let bvh = Bvh::build(&tris);
        for k in 0..3000 {
            let o = Vec3::new(rng(), rng(), rng()) * 50.0 - 25.0;
            let d = Vec3::new(rng(), rng(), rng()) * 2.0 - 1.0;
            let t_max = if k % 3 == 0 { 20.0 * rng() } else { 1e30 };
            let (a, b) = (bvh.intersect(o, d, t_max), intersect_brute(&tris, o, d, t_max));
            assert!(same_hit(&tris, o, d, a, b), "ray {k}: bvh {a:?} brute {b:?}");
            assert_eq!(bvh.occluded(o, d, t_max), b.is_some(), "ray {k}");
        }
    }

    /// Triangles nested in each other at shrinking sizes make a binary tree nearly as deep as the
    /// triangles are many, so the 4-wide traversal needs the deep stack; it still finds every hit.
    #[test]
    fn deep_tree_uses_the_deep_stack_and_agrees_with_brute_force() {
        const NESTED: i32 = 300;
        const RATIO: f32 = 0.8;
        let tris: Vec<[Vec3; 3]> = (0..NESTED)
            .map(|k| {
                let s = RATIO.powi(k);
                [Vec3::new(s, 0.0, 0.0), Vec3::new(s, s, 0.0), Vec3::new(s, 0.0, s)]
            })
            .collect();
        let bvh = Bvh::build(&tris);
        assert!(bvh.deep, "expected a tree needing more than {STACK_SMALL} stack entries");
        let mut rng = unit_rng(3);
        for k in 0..2000 {
            let s = RATIO.powi(k % NESTED);
            let o = Vec3::new(-1.0, s * rng() * 0.5, s * rng() * 0.5);
            let d = Vec3::new(1.0, 0.01 * (rng() - 0.5), 0.01 * (rng() - 0.5));
            let (a, b) = (bvh.intersect(o, d, 1e30), intersect_brute(&tris, o, d, 1e30));
            assert!(same_hit(&tris, o, d, a, b), "ray {k}: bvh {a:?} brute {b:?}");
        }
    }

    /// Floats in `[0, 1)` from a seeded [`SplitMix64`](sightline_job::rng::SplitMix64).
    fn unit_rng(seed: u64) -> impl FnMut() -> f32 {
        let mut r = sightline_job::rng::SplitMix64::new(seed);
        move || r.unit_f32()
    }
}
