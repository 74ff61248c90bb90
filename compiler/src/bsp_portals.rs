//! Portals of a compiled Quake BSP (BSP29, BSP2, BSP2-RMQ) rebuilt from its world tree alone, so a
//! map whose source and `.prt` are lost can be vised again.
//!
//! # How
//! Model 0's hull-0 node tree is copied into a [`Tree`] (pre-order, front child first) and
//! portalized by [`crate::portals::build_with`], the compiler's own qbsp-style builder: a huge
//! winding on each node's plane, clipped by the ancestors' planes and a box, split down the
//! subtree to the leaves. The box is the world model's bounds and the root node's, grown by
//! [`BOX_MARGIN`] (qbsp's own margin) and kept within [`WORLD_LIMIT`]. Every portal between two BSP
//! leaves whose contents let sight through becomes a PRT1 line between their vis leaves.
//!
//! # Conventions
//! - Vis leaves are the BSP's own: leaf `i` in `1..=visleafs` is vis leaf `i - 1`, so the PVS can
//!   be written back into the same file. Every non-solid leaf the world tree reaches must be one
//!   (qbsp numbers them so); one that is not, or a node or non-solid leaf reached twice, is an
//!   error: such a cell has no row, or is not convex.
//! - Contents decide sight as Quake's tools do ([`sight_passes_with`]): solid (-2) blocks; sky
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
//!   unmerged corners ([`TinyPieces::Keep`]): a portal is never dropped for being small.
//! - A tree deeper than [`MAX_DEPTH`] is refused (the node graph is acyclic once
//!   [`sightline_formats::bsp::read`] accepts it; the copy is iterative and visits each node once).

use glam::DVec3;
use sightline_formats::bsp::{Bsp, lump};
use sightline_formats::geom::{ON_EPSILON, WORLD_LIMIT};
use sightline_formats::prt::{PortalFile, PrtFormat, PrtPortal};
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

/// Counts of a rebuild.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct BspPortalStats {
    /// Nodes of the world tree.
    pub nodes: usize,
    /// Leaf references of the world tree (the shared solid leaf counts at each).
    pub tree_leaves: usize,
    /// Non-solid leaves the world tree reaches.
    pub open_leaves: usize,
    /// Vis leaves (`visleafs` of the world model).
    pub vis_leaves: usize,
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
    /// PRT1 over the BSP's vis leaves.
    pub prt: PortalFile,
    /// Counts.
    pub stats: BspPortalStats,
}

/// The world tree copied for the builder, with the BSP leaf of each tree leaf.
struct WorldTree {
    tree: Tree,
    planes: PlaneSet,
    /// For each tree index, the BSP leaf it is (`usize::MAX` for nodes).
    bsp_leaf: Vec<usize>,
    stats: BspPortalStats,
}

/// The sight rule for a BSP contents code (unknown codes count as empty).
fn sight_contents(code: i32) -> Contents {
    Contents::from_code(code).unwrap_or(Contents::Empty)
}

/// Rebuilds the portals of `bsp`'s world tree, liquids see-through or not as `liquids` says.
pub fn build(bsp: &Bsp, liquids: LiquidSight) -> Result<BspPortals, BspPortalsError> {
    let world = copy_tree(bsp)?;
    let bounds = portal_box(bsp);
    let graph = portals::build_with(&world.tree, &world.planes, &bounds, TinyPieces::Keep);
    let visleafs = bsp.visleafs();
    let mut stats = BspPortalStats { vis_leaves: visleafs, ..world.stats };
    let mut prt = PortalFile {
        format: PrtFormat::Prt1,
        num_leaves: visleafs as u32,
        num_clusters: visleafs as u32,
        portals: Vec::new(),
        leaf_clusters: (0..visleafs as u32).collect(),
    };
    for p in &graph.portals {
        // Box portals (no plane index) lead outside; no cell lies there.
        if p.plane_index.is_none() || p.winding.is_empty() {
            continue;
        }
        let leaves = p.nodes.map(|n| world.bsp_leaf.get(n as usize).copied().unwrap_or(usize::MAX));
        let contents = leaves.map(|l| sight_contents(bsp.leaves.get(l).map_or(-2, |leaf| leaf.contents)));
        if !sight_passes_with(contents[0], contents[1], liquids) {
            stats.liquid_portals_dropped +=
                usize::from(sight_passes_with(contents[0], contents[1], LiquidSight::Transparent));
            continue;
        }
        // Both leaves are open, so `copy_tree` checked they are vis leaves 1..=visleafs.
        stats.tiny_portals_kept += usize::from(p.winding.cleaned(ON_EPSILON).is_empty());
        prt.portals.push(PrtPortal { leaves: leaves.map(|l| (l - 1) as u32), winding: p.winding.clone() });
    }
    stats.portals = prt.portals.len();
    Ok(BspPortals { prt, stats })
}

