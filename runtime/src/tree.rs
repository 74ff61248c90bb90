//! The level's tables as the queries read them: the world tree ([`WNode`], [`WLeaf`]), the portals
//! ([`WPortal`]) and the per-leaf and per-cluster lists ([`Csr`]), built by [`Tree::new`].
//!
//! # Conventions
//! - Same geometry conventions as [`sightline_formats::level`]: a node's `children[0]` is the
//!   **front** of its plane (`normal · p - dist >= 0`, so a point exactly on a plane goes front),
//!   a child `c < 0` is leaf `-(c + 1)` (`!c`), units are Quake map units in `f32`.
//! - Plane normals are unit length (a stored normal within 1e-3 of unit is renormalised).
//! - Only the world model's tree (`models[0].head_node`) is walked. It is a tree: every node is
//!   reached once, every non-solid leaf at most once (solid leaves may be shared, as Quake's leaf
//!   0), and it is at most [`MAX_TREE_DEPTH`] deep.
//! - Node boxes are **recomputed** as the union of the non-solid leaves below them (solid leaves
//!   are never drawn), so a node box always contains its children: culling never depends on the
//!   bounds a compiler wrote. A node with no open leaf below has an empty box (negative extent).
//!   Leaf boxes are taken from the level (zero for solid leaves).
//!
//! [`Tree::new`] takes a level that passed [`sightline_formats::slvl::validate`] (the rules every
//! reader of a level shares) and checks only the rules above, which are the runtime's own. It
//! still reads the level with `get`, so a level that skipped validation fails rather than panics.
//! This module sits below [`crate::world`]: the point-location and walk layouts are built from a
//! [`Tree`], and the world owns one.

use glam::Vec3A;
use sightline_formats::level::{Contents, Level};

use crate::error::LoadError;

/// Index of a leaf in a world (the same index as in the source [`Level`]).
pub type LeafId = u32;

/// "No parent": the root, or a leaf outside the world tree.
pub(crate) const NO_PARENT: u32 = u32::MAX;

/// Deepest world tree accepted (Quake trees are 20–60 deep); bounds recursion in queries.
pub const MAX_TREE_DEPTH: usize = 1024;

/// An interior node, one cache line: plane inline, children encoded as in the level.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
pub(crate) struct WNode {
    pub normal: Vec3A,
    pub center: Vec3A,
    pub extent: Vec3A,
    pub dist: f32,
    pub children: [i32; 2],
    pub parent: u32,
}

/// A leaf with its box and the slice of face indices it draws.
#[derive(Debug, Clone, Copy)]
pub(crate) struct WLeaf {
    pub center: Vec3A,
    pub extent: Vec3A,
    pub contents: Contents,
    pub cluster: i32,
    pub first_face: u32,
    pub num_faces: u32,
    pub parent: u32,
    /// Reached from the world root (only set for non-solid leaves).
    pub in_tree: bool,
}

/// A portal polygon between two leaves; its plane's normal points into `leaves[0]`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct WPortal {
    pub normal: Vec3A,
    pub dist: f32,
    pub leaves: [u32; 2],
    pub first_vertex: u32,
    pub num_vertices: u32,
    /// A sphere holding every corner: centre and radius (widened by a relative 1e-5 and 1e-3
    /// units, so a test against it never contradicts a test of the corners).
    pub center: Vec3A,
    pub radius: f32,
}

/// A list of `u32` per index, stored flat (compressed sparse rows): list `i` is
/// `items[start[i]..start[i + 1]]`.
#[derive(Debug, Clone, Default)]
pub(crate) struct Csr {
    start: Vec<u32>,
    items: Vec<u32>,
}

impl Csr {
    /// `lists` lists from `(list, item)` entries; each list keeps its entries' order. Entries of
    /// a list `>= lists` are dropped.
    pub fn build(lists: usize, entries: &[(u32, u32)]) -> Self {
        let entries = entries.iter().filter(|&&(l, _)| (l as usize) < lists);
        let mut counts = vec![0u32; lists + 1];
        for &(l, _) in entries.clone() {
            counts[l as usize + 1] += 1;
        }
        for l in 0..lists {
            counts[l + 1] += counts[l];
        }
        let start = counts.clone();
        let mut items = vec![0u32; counts[lists] as usize];
        for &(l, item) in entries {
            let slot = &mut counts[l as usize];
            items[*slot as usize] = item;
            *slot += 1;
        }
        Self { start, items }
    }

    /// List `i` (empty out of range).
    #[inline]
    pub fn get(&self, i: usize) -> &[u32] {
        match (self.start.get(i), self.start.get(i + 1)) {
            (Some(&a), Some(&b)) => self.items.get(a as usize..b as usize).unwrap_or(&[]),
            _ => &[],
        }
    }

    /// The same lists with every item replaced by `f(item)`.
    pub fn map(&self, f: impl Fn(u32) -> u32) -> Self {
        Self { start: self.start.clone(), items: self.items.iter().map(|&i| f(i)).collect() }
    }
}

