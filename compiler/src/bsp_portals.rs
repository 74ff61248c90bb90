//! Portals of a compiled Quake BSP (BSP29, BSP2, BSP2-RMQ, and Half-Life's BSP30, whose tree
//! records and contents codes are BSP29's) rebuilt from its world tree alone, so a
//! map whose source and `.prt` are lost can be vised again.
//!
//! # How
//! Model 0's hull-0 node tree is copied into the builder's `bsp::Tree` (pre-order, front child first) and
//! portalized by `portals::build_with`, the compiler's own qbsp-style builder: a huge
//! winding on each node's plane, clipped by the ancestors' planes and a box, split down the
//! subtree to the leaves. The box holds every vertex and the world model's and root node's bounds
//! (those that are usable: a compiler may store `±inf`), grown by [`BOX_MARGIN`] (qbsp's own
//! margin) and kept within [`WORLD_LIMIT`]. Every portal between two
//! cells whose contents let sight through becomes a portal line between their clusters (their
//! vis leaves, unless clusters are kept, below).
//!
//! # Conventions
//! - Vis leaves are the BSP's own: leaf `i` in `1..=visleafs` is vis leaf `i - 1`, so the PVS can
//!   be written back into the same file. Every non-solid leaf the world tree reaches must be one
//!   (qbsp numbers them so); one that is not, or a node or non-solid leaf reached twice, is an
//!   error: such a cell has no row, or is not convex.
//! - Clusters: where the file already holds a PVS, a node whose open leaves all share one stored
//!   row (one `visofs`, a row that does not see everything) and see alike (one contents class
//!   under the liquid rule), and lie on both of its sides (the lowest node holding them all), has
//!   its whole convex region made one cell and its vis leaves one cluster (PRT2), as qbsp makes
//!   its detail clusters: solid leaves inside stop blocking, which only adds sight, and every leaf
//!   of the cluster gets the row of the whole region, a superset of its own. Without detail,
//!   leaves rarely share rows and the file stays PRT1; with detail, qbsp's clusters come back and
//!   vis runs as fast as on its `.prt`. [`BspPortalOptions::no_clusters`] turns this off.
//! - Contents decide sight as Quake's tools do (`sight_passes_with`): solid (-2) blocks; sky
//!   (-6) joins only sky; water (-3), slime (-4) and lava (-5) join empty space and each other
//!   unless liquids are opaque ([`LiquidSight::Opaque`], qbsp without `-transwater`: then only
//!   leaves of equal contents are joined). A contents code Quake does not define counts as empty:
//!   an unknown cell rounds toward visible.
//! - Planes are the file's, normalised (a stored normal that is not unit length keeps its sides),
//!   deduplicated and snapped by [`PlaneSet`] within its identity epsilons (a normal within 1e-6
//!   of an axis, a distance within 1e-4 of an integer): far inside the [`ON_EPSILON`] band that
//!   clipping keeps. A node whose plane has no normal is an error.
//! - Windings are clockwise seen from the portal's first leaf (the node's front), as the compiler
//!   writes them. Pieces too small to keep three corners [`ON_EPSILON`] apart are kept with their
//!   unmerged corners (the builder's `TinyPieces::Keep`): a portal is never dropped for being small.
//! - A tree deeper than [`MAX_DEPTH`] is refused (the node graph is acyclic once
//!   [`sightline_formats::bsp::read`] accepts it; the walks are iterative and visit each node
//!   once).

use std::collections::HashMap;

use glam::DVec3;
use sightline_formats::bsp::{Bsp, bounds, lump};
use sightline_formats::geom::{ON_EPSILON, WORLD_LIMIT};
use sightline_formats::prt::{PortalFile, PrtFormat, PrtPortal};
use sightline_formats::rle;
use sightline_formats::{Aabb, Contents, Plane, PlaneSet};

