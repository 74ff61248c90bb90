//! The runtime's validated, immutable level: [`World`].
//!
//! # Validation
//! [`World::new`] checks a level in two steps, so no rule is stated twice:
//! 1. [`sightline_formats::slvl::validate`], the rules every reader of a level relies on and the
//!    same check `.slvl` reading runs: every index in range, every value finite, no node cycle,
//!    clusters and PVS rows consistent, GVS lumps in range ([`LoadError::Invalid`]).
//! 2. The runtime's own rules (module `tree`): a world model, unit plane normals, a world tree
//!    that is a tree at most [`MAX_TREE_DEPTH`] deep, open leaves with non-inverted bounds, and
//!    fewer than 2³¹ faces.
//!
//! # Conventions
//! - Geometry conventions are those of [`sightline_formats::level`] (a node's `children[0]` is the
//!   **front** of its plane, `normal · p - dist >= 0`, so a point exactly on a plane goes front;
//!   units are Quake map units in `f32`).
//! - Only the world model's tree (`models[0].head_node`) is walked. Node boxes are **recomputed** at
//!   load as the union of the non-solid leaves below them, so culling never depends on the bounds
//!   a compiler wrote; leaf boxes are taken from the level.
//! - After [`World::new`] succeeds every index is proven in range, so no query can panic.
//!
//! # Layers
//! A world is assembled from lower modules that know nothing of it: `tree` (the level's
//! tables), `locate` and `layout` (the point-location and walk copies of the tree),
//! [`crate::pvs`] (rows and per-cluster trees) and [`crate::gvs_cells`]. Queries and backends
//! ([`crate::walk`], [`crate::trace`], [`crate::backend`]) sit above it; a new backend needs no
//! change here.

use glam::Vec3A;
use sightline_formats::level::{Contents, Level};
use sightline_formats::slvl;
use std::sync::atomic::{AtomicU64, Ordering};

use crate::draw::DrawData;
use crate::error::LoadError;
use crate::gvs_cells::GvsCells;
use crate::layout::{NO_ELEMENT, SHARED_FACE, WalkTree};
use crate::locate::LocateTree;
use crate::pvs::{Bitset, ClusterTrees, PhsRows, PvsRows};
use crate::tree::{Csr, Tree};

pub use crate::tree::{LeafId, MAX_TREE_DEPTH};

/// An interior node of the world tree, as [`World::node`] gives it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Node {
    /// Unit plane normal.
    pub normal: Vec3A,
    /// Plane distance: a point `p` is in front when `normal · p - dist >= 0`.
    pub dist: f32,
    /// Front and back child: a node index when `>= 0`, else leaf `!child`.
    pub children: [i32; 2],
    /// The union of the boxes of the non-solid leaves below (recomputed at load).
    pub bounds: Bounds,
}

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

/// A validated level laid out for queries. Immutable and `Send + Sync`: share it with `Arc`.
#[derive(Debug)]
pub struct World {
    id: u64,
    /// The level's tables ([`crate::tree`]).
    tree: Tree,
    /// The compressed PVS rows.
    rows: PvsRows,
    /// The PHS rows (computed from `rows` on first use).
    phs: PhsRows,
    /// Faces, textures and models for drawing ([`crate::draw`]).
    draw: DrawData,
    /// The tree for point location ([`crate::locate`]).
    locate: LocateTree,
    /// The walk's layout of the tree ([`crate::layout`]).
    walk: WalkTree,
    /// The walk-tree elements of the world-tree leaves of each cluster, for marking without a
    /// lookup.
    cluster_elems: Csr,
    /// Marks (generation 1) of every open leaf (no vis, or the eye in solid).
    all_marks: Vec<u32>,
    /// Every cluster's PVS as a pruned tree, when they fit [`crate::pvs::CLUSTER_TREE_BUDGET`].
    cluster_trees: Option<ClusterTrees>,
    /// The level's GVS cells, when it has any.
    gvs: Option<GvsCells>,
}

static NEXT_ID: AtomicU64 = AtomicU64::new(1);

impl World {
    /// Validate `level` (see the module docs) and lay it out for queries; the PHS is computed
    /// from the PVS on first use.
    pub fn new(level: &Level) -> Result<Self, LoadError> {
        Self::with_phs(level, None)
    }

