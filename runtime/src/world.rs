//! The runtime's validated, immutable level: [`World`].
//!
//! # Conventions
//! - Same geometry conventions as [`sightline_formats::level`]: a node's `children[0]` is the
//!   **front** of its plane (`normal · p - dist >= 0`, so a point exactly on a plane goes front),
//!   a child `c < 0` is leaf `-(c + 1)`, units are Quake map units in `f32`.
//! - Only the world model's tree (`models[0].head_node`) is walked. It must be a tree: every node is
//!   reached once, every non-solid leaf at most once (solid leaves may be shared, as Quake's leaf 0).
//! - Node boxes are **recomputed** at load as the union of the non-solid leaves below them (solid
//!   leaves are never drawn), so a node box always contains its children: culling never depends on
//!   the bounds a compiler wrote. Leaf boxes are taken from the level.
//! - After [`World::new`] succeeds every index is proven in range, so no query can panic.

use glam::Vec3A;
use sightline_formats::level::{Contents, Level};
use sightline_formats::rle;
use std::sync::atomic::{AtomicU64, Ordering};

use crate::backend::gvs::Gvs;
use crate::error::LoadError;
use crate::layout::WalkTree;
use crate::locate::LocateTree;
use crate::pvs::ClusterTrees;

/// Index of a leaf in [`World`] (the same index as in the source [`Level`]).
pub type LeafId = u32;

/// "No parent": the root, or a leaf outside the world tree.
pub(crate) const NO_PARENT: u32 = u32::MAX;

/// Deepest world tree accepted (Quake trees are 20–60 deep); bounds recursion in queries.
pub const MAX_TREE_DEPTH: usize = 1024;

/// A box as centre and half-size, the form the frustum test wants.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    /// Centre.
    pub center: Vec3A,
    /// Half-size (non-negative).
    pub extent: Vec3A,
}

impl Bounds {
    /// From corners (`mins <= maxs`).
    pub fn from_min_max(mins: Vec3A, maxs: Vec3A) -> Self {
        Self { center: (mins + maxs) * 0.5, extent: (maxs - mins) * 0.5 }
    }

    /// Smallest corner.
    pub fn mins(&self) -> Vec3A {
        self.center - self.extent
    }

    /// Largest corner.
    pub fn maxs(&self) -> Vec3A {
        self.center + self.extent
    }

    /// True when `p` is inside or within `eps` of the box.
    pub fn contains(&self, p: Vec3A, eps: f32) -> bool {
        ((p - self.center).abs() - self.extent).cmple(Vec3A::splat(eps)).all()
    }
}

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

/// A validated level laid out for queries. Immutable and `Send + Sync`: share it with `Arc`.
#[derive(Debug)]
pub struct World {
    pub(crate) id: u64,
    pub(crate) root: i32,
    pub(crate) depth: usize,
    pub(crate) nodes: Vec<WNode>,
    pub(crate) leaves: Vec<WLeaf>,
    pub(crate) leaf_faces: Vec<u32>,
    pub(crate) num_faces: usize,
    pub(crate) portals: Vec<WPortal>,
    pub(crate) portal_vertices: Vec<Vec3A>,
    /// CSR: portals of leaf `l` are `leaf_portals[leaf_portal_start[l]..leaf_portal_start[l + 1]]`.
    pub(crate) leaf_portal_start: Vec<u32>,
    pub(crate) leaf_portals: Vec<u32>,
    pub(crate) num_clusters: u32,
    pub(crate) row_bytes: usize,
    pub(crate) pvs_offsets: Vec<u32>,
    pub(crate) pvs_data: Vec<u8>,
    /// CSR: world-tree leaves of cluster `c`.
    pub(crate) cluster_leaf_start: Vec<u32>,
    pub(crate) cluster_leaves: Vec<u32>,
    /// The walk-tree element of each entry of `cluster_leaves`, for marking without a lookup.
    pub(crate) cluster_elems: Vec<u32>,
    /// Non-solid leaves of the world tree (what "everything visible" means).
    pub(crate) open_leaves: Vec<u32>,
    /// The tree for point location ([`crate::locate`]).
    pub(crate) locate: LocateTree,
    /// The walk's layout of the tree ([`crate::layout`]).
    pub(crate) tree: WalkTree,
    /// Marks (generation 1) of every open leaf (no vis, or the eye in solid).
    pub(crate) all_marks: Vec<u32>,
    /// Every cluster's PVS as a pruned tree, when they fit [`crate::pvs::CLUSTER_TREE_BUDGET`].
    pub(crate) cluster_trees: Option<ClusterTrees>,
    /// The GVS backend's data, when the level has GVS cells.
    pub(crate) gvs: Option<Gvs>,
}