use crate::bsp::{Tree, TreeNode};
use crate::contents::{LiquidSight, sight_passes_with};
use crate::portals::{self, TinyPieces};

/// How far the portal box reaches beyond the world's bounds (qbsp's `SIDESPACE`).
pub const BOX_MARGIN: f64 = 24.0;
/// Deepest world tree accepted (as the runtime's limit).
pub const MAX_DEPTH: usize = 1024;

/// Why portals could not be rebuilt from a BSP's tree. Offsets are bytes in the file.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum BspPortalsError {
    /// The file has no models, so no world tree.
    #[error("lump models is empty: no world tree to rebuild portals from")]
    NoWorld,
    /// A node of the world tree cannot be portalized.
    #[error("byte {offset}: node {node}: {detail}")]
    Node {
        /// The node record's offset.
        offset: usize,
        /// Node index.
        node: usize,
        /// What is wrong.
        detail: String,
    },
    /// A leaf of the world tree cannot be given a vis leaf.
    #[error("byte {offset}: leaf {leaf} (contents {contents}): {detail}")]
    Leaf {
        /// The leaf record's offset.
        offset: usize,
        /// Leaf index.
        leaf: usize,
        /// Its contents code.
        contents: i32,
        /// What is wrong.
        detail: String,
    },
}

/// What [`build`] does with liquids and with leaves that share a row.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BspPortalOptions {
    /// Whether liquid surfaces let sight through.
    pub liquids: LiquidSight,
    /// Vis every leaf on its own, even where the file's own PVS gives a subtree's open leaves one
    /// shared row (see the module docs): tighter, and slower on maps with detail.
    pub no_clusters: bool,
}

/// Counts of a rebuild.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct BspPortalStats {
    /// Nodes of the world tree.
    pub nodes: usize,
    /// Non-solid leaves the world tree reaches.
    pub open_leaves: usize,
    /// Vis leaves (`visleafs` of the world model).
    pub vis_leaves: usize,
    /// Clusters (equal to `vis_leaves` when no subtree was kept together).
    pub clusters: usize,
    /// Portals written.
    pub portals: usize,
    /// Portals between a liquid and another contents left out because liquids are opaque.
    pub liquid_portals_dropped: usize,
    /// Portals written whose corners lie within [`ON_EPSILON`] of a line or point.
    pub tiny_portals_kept: usize,
}

/// A rebuilt portal file and its counts.
#[derive(Debug, Clone)]
pub struct BspPortals {
    /// PRT1 over the BSP's vis leaves, or PRT2 when subtrees were kept together as clusters.
    pub prt: PortalFile,
    /// Counts.
    pub stats: BspPortalStats,
}

/// The world tree copied for the builder.
struct WorldTree {
    tree: Tree,
    planes: PlaneSet,
    /// For each tree index, a BSP leaf it holds (`usize::MAX` for nodes): the one whose contents
    /// stand for the cell.
    bsp_leaf: Vec<usize>,
    /// (tree leaf, BSP leaf) for every vis-range BSP leaf a tree leaf holds, in tree order.
    members: Vec<(usize, usize)>,
    stats: BspPortalStats,
}

/// The sight rule for a BSP contents code (unknown codes count as empty).
fn sight_contents(code: i32) -> Contents {
    Contents::from_code(code).unwrap_or(Contents::Empty)
}