    /// [`World::new`] with the PHS rows a file stores for itself (Quake 2's visibility lump;
    /// `None`: computed from the PVS on first use).
    pub(crate) fn with_phs(level: &Level, phs: Option<PvsRows>) -> Result<Self, LoadError> {
        slvl::validate(level).map_err(LoadError::Invalid)?;
        let tree = Tree::new(level)?;
        if tree.num_faces > (SHARED_FACE - 1) as usize {
            return Err(LoadError::Index {
                what: "face count",
                owner: "level",
                index: 0,
                value: tree.num_faces as u64,
            });
        }
        let walk = WalkTree::build(&tree);
        let cluster_elems =
            tree.cluster_leaves.map(|l| walk.leaf_bit.get(l as usize).copied().unwrap_or(NO_ELEMENT));
        let mut all_marks = vec![0; walk.mark_slots()];
        for &l in &tree.open_leaves {
            walk.mark_leaf(&mut all_marks, 1, l);
        }
        let rows = PvsRows::new(level);
        let cluster_trees = ClusterTrees::build(&walk, &rows, &cluster_elems);
        let gvs = if level.gvs_cells.is_empty() { None } else { Some(GvsCells::from_level(level)?) };
        Ok(Self {
            id: NEXT_ID.fetch_add(1, Ordering::Relaxed),
            locate: LocateTree::build(&tree),
            draw: DrawData::new(level, &tree)?,
            tree,
            rows,
            phs: PhsRows::stored(phs),
            walk,
            cluster_elems,
            all_marks,
            cluster_trees,
            gvs,
        })
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

    /// The GVS cells of the level, when it has any (answered by [`crate::backend::gvs`]).
    pub fn gvs_cells(&self) -> Option<&GvsCells> {
        self.gvs.as_ref()
    }

    /// The leaf holding `p`: descend from the root, going to the front child when
    /// `normal · p - dist >= 0` (a point exactly on a plane is in front). Never fails: a
    /// non-finite point ends in some leaf (NaN compares as "front").
    #[inline]
    pub fn leaf_at(&self, p: impl Into<Vec3A>) -> LeafId {
        self.locate.leaf_at(p.into())
    }

    /// Decode the PVS row of `cluster` into `out` (resized to [`World::num_clusters`] bits; bit `j`
    /// set means cluster `j` is potentially visible). Without vis data, or for a cluster out of
    /// range (the eye in solid), every bit is set, as Quake does.
    pub fn decode_pvs(&self, cluster: u32, out: &mut Bitset) {
        self.rows.decode(cluster, out);
    }

    /// Decode the PHS row of `cluster` into `out`, as [`World::decode_pvs`] does for the PVS: bit
    /// `j` set means a sound in cluster `j` may be heard from `cluster`. A Quake 2 file's own PHS
    /// rows are used as they are (the Quake 2 path of [`crate::load::load_bytes`]); otherwise row `c` is the union of
    /// the PVS rows of every cluster in `c`'s PVS (Quake's `SV_CalcPHS`), computed once, on the
    /// first call (about clusters × visible clusters × row words of work and a transient
    /// `clusters² / 8`-byte matrix: 61 ms for the 3,669 clusters of LibreQuake's E1M1).
    pub fn decode_phs(&self, cluster: u32, out: &mut Bitset) {
        self.phs.decode(&self.rows, cluster, out);
    }

    /// Faces, textures and brush models for drawing; face indices are those of
    /// [`crate::Visible::faces`] and [`World::leaf_faces`] (see [`crate::draw`]).
    pub fn draw(&self) -> &DrawData {
        &self.draw
    }

    /// Number of leaves.
    pub fn num_leaves(&self) -> usize {
        self.tree.leaves.len()
    }

    /// Number of interior nodes.
    pub fn num_nodes(&self) -> usize {
        self.tree.nodes.len()
    }

    /// Number of faces leaves may refer to.
    pub fn num_faces(&self) -> usize {
        self.tree.num_faces
    }

    /// Number of portals.
    pub fn num_portals(&self) -> usize {
        self.tree.portals.len()
    }

    /// Number of PVS clusters.
    pub fn num_clusters(&self) -> u32 {
        self.tree.num_clusters
    }

    /// True when the level carries a PVS (otherwise every leaf is potentially visible).
    pub fn has_vis(&self) -> bool {
        self.rows.has_vis()
    }

    /// Depth of the world tree (a lone leaf has depth 0).
    pub fn depth(&self) -> usize {
        self.tree.depth
    }

    /// The non-solid leaves of the world tree, in index order.
    pub fn open_leaves(&self) -> &[LeafId] {
        &self.tree.open_leaves
    }

    /// Bounds of a leaf; `None` when `leaf` is out of range.
    pub fn leaf_bounds(&self, leaf: LeafId) -> Option<Bounds> {
        self.tree.leaves.get(leaf as usize).map(|l| Bounds { center: l.center, extent: l.extent })
    }

    /// What fills a leaf; `None` when `leaf` is out of range.
    pub fn leaf_contents(&self, leaf: LeafId) -> Option<Contents> {
        self.tree.leaves.get(leaf as usize).map(|l| l.contents)
    }

    /// Cluster of a leaf (`None` for out of range leaves and leaves without a cluster).
    pub fn leaf_cluster(&self, leaf: LeafId) -> Option<u32> {
        self.tree.leaves.get(leaf as usize).and_then(|l| u32::try_from(l.cluster).ok())
    }

    /// Face indices a leaf draws (empty when `leaf` is out of range).
    pub fn leaf_faces(&self, leaf: LeafId) -> &[u32] {
        self.tree
            .leaves
            .get(leaf as usize)
            .and_then(|l| {
                let start = l.first_face as usize;
                self.tree.leaf_faces.get(start..start + l.num_faces as usize)
            })
            .unwrap_or(&[])
    }

    /// Portals touching a leaf, as indices usable with [`World::portal`].
    pub fn leaf_portals(&self, leaf: LeafId) -> &[u32] {
        self.tree.leaf_portals.get(leaf as usize)
    }

    /// A portal's two leaves (front of its plane first) and polygon; `None` when out of range.
    pub fn portal(&self, portal: u32) -> Option<([LeafId; 2], &[Vec3A])> {
        let p = self.tree.portals.get(portal as usize)?;
        let start = p.first_vertex as usize;
        let pts = self.tree.portal_vertices.get(start..start + p.num_vertices as usize)?;
        Some((p.leaves, pts))
    }

    /// Leaves of a cluster that belong to the world tree.
    pub fn cluster_leaves(&self, cluster: u32) -> &[LeafId] {
        self.tree.cluster_leaves.get(cluster as usize)
    }

    /// The root of the world tree, encoded as a node's children are ([`Node::children`]).
    pub fn root(&self) -> i32 {
        self.tree.root
    }

    /// Interior node `node` (`0..num_nodes`) of the world tree, with its box recomputed at load;
    /// for reference walks in tests and tools ([`World::root`] starts them). `None` when out of
    /// range.
    pub fn node(&self, node: u32) -> Option<Node> {
        let n = self.tree.nodes.get(node as usize)?;
        Some(Node {
            normal: n.normal,
            dist: n.dist,
            children: n.children,
            bounds: Bounds { center: n.center, extent: n.extent },
        })
    }

    // Crate-internal views for the layers above (queries and backends); all read-only.

    /// Identity of this world, for scratches to notice a change of world.
    pub(crate) fn id(&self) -> u64 {
        self.id
    }

    /// The level's tables.
    pub(crate) fn tree(&self) -> &Tree {
        &self.tree
    }

    /// The walk layout.
    pub(crate) fn walk_tree(&self) -> &WalkTree {
        &self.walk
    }

    /// Marks of every open leaf, generation 1, over [`World::walk_tree`].
    pub(crate) fn all_marks(&self) -> &[u32] {
        &self.all_marks
    }

    /// The per-cluster PVS trees, when kept.
    pub(crate) fn cluster_trees(&self) -> Option<&ClusterTrees> {
        self.cluster_trees.as_ref()
    }

    /// Walk-tree elements of [`World::cluster_leaves`].
    pub(crate) fn cluster_elements(&self, cluster: u32) -> &[u32] {
        self.cluster_elems.get(cluster as usize)
    }
}