/// The level's tables for queries (see the module docs).
#[derive(Debug, Clone)]
pub(crate) struct Tree {
    /// The world root as a child code.
    pub root: i32,
    /// Depth of the world tree (a lone leaf has depth 0).
    pub depth: usize,
    pub nodes: Vec<WNode>,
    pub leaves: Vec<WLeaf>,
    pub leaf_faces: Vec<u32>,
    /// Faces in the level (what leaf face entries index).
    pub num_faces: usize,
    pub portals: Vec<WPortal>,
    pub portal_vertices: Vec<Vec3A>,
    /// Portals touching each leaf.
    pub leaf_portals: Csr,
    pub num_clusters: u32,
    /// World-tree leaves of each cluster.
    pub cluster_leaves: Csr,
    /// Non-solid leaves of the world tree (what "everything visible" means), ascending.
    pub open_leaves: Vec<u32>,
}

fn vec(a: [f32; 3]) -> Vec3A {
    Vec3A::from_array(a)
}

#[derive(Debug, Clone, Copy)]
enum Child {
    Node(usize),
    Leaf(usize),
}

fn decode_child(child: i32, nodes: usize, leaves: usize) -> Option<Child> {
    if child >= 0 {
        let n = child as usize;
        (n < nodes).then_some(Child::Node(n))
    } else {
        let l = (-(child as i64) - 1) as usize;
        (l < leaves).then_some(Child::Leaf(l))
    }
}

impl Tree {
    /// Lay out `level`, which passed [`sightline_formats::slvl::validate`], checking the
    /// runtime's own rules (see the module docs).
    pub fn new(level: &Level) -> Result<Self, LoadError> {
        let planes = unit_planes(level)?;
        let root = level.models.first().ok_or(LoadError::NoWorldModel)?.head_node;

        let mut leaves = Vec::with_capacity(level.leaves.len());
        for (i, leaf) in level.leaves.iter().enumerate() {
            let open = leaf.contents.is_open();
            let (mins, maxs) = (vec(leaf.mins), vec(leaf.maxs));
            if open && !(mins.is_finite() && maxs.is_finite() && mins.cmple(maxs).all()) {
                return Err(LoadError::BadBounds { owner: "leaf", index: i });
            }
            let (mins, maxs) = if open { (mins, maxs) } else { (Vec3A::ZERO, Vec3A::ZERO) };
            leaves.push(WLeaf {
                center: (mins + maxs) * 0.5,
                extent: (maxs - mins) * 0.5,
                contents: leaf.contents,
                cluster: leaf.cluster,
                first_face: leaf.first_face,
                num_faces: leaf.num_faces,
                parent: NO_PARENT,
                in_tree: false,
            });
        }

        let mut nodes = Vec::with_capacity(level.nodes.len());
        for (i, node) in level.nodes.iter().enumerate() {
            let &(normal, dist) = planes.get(node.plane as usize).ok_or(LoadError::Index {
                what: "plane",
                owner: "node",
                index: i,
                value: u64::from(node.plane),
            })?;
            nodes.push(WNode {
                normal,
                center: Vec3A::ZERO,
                extent: Vec3A::splat(-1.0),
                dist,
                children: node.children,
                parent: NO_PARENT,
            });
        }
        let depth = link_tree(root, &mut nodes, &mut leaves)?;
        compute_node_bounds(root, &mut nodes, &leaves);

        let (portals, portal_vertices) = build_portals(level, &planes)?;
        let mut touching = Vec::with_capacity(2 * portals.len());
        for (i, p) in portals.iter().enumerate() {
            touching.push((p.leaves[0], i as u32));
            if p.leaves[1] != p.leaves[0] {
                touching.push((p.leaves[1], i as u32));
            }
        }
        let leaf_portals = Csr::build(leaves.len(), &touching);

        let open_leaves: Vec<u32> =
            leaves.iter().enumerate().filter(|(_, l)| l.in_tree).map(|(i, _)| i as u32).collect();
        let in_clusters: Vec<(u32, u32)> = open_leaves
            .iter()
            .filter_map(|&i| {
                let c = leaves.get(i as usize)?.cluster;
                Some((u32::try_from(c).ok()?, i))
            })
            .collect();
        let cluster_leaves = Csr::build(level.num_clusters as usize, &in_clusters);

        Ok(Self {
            root,
            depth,
            nodes,
            leaves,
            leaf_faces: level.leaf_faces.clone(),
            num_faces: level.faces.len(),
            portals,
            portal_vertices,
            leaf_portals,
            num_clusters: level.num_clusters,
            cluster_leaves,
            open_leaves,
        })
    }
}

/// Unit normals and distances of every plane, or the first plane whose normal is not within 1e-3
/// of unit length.
fn unit_planes(level: &Level) -> Result<Vec<(Vec3A, f32)>, LoadError> {
    level
        .planes
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let n = vec(p.normal);
            let len = n.length();
            if !len.is_finite() || (len - 1.0).abs() > 1e-3 || !p.dist.is_finite() {
                return Err(LoadError::BadPlane { index: i });
            }
            Ok((n / len, p.dist / len))
        })
        .collect()
}