/// Rebuilds the portals of `bsp`'s world tree as `opts` says.
pub fn build(bsp: &Bsp, opts: BspPortalOptions) -> Result<BspPortals, BspPortalsError> {
    let world = copy_tree(bsp, opts)?;
    let bounds = portal_box(bsp);
    let graph = portals::build_with(&world.tree, &world.planes, &bounds, TinyPieces::Keep);
    let visleafs = bsp.visleafs();
    let (leaf_clusters, cluster_of_tree) = clusters(visleafs, world.tree.nodes.len(), &world.members);
    let num_clusters = leaf_clusters.iter().max().map_or(0, |&c| c as usize + 1);
    let mut stats = BspPortalStats { vis_leaves: visleafs, clusters: num_clusters, ..world.stats };
    let mut prt = PortalFile {
        format: if num_clusters == visleafs { PrtFormat::Prt1 } else { PrtFormat::Prt2 },
        num_leaves: visleafs as u32,
        num_clusters: num_clusters as u32,
        portals: Vec::new(),
        leaf_clusters,
    };
    for p in &graph.portals {
        // Box portals (no plane index) lead outside; no cell lies there.
        if p.plane_index.is_none() || p.winding.is_empty() {
            continue;
        }
        let leaves = p.nodes.map(|n| world.bsp_leaf.get(n as usize).copied().unwrap_or(usize::MAX));
        let contents = leaves.map(|l| sight_contents(bsp.leaves.get(l).map_or(-2, |leaf| leaf.contents)));
        if !sight_passes_with(contents[0], contents[1], opts.liquids) {
            stats.liquid_portals_dropped +=
                usize::from(sight_passes_with(contents[0], contents[1], LiquidSight::Transparent));
            continue;
        }
        // Both cells are open, so each holds an open vis leaf (`copy_tree` checked) and has a
        // cluster.
        let ends = p.nodes.map(|n| cluster_of_tree.get(n as usize).copied().unwrap_or(u32::MAX));
        if ends.contains(&u32::MAX) {
            continue;
        }
        stats.tiny_portals_kept += usize::from(p.winding.cleaned(ON_EPSILON).is_empty());
        prt.portals.push(PrtPortal { leaves: ends, winding: p.winding.clone() });
    }
    stats.portals = prt.portals.len();
    Ok(BspPortals { prt, stats })
}

/// The cluster of every vis leaf and of every tree leaf holding one: the vis leaves one tree leaf
/// holds form one cluster, a vis leaf no tree leaf holds its own; clusters are numbered in the
/// order of their first vis leaf.
fn clusters(visleafs: usize, tree_len: usize, members: &[(usize, usize)]) -> (Vec<u32>, Vec<u32>) {
    let mut holder = vec![usize::MAX; visleafs];
    for &(t, l) in members {
        if let Some(h) = l.checked_sub(1).and_then(|j| holder.get_mut(j))
            && *h == usize::MAX
        {
            *h = t;
        }
    }
    let mut of_tree = vec![u32::MAX; tree_len];
    let mut next = 0u32;
    let mut fresh = || {
        next += 1;
        next - 1
    };
    let leaf_clusters = holder
        .iter()
        .map(|&t| match of_tree.get_mut(t) {
            None => fresh(),
            Some(c) => {
                if *c == u32::MAX {
                    *c = fresh();
                }
                *c
            }
        })
        .collect();
    (leaf_clusters, of_tree)
}

/// What the open leaves under a node have in common, for keeping a subtree together.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Class {
    /// No open leaf.
    Solid,
    /// Every open leaf sees alike (`sight`) and has the stored row at `visofs`; `count` of them,
    /// the first being `first`.
    Shared { sight: i32, visofs: i32, first: usize, count: usize },
    /// Anything else.
    Mixed,
}

impl Class {
    fn join(self, other: Class) -> Class {
        match (self, other) {
            (Class::Solid, c) | (c, Class::Solid) => c,
            (
                Class::Shared { sight, visofs, first, count },
                Class::Shared { sight: s2, visofs: v2, count: c2, .. },
            ) if sight == s2 && visofs == v2 => Class::Shared { sight, visofs, first, count: count + c2 },
            _ => Class::Mixed,
        }
    }
}