/// Model 0's hull-0 tree as a [`Tree`], checking what [`build`] needs (see the module docs).
fn copy_tree(bsp: &Bsp) -> Result<WorldTree, BspPortalsError> {
    let model = bsp.models.first().ok_or(BspPortalsError::NoWorld)?;
    let visleafs = bsp.visleafs();
    let node_at = |n: usize| bsp.lumps[lump::NODES].offset + n * bsp.version.node_bytes();
    let leaf_at = |l: usize| bsp.lumps[lump::LEAVES].offset + l * bsp.version.leaf_bytes();
    let mut out = WorldTree {
        tree: Tree::default(),
        planes: PlaneSet::new(),
        bsp_leaf: Vec::new(),
        stats: BspPortalStats::default(),
    };
    let mut node_seen = vec![false; bsp.nodes.len()];
    let mut leaf_seen = vec![false; bsp.leaves.len()];
    // (child code, the tree node and side to patch, depth), popped front child first.
    let mut stack: Vec<(i32, Option<(usize, usize)>, usize)> = vec![(model.head_nodes[0], None, 0)];
    while let Some((code, parent, depth)) = stack.pop() {
        let index = out.tree.nodes.len();
        if let Some((p, side)) = parent
            && let Some(TreeNode::Node { children, .. }) = out.tree.nodes.get_mut(p)
        {
            children[side] = index as u32;
        }
        let bounds = |mins: [f32; 3], maxs: [f32; 3]| Aabb::new(vec3(mins), vec3(maxs));
        match usize::try_from(code) {
            Ok(n) => {
                let node_err = |detail: String| BspPortalsError::Node { offset: node_at(n), node: n, detail };
                let Some(node) = bsp.nodes.get(n) else {
                    return Err(node_err(format!("no such node ({} in the file)", bsp.nodes.len())));
                };
                if std::mem::replace(&mut node_seen[n], true) {
                    return Err(node_err(
                        "reached twice in the world tree (a cell that is not convex)".into(),
                    ));
                }
                if depth >= MAX_DEPTH {
                    return Err(node_err(format!("the world tree is deeper than {MAX_DEPTH}")));
                }
                let stored = bsp.planes.get(node.plane as usize);
                let plane = stored.and_then(|p| Plane::new(vec3(p.normal), f64::from(p.dist)));
                let Some(plane) = plane else {
                    return Err(node_err(format!("plane {} has no normal", node.plane)));
                };
                let i = out.planes.insert(plane);
                // The tree takes even (positive-facing) plane indices: an odd one swaps the sides.
                let (plane, sides) = if i % 2 == 0 { (i, [0, 1]) } else { (i ^ 1, [1, 0]) };
                out.tree.nodes.push(TreeNode::Node {
                    plane: plane as u32,
                    children: [0, 0],
                    bounds: bounds(node.mins, node.maxs),
                    detail: false,
                });
                out.bsp_leaf.push(usize::MAX);
                out.stats.nodes += 1;
                stack.push((node.children[1], Some((index, sides[1])), depth + 1));
                stack.push((node.children[0], Some((index, sides[0])), depth + 1));
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
                let contents = sight_contents(leaf.contents);
                if contents != Contents::Solid {
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
                    out.stats.open_leaves += 1;
                }
                out.tree.nodes.push(TreeNode::Leaf { contents, bounds: bounds(leaf.mins, leaf.maxs) });
                out.bsp_leaf.push(l);
                out.stats.tree_leaves += 1;
            }
        }
    }
    Ok(out)
}