/// Set parent links from the root, proving the world tree is a tree of bounded depth; returns
/// its depth.
fn link_tree(root: i32, nodes: &mut [WNode], leaves: &mut [WLeaf]) -> Result<usize, LoadError> {
    let Some(root_child) = decode_child(root, nodes.len(), leaves.len()) else {
        return Err(LoadError::Index { what: "head node", owner: "model", index: 0, value: root as u64 });
    };
    let mut seen = vec![false; nodes.len()];
    let mut stack = vec![(root_child, NO_PARENT, 0usize)];
    let mut depth = 0;
    while let Some((child, parent, d)) = stack.pop() {
        if d > MAX_TREE_DEPTH {
            return Err(LoadError::TooDeep { max: MAX_TREE_DEPTH });
        }
        depth = depth.max(d);
        match child {
            Child::Leaf(l) => {
                let leaf = &mut leaves[l];
                if leaf.contents.is_open() {
                    if leaf.in_tree {
                        return Err(LoadError::SharedLeaf { index: l });
                    }
                    leaf.in_tree = true;
                    leaf.parent = parent;
                }
            }
            Child::Node(n) => {
                if std::mem::replace(&mut seen[n], true) {
                    return Err(LoadError::NotATree { index: n });
                }
                nodes[n].parent = parent;
                for c in nodes[n].children {
                    let Some(c) = decode_child(c, nodes.len(), leaves.len()) else {
                        return Err(LoadError::Index {
                            what: "child",
                            owner: "node",
                            index: n,
                            value: c as u64,
                        });
                    };
                    stack.push((c, n as u32, d + 1));
                }
            }
        }
    }
    Ok(depth)
}

/// Node boxes as the union of the non-solid leaves below (post-order, iterative). A node with no
/// open leaf below gets an empty box (negative extent), which every frustum rejects.
fn compute_node_bounds(root: i32, nodes: &mut [WNode], leaves: &[WLeaf]) {
    let mut order = Vec::with_capacity(nodes.len());
    let mut stack = vec![root];
    while let Some(c) = stack.pop() {
        if let Some(node) = usize::try_from(c).ok().and_then(|n| nodes.get(n)) {
            order.push(c as usize);
            stack.extend(node.children);
        }
    }
    for &n in order.iter().rev() {
        let mut mins = Vec3A::splat(f32::INFINITY);
        let mut maxs = Vec3A::splat(f32::NEG_INFINITY);
        for c in nodes[n].children {
            let (cmin, cmax) = if c >= 0 {
                let child = &nodes[c as usize];
                if child.extent.x < 0.0 {
                    continue;
                }
                (child.center - child.extent, child.center + child.extent)
            } else {
                let leaf = &leaves[(-(c as i64) - 1) as usize];
                if !leaf.contents.is_open() {
                    continue;
                }
                (leaf.center - leaf.extent, leaf.center + leaf.extent)
            };
            mins = mins.min(cmin);
            maxs = maxs.max(cmax);
        }
        let node = &mut nodes[n];
        if mins.cmple(maxs).all() {
            node.center = (mins + maxs) * 0.5;
            node.extent = (maxs - mins) * 0.5;
        } else {
            node.center = Vec3A::ZERO;
            node.extent = Vec3A::splat(-1.0);
        }
    }
}

/// The portals with their unit planes and bounding spheres, and their corners.
fn build_portals(level: &Level, planes: &[(Vec3A, f32)]) -> Result<(Vec<WPortal>, Vec<Vec3A>), LoadError> {
    let mut portals = Vec::with_capacity(level.portals.len());
    let mut vertices = Vec::new();
    for (i, p) in level.portals.iter().enumerate() {
        let index_err = |what, value| LoadError::Index { what, owner: "portal", index: i, value };
        let &(normal, dist) = planes.get(p.plane as usize).ok_or(index_err("plane", u64::from(p.plane)))?;
        if let Some(&l) = p.leaves.iter().find(|&&l| l as usize >= level.leaves.len()) {
            return Err(index_err("leaf", u64::from(l)));
        }
        let start = p.first_vertex as usize;
        let end = u64::from(p.first_vertex) + u64::from(p.num_vertices);
        let pts = usize::try_from(end)
            .ok()
            .and_then(|end| level.vertices.get(start..end))
            .filter(|pts| !pts.is_empty())
            .ok_or(index_err("vertices", end))?;
        let center = pts.iter().map(|&v| vec(v)).sum::<Vec3A>() / pts.len() as f32;
        let radius = pts.iter().map(|&v| vec(v).distance(center)).fold(0.0, f32::max);
        portals.push(WPortal {
            center,
            radius: radius * (1.0 + 1e-5) + 1e-3 + center.abs().max_element() * 1e-6,
            normal,
            dist,
            leaves: p.leaves,
            first_vertex: vertices.len() as u32,
            num_vertices: pts.len() as u32,
        });
        vertices.extend(pts.iter().map(|&v| vec(v)));
    }
    Ok((portals, vertices))
}