/// Walks model 0's hull-0 tree once, checking what [`build`] needs (see the module docs), and
/// classifies every node it reaches (index by node) for keeping subtrees together.
fn survey(bsp: &Bsp, opts: BspPortalOptions) -> Result<(Vec<Class>, BspPortalStats), BspPortalsError> {
    let model = bsp.models.first().ok_or(BspPortalsError::NoWorld)?;
    let visleafs = bsp.visleafs();
    let node_at = |n: usize| bsp.lumps[lump::NODES].offset + n * bsp.version.node_bytes();
    let leaf_at = |l: usize| bsp.lumps[lump::LEAVES].offset + l * bsp.version.leaf_bytes();
    let mut class = vec![Class::Solid; bsp.nodes.len()];
    let mut node_seen = vec![false; bsp.nodes.len()];
    let mut leaf_seen = vec![false; bsp.leaves.len()];
    let mut stats = BspPortalStats::default();
    let rows = !bsp.visdata.is_empty() && !opts.no_clusters;
    // Whether the stored row at each `visofs` sees fewer than every vis leaf (a row that sees
    // everything says nothing about clusters: an unvised file may share one such row).
    let mut partial: HashMap<i32, bool> = HashMap::new();
    // (child code, depth, children done): a node is pushed again to be classified after them.
    let mut stack: Vec<(i32, usize, bool)> = vec![(model.head_nodes[0], 0, false)];
    let mut leaf_class = |l: usize| -> Class {
        let leaf = &bsp.leaves[l];
        let c = sight_contents(leaf.contents);
        if c == Contents::Solid {
            return Class::Solid;
        }
        let sight = match opts.liquids {
            LiquidSight::Transparent => i32::from(c == Contents::Sky),
            LiquidSight::Opaque => c.code(),
        };
        let partial = rows
            && leaf.visofs >= 0
            && *partial
                .entry(leaf.visofs)
                .or_insert_with(|| bsp.decode_leaf_pvs(l).is_ok_and(|row| rle::count_bits(&row) < visleafs));
        if partial { Class::Shared { sight, visofs: leaf.visofs, first: l, count: 1 } } else { Class::Mixed }
    };
    let mut child_class = |class: &[Class], code: i32| match usize::try_from(code) {
        Ok(n) => class.get(n).copied().unwrap_or(Class::Mixed),
        Err(_) => {
            let l = (-(i64::from(code) + 1)) as usize;
            if l < bsp.leaves.len() { leaf_class(l) } else { Class::Mixed }
        }
    };
    while let Some((code, depth, done)) = stack.pop() {
        match usize::try_from(code) {
            Ok(n) => {
                let node_err = |detail: String| BspPortalsError::Node { offset: node_at(n), node: n, detail };
                let Some(node) = bsp.nodes.get(n) else {
                    return Err(node_err(format!("no such node ({} in the file)", bsp.nodes.len())));
                };
                if done {
                    class[n] =
                        child_class(&class, node.children[0]).join(child_class(&class, node.children[1]));
                    continue;
                }
                if std::mem::replace(&mut node_seen[n], true) {
                    return Err(node_err(
                        "reached twice in the world tree (a cell that is not convex)".into(),
                    ));
                }
                if depth >= MAX_DEPTH {
                    return Err(node_err(format!("the world tree is deeper than {MAX_DEPTH}")));
                }
                stats.nodes += 1;
                stack.push((code, depth, true));
                stack.push((node.children[1], depth + 1, false));
                stack.push((node.children[0], depth + 1, false));
            }
            Err(_) => {
                let l = (-(i64::from(code) + 1)) as usize;
                let Some(leaf) = bsp.leaves.get(l) else {
                    return Err(BspPortalsError::Leaf {
                        offset: leaf_at(l),
                        leaf: l,
                        contents: 0,
                        detail: format!("no such leaf ({} in the file)", bsp.leaves.len()),
                    });
                };
                if sight_contents(leaf.contents) == Contents::Solid {
                    continue;
                }
                let leaf_err = |detail: String| BspPortalsError::Leaf {
                    offset: leaf_at(l),
                    leaf: l,
                    contents: leaf.contents,
                    detail,
                };
                if !(1..=visleafs).contains(&l) {
                    return Err(leaf_err(format!(
                        "an open leaf of the world tree without a PVS row (vis leaves are 1..={visleafs})"
                    )));
                }
                if std::mem::replace(&mut leaf_seen[l], true) {
                    return Err(leaf_err(
                        "reached twice in the world tree (a cell that is not convex)".into(),
                    ));
                }
                stats.open_leaves += 1;
            }
        }
    }
    Ok((class, stats))
}