static NEXT_ID: AtomicU64 = AtomicU64::new(1);

fn vec(a: [f32; 3]) -> Vec3A {
    Vec3A::from_array(a)
}

fn finite(a: [f32; 3]) -> bool {
    a.iter().all(|v| v.is_finite())
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

#[derive(Debug, Clone, Copy)]
enum Child {
    Node(usize),
    Leaf(usize),
}

impl World {
    /// Validate `level` and lay it out for queries.
    pub fn new(level: &Level) -> Result<Self, LoadError> {
        let planes = validate_planes(level)?;
        let root_child = level.models.first().ok_or(LoadError::NoWorldModel)?.head_node;

        // Leaves.
        let mut leaves = Vec::with_capacity(level.leaves.len());
        for (i, leaf) in level.leaves.iter().enumerate() {
            let end = u64::from(leaf.first_face) + u64::from(leaf.num_faces);
            if end > level.leaf_faces.len() as u64 {
                return Err(LoadError::Index { what: "leaf faces", owner: "leaf", index: i, value: end });
            }
            if leaf.cluster < -1 || (leaf.cluster >= 0 && leaf.cluster as u32 >= level.num_clusters) {
                return Err(LoadError::Index {
                    what: "cluster",
                    owner: "leaf",
                    index: i,
                    value: leaf.cluster as u64,
                });
            }
            let open = leaf.contents.is_open();
            if open
                && (!finite(leaf.mins) || !finite(leaf.maxs) || vec(leaf.mins).cmpgt(vec(leaf.maxs)).any())
            {
                return Err(LoadError::BadBounds { owner: "leaf", index: i });
            }
            let (mins, maxs) =
                if open { (vec(leaf.mins), vec(leaf.maxs)) } else { (Vec3A::ZERO, Vec3A::ZERO) };
            let b = Bounds::from_min_max(mins, maxs);
            leaves.push(WLeaf {
                center: b.center,
                extent: b.extent,
                contents: leaf.contents,
                cluster: leaf.cluster,
                first_face: leaf.first_face,
                num_faces: leaf.num_faces,
                parent: NO_PARENT,
                in_tree: false,
            });
        }
        let num_faces = level.faces.len();
        if let Some(pos) = level.leaf_faces.iter().position(|&f| f as usize >= num_faces) {
            return Err(LoadError::Index {
                what: "face",
                owner: "leaf face list entry",
                index: pos,
                value: u64::from(level.leaf_faces[pos]),
            });
        }

        // Nodes.
        let mut nodes = Vec::with_capacity(level.nodes.len());
        for (i, node) in level.nodes.iter().enumerate() {
            let plane = planes.get(node.plane as usize).ok_or(LoadError::Index {
                what: "plane",
                owner: "node",
                index: i,
                value: u64::from(node.plane),
            })?;
            for c in node.children {
                if decode_child(c, level.nodes.len(), level.leaves.len()).is_none() {
                    return Err(LoadError::Index { what: "child", owner: "node", index: i, value: c as u64 });
                }
            }
            nodes.push(WNode {
                normal: plane.0,
                center: Vec3A::ZERO,
                extent: Vec3A::splat(-1.0),
                dist: plane.1,
                children: node.children,
                parent: NO_PARENT,
            });
        }

        let depth = link_tree(root_child, &mut nodes, &mut leaves)?;
        compute_node_bounds(root_child, &mut nodes, &leaves);

        let (leaf_portal_start, leaf_portals, portals, portal_vertices) = build_portals(level, leaves.len())?;
        let (row_bytes, pvs_offsets) = validate_pvs(level)?;

        // Clusters → world-tree leaves, and the open leaves of the world tree.
        let clusters = level.num_clusters as usize;
        let in_tree = |l: &WLeaf| l.in_tree;
        let mut counts = vec![0u32; clusters + 1];
        let mut open_leaves = Vec::new();
        for (i, l) in leaves.iter().enumerate() {
            if in_tree(l) {
                open_leaves.push(i as u32);
                if l.cluster >= 0 {
                    counts[l.cluster as usize + 1] += 1;
                }
            }
        }
        for c in 0..clusters {
            counts[c + 1] += counts[c];
        }
        let cluster_leaf_start = counts.clone();
        let mut cluster_leaves = vec![0u32; open_leaves.len()];
        for &i in &open_leaves {
            let c = leaves[i as usize].cluster;
            if c >= 0 {
                let slot = &mut counts[c as usize];
                cluster_leaves[*slot as usize] = i;
                *slot += 1;
            }
        }
        cluster_leaves.truncate(cluster_leaf_start[clusters] as usize);

        if num_faces > (crate::layout::SHARED_FACE - 1) as usize {
            return Err(LoadError::Index {
                what: "face count",
                owner: "level",
                index: 0,
                value: num_faces as u64,
            });
        }
        let tree = WalkTree::build(root_child, &nodes, &leaves, &level.leaf_faces, num_faces);
        let cluster_elems = cluster_leaves
            .iter()
            .map(|&l| tree.leaf_bit.get(l as usize).copied().unwrap_or(crate::layout::NO_ELEMENT))
            .collect();
        let mut all_marks = vec![0; tree.mark_slots()];
        for &l in &open_leaves {
            tree.mark_leaf(&mut all_marks, 1, l);
        }
        let gvs = if level.gvs_cells.is_empty() { None } else { Some(Gvs::from_level(level)?) };
        let mut world = Self {
            locate: LocateTree::build(root_child, &nodes),
            tree,
            all_marks,
            cluster_trees: None,
            gvs,
            id: NEXT_ID.fetch_add(1, Ordering::Relaxed),
            root: root_child,
            depth,
            nodes,
            leaves,
            leaf_faces: level.leaf_faces.clone(),
            num_faces,
            portals,
            portal_vertices,
            leaf_portal_start,
            leaf_portals,
            num_clusters: level.num_clusters,
            row_bytes,
            pvs_offsets,
            pvs_data: if level.has_vis() { level.pvs_data.clone() } else { Vec::new() },
            cluster_leaf_start,
            cluster_leaves,
            cluster_elems,
            open_leaves,
        };
        world.cluster_trees = ClusterTrees::build(&world);
        Ok(world)
    }

    /// True when every cluster's PVS is kept as a pruned tree (levels whose trees fit
    /// [`crate::pvs::CLUSTER_TREE_BUDGET`]); otherwise the PVS backend decodes a row and marks
    /// the tree when the eye changes cluster.
    pub fn pvs_trees_in_memory(&self) -> bool {
        self.cluster_trees.is_some()
    }

    /// Drop the per-cluster PVS trees to save their memory; the PVS backend then decodes a row
    /// and marks the tree when the eye changes cluster (Quake's scheme). Answers do not change.
    pub fn drop_pvs_trees(&mut self) {
        self.cluster_trees = None;
    }

    /// The GVS cells of the level, when it has any (see [`crate::backend::gvs`]).
    pub fn gvs(&self) -> Option<&Gvs> {
        self.gvs.as_ref()
    }

    /// Number of leaves.
    pub fn num_leaves(&self) -> usize {
        self.leaves.len()
    }

    /// Number of interior nodes.
    pub fn num_nodes(&self) -> usize {
        self.nodes.len()
    }

    /// Number of faces leaves may refer to.
    pub fn num_faces(&self) -> usize {
        self.num_faces
    }

    /// Number of portals.
    pub fn num_portals(&self) -> usize {
        self.portals.len()
    }

    /// Number of PVS clusters.
    pub fn num_clusters(&self) -> u32 {
        self.num_clusters
    }

    /// True when the level carries a PVS (otherwise every leaf is potentially visible).
    pub fn has_vis(&self) -> bool {
        !self.pvs_offsets.is_empty()
    }

    /// Depth of the world tree (a lone leaf has depth 0).
    pub fn depth(&self) -> usize {
        self.depth
    }

    /// The non-solid leaves of the world tree, in index order.
    pub fn open_leaves(&self) -> &[LeafId] {
        &self.open_leaves
    }

    /// Bounds of a leaf; `None` when `leaf` is out of range.
    pub fn leaf_bounds(&self, leaf: LeafId) -> Option<Bounds> {
        self.leaves.get(leaf as usize).map(|l| Bounds { center: l.center, extent: l.extent })
    }

    /// What fills a leaf; `None` when `leaf` is out of range.
    pub fn leaf_contents(&self, leaf: LeafId) -> Option<Contents> {
        self.leaves.get(leaf as usize).map(|l| l.contents)
    }

    /// Cluster of a leaf (`None` for out of range leaves and leaves without a cluster).
    pub fn leaf_cluster(&self, leaf: LeafId) -> Option<u32> {
        self.leaves.get(leaf as usize).and_then(|l| u32::try_from(l.cluster).ok())
    }

    /// Face indices a leaf draws (empty when `leaf` is out of range).
    pub fn leaf_faces(&self, leaf: LeafId) -> &[u32] {
        self.leaves
            .get(leaf as usize)
            .and_then(|l| {
                let start = l.first_face as usize;
                self.leaf_faces.get(start..start + l.num_faces as usize)
            })
            .unwrap_or(&[])
    }

    /// Portals touching a leaf, as indices usable with [`World::portal`].
    pub fn leaf_portals(&self, leaf: LeafId) -> &[u32] {
        let l = leaf as usize;
        match (self.leaf_portal_start.get(l), self.leaf_portal_start.get(l + 1)) {
            (Some(&a), Some(&b)) => self.leaf_portals.get(a as usize..b as usize).unwrap_or(&[]),
            _ => &[],
        }
    }

    /// A portal's two leaves (front of its plane first) and polygon; `None` when out of range.
    pub fn portal(&self, portal: u32) -> Option<([LeafId; 2], &[Vec3A])> {
        let p = self.portals.get(portal as usize)?;
        let start = p.first_vertex as usize;
        let pts = self.portal_vertices.get(start..start + p.num_vertices as usize)?;
        Some((p.leaves, pts))
    }

    /// Walk-tree elements of [`World::cluster_leaves`].
    pub(crate) fn cluster_elements(&self, cluster: u32) -> &[u32] {
        let c = cluster as usize;
        match (self.cluster_leaf_start.get(c), self.cluster_leaf_start.get(c + 1)) {
            (Some(&a), Some(&b)) => self.cluster_elems.get(a as usize..b as usize).unwrap_or(&[]),
            _ => &[],
        }
    }

    /// Leaves of a cluster that belong to the world tree.
    pub fn cluster_leaves(&self, cluster: u32) -> &[LeafId] {
        let c = cluster as usize;
        match (self.cluster_leaf_start.get(c), self.cluster_leaf_start.get(c + 1)) {
            (Some(&a), Some(&b)) => self.cluster_leaves.get(a as usize..b as usize).unwrap_or(&[]),
            _ => &[],
        }
    }

    /// The interior node planes from the root to `leaf`, each with the side the leaf is on
    /// (`true` = front). Empty for a leaf outside the world tree. For tests and tools.
    pub fn leaf_path(&self, leaf: LeafId) -> Vec<(Vec3A, f32, bool)> {
        let mut path = Vec::new();
        let Some(l) = self.leaves.get(leaf as usize) else { return path };
        let mut child = -(leaf as i64) - 1;
        let mut parent = l.parent;
        while let Some(node) = self.nodes.get(parent as usize) {
            path.push((node.normal, node.dist, i64::from(node.children[0]) == child));
            child = i64::from(parent);
            parent = node.parent;
        }
        path.reverse();
        path
    }
}

/// Unit normals and distances of every plane, or the first bad plane.
fn validate_planes(level: &Level) -> Result<Vec<(Vec3A, f32)>, LoadError> {
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
                    // Checked in `World::new`; a bad child here would be a logic error.
                    let Some(c) = decode_child(c, nodes.len(), leaves.len()) else {
                        return Err(LoadError::NotATree { index: n });
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

type PortalTables = (Vec<u32>, Vec<u32>, Vec<WPortal>, Vec<Vec3A>);

/// Validate portals and build the leaf → portals adjacency.
fn build_portals(level: &Level, num_leaves: usize) -> Result<PortalTables, LoadError> {
    let mut portals = Vec::with_capacity(level.portals.len());
    let mut vertices = Vec::new();
    let mut counts = vec![0u32; num_leaves + 1];
    for (i, p) in level.portals.iter().enumerate() {
        let plane = level.planes.get(p.plane as usize).ok_or(LoadError::Index {
            what: "plane",
            owner: "portal",
            index: i,
            value: u64::from(p.plane),
        })?;
        for l in p.leaves {
            if l as usize >= num_leaves {
                return Err(LoadError::Index {
                    what: "leaf",
                    owner: "portal",
                    index: i,
                    value: u64::from(l),
                });
            }
        }
        let start = p.first_vertex as usize;
        let end = start as u64 + u64::from(p.num_vertices);
        let pts = level.vertices.get(start..end.min(usize::MAX as u64) as usize).ok_or(LoadError::Index {
            what: "vertices",
            owner: "portal",
            index: i,
            value: end,
        })?;
        if pts.len() < 3 || pts.iter().any(|v| !finite(*v)) {
            return Err(LoadError::BadPortal { index: i });
        }
        let n = vec(plane.normal);
        let len = n.length();
        let center = pts.iter().map(|&v| vec(v)).sum::<Vec3A>() / pts.len() as f32;
        let radius = pts.iter().map(|&v| vec(v).distance(center)).fold(0.0, f32::max);
        portals.push(WPortal {
            center,
            radius: radius * (1.0 + 1e-5) + 1e-3 + center.abs().max_element() * 1e-6,
            normal: n / len,
            dist: plane.dist / len,
            leaves: p.leaves,
            first_vertex: vertices.len() as u32,
            num_vertices: pts.len() as u32,
        });
        vertices.extend(pts.iter().map(|&v| vec(v)));
        counts[p.leaves[0] as usize + 1] += 1;
        if p.leaves[1] != p.leaves[0] {
            counts[p.leaves[1] as usize + 1] += 1;
        }
    }
    for l in 0..num_leaves {
        counts[l + 1] += counts[l];
    }
    let start = counts.clone();
    let mut list = vec![0u32; counts[num_leaves] as usize];
    for (i, p) in portals.iter().enumerate() {
        for (k, &l) in p.leaves.iter().enumerate() {
            if k == 1 && p.leaves[1] == p.leaves[0] {
                continue;
            }
            let slot = &mut counts[l as usize];
            list[*slot as usize] = i as u32;
            *slot += 1;
        }
    }
    Ok((start, list, portals, vertices))
}

/// Check every PVS row decodes inside the data; returns the row length and the offsets.
fn validate_pvs(level: &Level) -> Result<(usize, Vec<u32>), LoadError> {
    let row_bytes = level.row_bytes();
    if level.num_clusters as usize > level.leaves.len() {
        return Err(LoadError::TooManyClusters { clusters: level.num_clusters, leaves: level.leaves.len() });
    }
    if !level.has_vis() {
        return Ok((row_bytes, Vec::new()));
    }
    if level.pvs_offsets.len() != level.num_clusters as usize {
        return Err(LoadError::PvsRows { rows: level.pvs_offsets.len(), clusters: level.num_clusters });
    }
    let mut row = vec![0u8; row_bytes];
    for (c, &off) in level.pvs_offsets.iter().enumerate() {
        let data = level.pvs_data.get(off as usize..).ok_or(LoadError::Index {
            what: "PVS data offset",
            owner: "cluster",
            index: c,
            value: u64::from(off),
        })?;
        rle::decode_row(data, row_bytes, &mut row)
            .map_err(|source| LoadError::PvsRow { cluster: c, source })?;
    }
    Ok((row_bytes, level.pvs_offsets.clone()))
}