fn vec3(v: [f32; 3]) -> DVec3 {
    DVec3::new(f64::from(v[0]), f64::from(v[1]), f64::from(v[2]))
}

/// The box the portals start in: the world model's bounds and its root node's (those that are
/// finite and not inverted), grown by [`BOX_MARGIN`], within [`WORLD_LIMIT`]; the whole world
/// when neither is usable.
fn portal_box(bsp: &Bsp) -> Aabb {
    let mut b = Aabb::EMPTY;
    let mut add = |mins: [f32; 3], maxs: [f32; 3]| {
        let (mins, maxs) = (vec3(mins), vec3(maxs));
        if mins.is_finite() && maxs.is_finite() && mins.cmple(maxs).all() {
            b.add_point(mins);
            b.add_point(maxs);
        }
    };
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

    fn pairs(b: &BspPortals) -> Vec<[u32; 2]> {
        let mut p: Vec<[u32; 2]> = b.prt.portals.iter().map(|p| p.leaves).collect();
        p.sort();
        p
    }

    #[test]
    fn three_cells_get_the_portals_between_them() {
        let bsp = three_cells([-1, -1, -3]);
        let built = build(&bsp, LiquidSight::Transparent).unwrap();
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
        let opaque = build(&bsp, LiquidSight::Opaque).unwrap();
        assert_eq!(pairs(&opaque), [[0, 1]]);
        assert_eq!(opaque.stats.liquid_portals_dropped, 2);
        // Sky joins only sky; an unknown contents code counts as empty.
        assert_eq!(pairs(&build(&three_cells([-1, -6, -6]), LiquidSight::Transparent).unwrap()), [[1, 2]]);
        assert_eq!(pairs(&build(&three_cells([-1, -9, -1]), LiquidSight::Transparent).unwrap()).len(), 3);
        assert!(build(&three_cells([-1, -2, -1]), LiquidSight::Transparent).unwrap().prt.portals.len() == 1);
    }

    #[test]
    fn bad_trees_are_errors_naming_the_record() {
        // An open leaf beyond visleafs.
        let mut beyond = three_cells([-1, -1, -1]);
        beyond.models[0].visleafs = 2;
        let e = build(&beyond, LiquidSight::Transparent).unwrap_err();
        assert!(matches!(e, BspPortalsError::Leaf { leaf: 3, contents: -1, .. }), "{e}");
        // A node reached twice (both sides of the root lead to node 1's subtree).
        let mut shared = three_cells([-1, -1, -1]);
        shared.nodes[0].children = [1, 1];
        assert!(matches!(
            build(&shared, LiquidSight::Transparent),
            Err(BspPortalsError::Node { node: 1, .. })
        ));
        // An open leaf reached twice.
        let mut twice = three_cells([-1, -1, -1]);
        let last = twice.nodes.len() - 1;
        twice.nodes[last].children[0] = -2;
        assert!(matches!(
            build(&twice, LiquidSight::Transparent),
            Err(BspPortalsError::Leaf { leaf: 1, .. })
        ));
        // A plane without a normal.
        let mut flat = three_cells([-1, -1, -1]);
        flat.planes[1].normal = [0.0; 3];
        let e = build(&flat, LiquidSight::Transparent).unwrap_err();
        assert!(e.to_string().contains("plane 1 has no normal"), "{e}");
        let mut none = three_cells([-1, -1, -1]);
        none.models.clear();
        assert_eq!(build(&none, LiquidSight::Transparent).unwrap_err(), BspPortalsError::NoWorld);
    }

    #[test]
    fn a_world_of_one_leaf_has_no_portals_and_inverted_bounds_fall_back_to_the_world() {
        let mut one = three_cells([-1, -1, -1]);
        one.models[0].head_nodes[0] = -2;
        one.models[0].mins = [1.0; 3];
        one.models[0].maxs = [-1.0; 3];
        let built = build(&one, LiquidSight::Transparent).unwrap();
        assert!(built.prt.portals.is_empty());
        assert_eq!(portal_box(&one).maxs, DVec3::splat(WORLD_LIMIT));
    }
}