/// Model 0's hull-0 tree as a [`Tree`] after [`survey`]: pre-order, front child first, with every
/// subtree of [`Class::Shared`] open leaves (two or more) made one leaf.
fn copy_tree(bsp: &Bsp, opts: BspPortalOptions) -> Result<WorldTree, BspPortalsError> {
    let (class, stats) = survey(bsp, opts)?;
    let model = bsp.models.first().ok_or(BspPortalsError::NoWorld)?;
    let visleafs = bsp.visleafs();
    let mut out = WorldTree {
        tree: Tree::default(),
        planes: PlaneSet::new(),
        bsp_leaf: Vec::new(),
        members: Vec::new(),
        stats,
    };
    let bounds = |mins: [f32; 3], maxs: [f32; 3]| Aabb::new(vec3(mins), vec3(maxs));
    let in_vis_range = |l: usize| (1..=visleafs).contains(&l);
    // (child code, the tree node and side to patch), popped front child first.
    let mut stack: Vec<(i32, Option<(usize, usize)>)> = vec![(model.head_nodes[0], None)];
    while let Some((code, parent)) = stack.pop() {
        let index = out.tree.nodes.len();
        if let Some((p, side)) = parent
            && let Some(TreeNode::Node { children, .. }) = out.tree.nodes.get_mut(p)
        {
            children[side] = index as u32;
        }
        // `survey` reached and checked every node and leaf below, so these lookups succeed.
        match usize::try_from(code) {
            Ok(n) => {
                let Some(node) = bsp.nodes.get(n) else { continue };
                // Kept together at the lowest node holding them all: open leaves on both sides.
                let solid_side = node.children.iter().any(|&c| match usize::try_from(c) {
                    Ok(m) => class.get(m) == Some(&Class::Solid),
                    Err(_) => bsp.leaves.get((-(i64::from(c) + 1)) as usize).is_none_or(|l| l.contents == -2),
                });
                if let (false, Some(Class::Shared { first, count: 2.., .. })) =
                    (solid_side, class.get(n).copied())
                {
                    let contents = sight_contents(bsp.leaves[first].contents);
                    out.tree.nodes.push(TreeNode::Leaf { contents, bounds: bounds(node.mins, node.maxs) });
                    out.bsp_leaf.push(first);
                    subtree_leaves(bsp, n, |l| {
                        if in_vis_range(l) {
                            out.members.push((index, l));
                        }
                    });
                    continue;
                }
                let stored = bsp.planes.get(node.plane as usize);
                let plane = stored.and_then(|p| Plane::new(vec3(p.normal), f64::from(p.dist)));
                let Some(plane) = plane else {
                    return Err(BspPortalsError::Node {
                        offset: bsp.lumps[lump::NODES].offset + n * bsp.version.node_bytes(),
                        node: n,
                        detail: format!("plane {} has no normal", node.plane),
                    });
                };
                let i = out.planes.insert(plane);
                // The tree takes even (positive-facing) plane indices: an odd one swaps the sides.
                let (plane, sides) = if i.is_multiple_of(2) { (i, [0, 1]) } else { (i ^ 1, [1, 0]) };
                out.tree.nodes.push(TreeNode::Node {
                    plane: plane as u32,
                    children: [0, 0],
                    bounds: bounds(node.mins, node.maxs),
                    detail: false,
                });
                out.bsp_leaf.push(usize::MAX);
                stack.push((node.children[1], Some((index, sides[1]))));
                stack.push((node.children[0], Some((index, sides[0]))));
            }
            Err(_) => {
                let l = (-(i64::from(code) + 1)) as usize;
                let Some(leaf) = bsp.leaves.get(l) else { continue };
                let contents = sight_contents(leaf.contents);
                out.tree.nodes.push(TreeNode::Leaf { contents, bounds: bounds(leaf.mins, leaf.maxs) });
                out.bsp_leaf.push(l);
                if contents != Contents::Solid && in_vis_range(l) {
                    out.members.push((index, l));
                }
            }
        }
    }
    Ok(out)
}

/// Calls `f` with every leaf under node `n` (front first; the tree is acyclic and checked).
fn subtree_leaves(bsp: &Bsp, n: usize, mut f: impl FnMut(usize)) {
    let mut stack = vec![n as i32];
    while let Some(code) = stack.pop() {
        match usize::try_from(code) {
            Ok(n) => {
                if let Some(node) = bsp.nodes.get(n) {
                    stack.push(node.children[1]);
                    stack.push(node.children[0]);
                }
            }
            Err(_) => f((-(i64::from(code) + 1)) as usize),
        }
    }
}

fn vec3(v: [f32; 3]) -> DVec3 {
    DVec3::new(f64::from(v[0]), f64::from(v[1]), f64::from(v[2]))
}

/// The box the portals start in: every vertex of the file, the world model's bounds and its root
/// node's (those that are [`bounds::usable`]), grown by [`BOX_MARGIN`], within [`WORLD_LIMIT`];
/// the whole world when the file has none of them.
fn portal_box(bsp: &Bsp) -> Aabb {
    let mut b = Aabb::EMPTY;
    let mut add = |mins: [f32; 3], maxs: [f32; 3]| {
        if bounds::usable(mins, maxs) {
            b.add_point(vec3(mins));
            b.add_point(vec3(maxs));
        }
    };
    bsp.vertices.iter().for_each(|&v| add(v, v));
    if let Some(m) = bsp.models.first() {
        add(m.mins, m.maxs);
        if let Some(root) = usize::try_from(m.head_nodes[0]).ok().and_then(|n| bsp.nodes.get(n)) {
            add(root.mins, root.maxs);
        }
    }
    let limit = DVec3::splat(WORLD_LIMIT);
    if b.is_empty() {
        return Aabb::new(-limit, limit);
    }
    let b = b.expanded(BOX_MARGIN);
    Aabb::new(b.mins.clamp(-limit, limit), b.maxs.clamp(-limit, limit))
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_formats::bsp::{BspLeaf, BspModel, BspNode, BspPlane, BspVersion, LumpEntry, NUM_LUMPS};

    fn leaf(contents: i32) -> BspLeaf {
        BspLeaf {
            contents,
            visofs: -1,
            mins: [0.0; 3],
            maxs: [0.0; 3],
            first_marksurface: 0,
            num_marksurfaces: 0,
            ambient: [0; 4],
        }
    }

    fn node(plane: u32, children: [i32; 2]) -> BspNode {
        BspNode { plane, children, mins: [-64.0; 3], maxs: [64.0; 3], first_face: 0, num_faces: 0 }
    }

    /// A 128-unit cube split by x = 0 (front: leaf 1) and then, behind it, by z = 0 (leaf 2 above,
    /// leaf 3 below); the six walls are the solid leaf 0 outside the box.
    fn three_cells(contents: [i32; 3]) -> Bsp {
        let axis = |normal: [f32; 3], dist: f32| BspPlane { normal, dist, kind: 0 };
        let mut planes = vec![axis([1.0, 0.0, 0.0], 0.0), axis([0.0, 0.0, 1.0], 0.0)];
        let mut nodes = vec![node(0, [1, 2])];
        // Node 1: x = 0 front side, bounded by six walls as nodes down to leaf 1.
        let walls = |planes: &mut Vec<BspPlane>, nodes: &mut Vec<BspNode>, open: i32| {
            let first = nodes.len();
            for (i, (n, d)) in [
                ([1.0, 0.0, 0.0], -64.0),
                ([-1.0, 0.0, 0.0], -64.0),
                ([0.0, 1.0, 0.0], -64.0),
                ([0.0, -1.0, 0.0], -64.0),
                ([0.0, 0.0, 1.0], -64.0),
                ([0.0, 0.0, -1.0], -64.0),
            ]
            .into_iter()
            .enumerate()
            {
                planes.push(axis(n, d));
                let next = if i == 5 { open } else { (first + i + 1) as i32 };
                nodes.push(node(planes.len() as u32 - 1, [next, -1]));
            }
            first as i32
        };
        let front = walls(&mut planes, &mut nodes, -2);
        nodes[0].children[0] = front;
        let back = nodes.len() as i32;
        nodes.push(node(1, [0, 0]));
        nodes[0].children[1] = back;
        let up = walls(&mut planes, &mut nodes, -3);
        let down = walls(&mut planes, &mut nodes, -4);
        nodes[back as usize].children = [up, down];
        let mut leaves = vec![leaf(-2)];
        leaves.extend(contents.map(leaf));
        Bsp {
            version: BspVersion::Bsp29,
            lumps: [LumpEntry::default(); NUM_LUMPS],
            entities: String::new(),
            planes,
            textures: Vec::new(),
            vertices: Vec::new(),
            visdata: Vec::new(),
            nodes,
            texinfo: Vec::new(),
            faces: Vec::new(),
            num_clipnodes: 0,
            leaves,
            marksurfaces: Vec::new(),
            edges: Vec::new(),
            surfedges: Vec::new(),
            models: vec![BspModel {
                mins: [-64.0; 3],
                maxs: [64.0; 3],
                origin: [0.0; 3],
                head_nodes: [0, -1, -1, -1],
                visleafs: 3,
                first_face: 0,
                num_faces: 0,
            }],
        }
    }

    fn clear() -> BspPortalOptions {
        BspPortalOptions::default()
    }

    fn pairs(b: &BspPortals) -> Vec<[u32; 2]> {
        let mut p: Vec<[u32; 2]> = b.prt.portals.iter().map(|p| p.leaves).collect();
        p.sort();
        p
    }

    #[test]
    fn three_cells_get_the_portals_between_them() {
        let bsp = three_cells([-1, -1, -3]);
        let built = build(&bsp, clear()).unwrap();
        assert_eq!(built.prt.num_leaves, 3);
        assert_eq!(pairs(&built), [[0, 1], [0, 2], [1, 2]]);
        for p in &built.prt.portals {
            assert!(
                (p.winding.area() - 64.0 * 128.0).abs() < 1.0
                    || (p.winding.area() - 128.0 * 128.0).abs() < 1.0
            );
        }
        // The x = 0 portal faces its first leaf, the front one.
        let x = built.prt.portals.iter().find(|p| p.leaves == [0, 1]).unwrap();
        assert!(x.winding.plane().unwrap().normal.x > 0.99);
        assert_eq!(
            (built.stats.open_leaves, built.stats.portals, built.stats.liquid_portals_dropped),
            (3, 3, 0)
        );
        // Opaque water: the two portals into the water leaf go.
        let opaque = build(&bsp, BspPortalOptions { liquids: LiquidSight::Opaque, ..clear() }).unwrap();
        assert_eq!(pairs(&opaque), [[0, 1]]);
        assert_eq!(opaque.stats.liquid_portals_dropped, 2);
        // Sky joins only sky; an unknown contents code counts as empty.
        assert_eq!(pairs(&build(&three_cells([-1, -6, -6]), clear()).unwrap()), [[1, 2]]);
        assert_eq!(pairs(&build(&three_cells([-1, -9, -1]), clear()).unwrap()).len(), 3);
        assert!(build(&three_cells([-1, -2, -1]), clear()).unwrap().prt.portals.len() == 1);
    }

    #[test]
    fn open_leaves_sharing_a_stored_row_under_a_node_become_one_cluster() {
        // Leaves 2 and 3 (under the z = 0 node) share the row at 0; leaf 1 has its own.
        let mut bsp = three_cells([-1, -1, -3]);
        bsp.visdata = vec![0b110, 0b011];
        bsp.leaves[1].visofs = 1;
        bsp.leaves[2].visofs = 0;
        bsp.leaves[3].visofs = 0;
        let built = build(&bsp, clear()).unwrap();
        assert_eq!(built.prt.format, PrtFormat::Prt2);
        assert_eq!(built.prt.leaf_clusters, [0, 1, 1]);
        assert_eq!(pairs(&built), [[0, 1]]);
        assert!((built.prt.portals[0].winding.area() - 128.0 * 128.0).abs() < 1.0, "the whole x = 0 opening");
        assert_eq!(built.stats.clusters, 2);
        // Asked not to, or where the water surface blocks, or where the shared row sees
        // everything, every leaf stays its own cluster.
        let leaves = build(&bsp, BspPortalOptions { no_clusters: true, ..clear() }).unwrap();
        assert_eq!((leaves.prt.format, leaves.prt.portals.len()), (PrtFormat::Prt1, 3));
        let opaque = build(&bsp, BspPortalOptions { liquids: LiquidSight::Opaque, ..clear() }).unwrap();
        assert_eq!(opaque.prt.format, PrtFormat::Prt1);
        let mut everything = bsp.clone();
        everything.visdata = vec![0b111, 0b011];
        assert_eq!(build(&everything, clear()).unwrap().prt.format, PrtFormat::Prt1);
    }

    #[test]
    fn bad_trees_are_errors_naming_the_record() {
        // An open leaf beyond visleafs.
        let mut beyond = three_cells([-1, -1, -1]);
        beyond.models[0].visleafs = 2;
        let e = build(&beyond, clear()).unwrap_err();
        assert!(matches!(e, BspPortalsError::Leaf { leaf: 3, contents: -1, .. }), "{e}");
        // A node reached twice (both sides of the root lead to node 1's subtree).
        let mut shared = three_cells([-1, -1, -1]);
        shared.nodes[0].children = [1, 1];
        assert!(matches!(build(&shared, clear()), Err(BspPortalsError::Node { node: 1, .. })));
        // An open leaf reached twice.
        let mut twice = three_cells([-1, -1, -1]);
        let last = twice.nodes.len() - 1;
        twice.nodes[last].children[0] = -2;
        assert!(matches!(build(&twice, clear()), Err(BspPortalsError::Leaf { leaf: 1, .. })));
        // A plane without a normal.
        let mut flat = three_cells([-1, -1, -1]);
        flat.planes[1].normal = [0.0; 3];
        let e = build(&flat, clear()).unwrap_err();
        assert!(e.to_string().contains("plane 1 has no normal"), "{e}");
        let mut none = three_cells([-1, -1, -1]);
        none.models.clear();
        assert_eq!(build(&none, clear()).unwrap_err(), BspPortalsError::NoWorld);
    }

    #[test]
    fn a_world_of_one_leaf_has_no_portals_and_inverted_bounds_fall_back_to_the_world() {
        let mut one = three_cells([-1, -1, -1]);
        one.models[0].head_nodes[0] = -2;
        one.models[0].mins = [1.0; 3];
        one.models[0].maxs = [-1.0; 3];
        let built = build(&one, clear()).unwrap();
        assert!(built.prt.portals.is_empty());
        assert_eq!(portal_box(&one).maxs, DVec3::splat(WORLD_LIMIT));
    }
}
