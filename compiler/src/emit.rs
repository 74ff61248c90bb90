//! Emit the [`Level`] and the [`PortalFile`] from the sealed tree, its portals and the CSG faces.
//!
//! - Interior nodes whose whole subtree is solid after the outside fill become one solid leaf.
//! - Leaves are numbered in tree pre-order (front first). Non-solid world leaves are the vis
//!   leaves, numbered `0..` in that order; each maximal subtree under a detail node is one
//!   cluster, every other vis leaf its own, clusters numbered by first vis leaf. The `.prt` is
//!   PRT1 when clusters are one per leaf, else PRT2 whose portals are those of the tree with each
//!   detail subtree collapsed to one cell (whole structural portals, as qbsp writes them: detail
//!   never blocks vis). The level's own portals stay leaf to leaf. A `func_viscluster` makes the
//!   leaves inside it (and their detail clusters) one cluster, dropping the portals within it.
//! - A face lies on its brush side's plane and is listed by every kept leaf it touches on its
//!   front side (found by pushing the polygon down the tree, splitting with [`ON_EPSILON`]); a
//!   face that touches no kept leaf borders only filled space and is dropped.
//! - Every face gets its [`FaceDraw`]: its side's texture vectors (qbsp's texinfo, from the
//!   `.map` side), flags 0, no light map (styles 255, offset -1); `texture_sizes` stays empty (a
//!   `.map` does not size its textures).
//! - Submodel trees follow the world's; their leaves have cluster -1 and list no faces.

use std::collections::HashMap;

use rayon::prelude::*;
use sightline_formats::geom::ON_EPSILON;
use sightline_formats::prt::{PortalFile, PrtFormat, PrtPortal};
use sightline_formats::{
    Aabb, Contents, Face, FaceDraw, Leaf, Level, LevelPlane, Model, Node, PlaneSet, Portal, Winding,
};

use crate::bsp::{Tree, TreeNode};
use crate::contents::sight_passes;
use crate::csg::{CsgFace, Surface};
use crate::portals::Portals;

/// The world part handed to [`emit`].
#[derive(Debug)]
pub struct World<'a> {
    /// The world tree.
    pub tree: &'a Tree,
    /// Leaf contents after the outside fill, per tree index.
    pub contents: &'a [Contents],
    /// Its portals.
    pub portals: &'a Portals,
    /// Its CSG faces (structural and detail).
    pub faces: &'a [CsgFace],
    /// Bounds of its brushes.
    pub bounds: Aabb,
    /// With detail: the portals of the tree with detail subtrees collapsed, and for each index of
    /// that tree the world tree index it stands for. These become the `.prt`'s cluster portals.
    pub cluster_portals: Option<(&'a Portals, &'a [u32])>,
    /// Per tree index, the `func_viscluster` whose volume holds the leaf (empty: none); each
    /// entity's leaves become one cluster (see `viscluster`).
    pub vis_groups: &'a [Option<u32>],
}

/// A submodel handed to [`emit`].
#[derive(Debug)]
pub struct Submodel {
    /// Its tree.
    pub tree: Tree,
    /// Its faces.
    pub faces: Vec<CsgFace>,
    /// Bounds of its brushes.
    pub bounds: Aabb,
}

/// Everything [`emit`] produces.
#[derive(Debug)]
pub struct Emitted {
    /// The level (no PVS yet).
    pub level: Level,
    /// The portal file for vis.
    pub prt: PortalFile,
    /// Per `func_viscluster` (by its index in [`World::vis_groups`]), the vis leaves of its
    /// cluster; shorter when the last ones hold none.
    pub viscluster_leaves: Vec<usize>,
}

fn f3(v: glam::DVec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

struct Out<'a> {
    level: Level,
    surfaces: &'a [Surface],
}

/// Build the level.
pub fn emit(
    planes: &PlaneSet,
    world: &World<'_>,
    submodels: &[Submodel],
    entities: String,
    textures: Vec<String>,
    surfaces: &[Surface],
) -> Emitted {
    let mut out = Out { level: Level { entities, textures, ..Level::default() }, surfaces };
    out.level.planes =
        planes.planes().iter().map(|p| LevelPlane { normal: f3(p.normal), dist: p.dist as f32 }).collect();

    // World tree.
    let mut leaf_map = vec![u32::MAX; world.tree.nodes.len()];
    let head = emit_tree(&mut out, world.tree, world.contents, &mut leaf_map);
    let mut keys = cluster_keys(world.tree);
    crate::viscluster::merge_keys(&mut keys, world.vis_groups);
    let group_base = keys.len() as u32;
    let mut viscluster_leaves: Vec<usize> = Vec::new();
    let mut clusters: HashMap<u32, i32> = HashMap::new();
    let mut leaf_clusters = Vec::new();
    for (t, &l) in leaf_map.iter().enumerate() {
        let Some(leaf) = out.level.leaves.get_mut(l as usize) else { continue };
        // Tree pre-order visits a level leaf first at its own index; later entries are inside a
        // merged solid subtree.
        if leaf.contents == Contents::Solid || leaf.cluster >= 0 {
            continue;
        }
        let next = clusters.len() as i32;
        leaf.cluster = *clusters.entry(keys[t]).or_insert(next);
        leaf_clusters.push(leaf.cluster as u32);
        if let Some(g) = keys[t].checked_sub(group_base).map(|g| g as usize) {
            if viscluster_leaves.len() <= g {
                viscluster_leaves.resize(g + 1, 0);
            }
            viscluster_leaves[g] += 1;
        }
    }
    out.level.num_clusters = clusters.len() as u32;
    let num_vis_leaves = leaf_clusters.len() as u32;

    // World faces and the leaves that list them.
    let kept = |i: u32| world.contents.get(i as usize).is_some_and(|c| *c != Contents::Solid);
    let touched: Vec<Vec<u32>> = world
        .faces
        .par_iter()
        .map(|f| {
            let mut list = Vec::new();
            touch(world.tree, planes, 0, &f.winding, f.plane, &mut list);
            list.retain(|&i| kept(i));
            list
        })
        .collect();
    let mut per_leaf: Vec<Vec<u32>> = vec![Vec::new(); out.level.leaves.len()];
    for (f, list) in world.faces.iter().zip(&touched) {
        if list.is_empty() {
            continue;
        }
        let face = out.push_face(f);
        for &t in list {
            if let Some(l) = per_leaf.get_mut(leaf_map[t as usize] as usize) {
                l.push(face);
            }
        }
    }
    for (leaf, list) in out.level.leaves.iter_mut().zip(&per_leaf) {
        leaf.first_face = out.level.leaf_faces.len() as u32;
        leaf.num_faces = list.len() as u32;
        out.level.leaf_faces.extend_from_slice(list);
    }
    let num_faces = out.level.faces.len() as u32;
    out.level.models.push(Model {
        head_node: head,
        mins: f3(world.bounds.mins),
        maxs: f3(world.bounds.maxs),
        first_face: 0,
        num_faces,
    });

    // Portals.
    let mut prt = PortalFile {
        format: if num_vis_leaves == out.level.num_clusters { PrtFormat::Prt1 } else { PrtFormat::Prt2 },
        num_leaves: num_vis_leaves,
        num_clusters: out.level.num_clusters,
        portals: Vec::new(),
        leaf_clusters,
    };
    for p in &world.portals.portals {
        let Some(plane) = p.plane_index else { continue };
        let contents_of = |n: u32| world.contents.get(n as usize).copied().unwrap_or(Contents::Solid);
        if p.winding.is_empty() || !sight_passes(contents_of(p.nodes[0]), contents_of(p.nodes[1])) {
            continue;
        }
        let leaves = p.nodes.map(|n| leaf_map[n as usize]);
        let first_vertex = out.push_winding(&p.winding);
        out.level.portals.push(Portal { leaves, plane, first_vertex, num_vertices: p.winding.len() as u32 });
        if world.cluster_portals.is_none() {
            let clusters = leaves.map(|l| out.level.leaves[l as usize].cluster as u32);
            // Only a func_viscluster puts both sides of a portal in one cluster here.
            if clusters[0] != clusters[1] {
                prt.portals.push(PrtPortal { leaves: clusters, winding: p.winding.clone() });
            }
        }
    }
    if let Some((graph, origin)) = world.cluster_portals {
        for p in &graph.portals {
            if p.plane_index.is_none() || p.winding.is_empty() {
                continue;
            }
            let cluster_of = |n: u32| {
                let original = origin.get(n as usize)?;
                clusters.get(keys.get(*original as usize)?).copied()
            };
            // A collapsed detail cell stands for a node, whose placeholder contents are not sky.
            let sky = |n: u32| {
                origin.get(n as usize).and_then(|&o| world.contents.get(o as usize)) == Some(&Contents::Sky)
            };
            if let (Some(a), Some(b)) = (cluster_of(p.nodes[0]), cluster_of(p.nodes[1]))
                && a != b
                && sky(p.nodes[0]) == sky(p.nodes[1])
            {
                prt.portals.push(PrtPortal { leaves: [a as u32, b as u32], winding: p.winding.clone() });
            }
        }
    }

    // Submodels.
    for m in submodels {
        let contents = m.tree.contents_by_node();
        let mut map = vec![u32::MAX; m.tree.nodes.len()];
        let head = emit_tree(&mut out, &m.tree, &contents, &mut map);
        let first_face = out.level.faces.len() as u32;
        for f in &m.faces {
            out.push_face(f);
        }
        out.level.models.push(Model {
            head_node: head,
            mins: f3(m.bounds.mins),
            maxs: f3(m.bounds.maxs),
            first_face,
            num_faces: out.level.faces.len() as u32 - first_face,
        });
    }
    Emitted { level: out.level, prt, viscluster_leaves }
}

impl Out<'_> {
    fn push_winding(&mut self, w: &Winding) -> u32 {
        let first = self.level.vertices.len() as u32;
        self.level.vertices.extend(w.points.iter().map(|&p| f3(p)));
        first
    }

    fn push_face(&mut self, f: &CsgFace) -> u32 {
        let first_vertex = self.push_winding(&f.winding);
        let surface = self.surfaces.get(f.surface as usize);
        self.level.faces.push(Face {
            plane: f.plane,
            first_vertex,
            num_vertices: f.winding.len() as u32,
            texture: surface.map_or(0, |s| s.texture),
        });
        let [s, t] = surface.map_or([[0.0; 4]; 2], |s| s.vectors);
        self.level.face_draw.push(FaceDraw { s, t, ..FaceDraw::NONE });
        self.level.faces.len() as u32 - 1
    }
}

/// Emit a tree; returns the head as a node child code. `leaf_map` receives the level leaf of every
/// tree leaf (and of merged solid subtrees' leaves). Leaves get cluster -1 here.
fn emit_tree(out: &mut Out, tree: &Tree, contents: &[Contents], leaf_map: &mut [u32]) -> i32 {
    let n = tree.nodes.len();
    let mut all_solid = vec![false; n];
    for i in (0..n).rev() {
        all_solid[i] = match &tree.nodes[i] {
            TreeNode::Leaf { .. } => contents[i] == Contents::Solid,
            TreeNode::Node { children, .. } => {
                all_solid[children[0] as usize] && all_solid[children[1] as usize]
            }
        };
    }
    emit_r(out, tree, contents, &all_solid, leaf_map, 0)
}

fn emit_r(
    out: &mut Out,
    tree: &Tree,
    contents: &[Contents],
    all_solid: &[bool],
    leaf_map: &mut [u32],
    i: u32,
) -> i32 {
    let node = &tree.nodes[i as usize];
    let bounds = node.bounds();
    let leaf_contents = match node {
        _ if all_solid[i as usize] => Some(Contents::Solid),
        TreeNode::Leaf { .. } => Some(contents[i as usize]),
        TreeNode::Node { .. } => None,
    };
    if let Some(c) = leaf_contents {
        let index = out.level.leaves.len() as u32;
        out.level.leaves.push(Leaf {
            contents: c,
            cluster: -1,
            mins: f3(bounds.mins),
            maxs: f3(bounds.maxs),
            first_face: 0,
            num_faces: 0,
        });
        mark(tree, i, index, leaf_map);
        return -(index as i32) - 1;
    }
    let TreeNode::Node { plane, children, .. } = node else { return -1 };
    let index = out.level.nodes.len();
    out.level.nodes.push(Node {
        plane: *plane,
        children: [0, 0],
        mins: f3(bounds.mins),
        maxs: f3(bounds.maxs),
    });
    let f = emit_r(out, tree, contents, all_solid, leaf_map, children[0]);
    let k = emit_r(out, tree, contents, all_solid, leaf_map, children[1]);
    out.level.nodes[index].children = [f, k];
    index as i32
}

/// For every tree index, the index that names its cluster: the topmost detail node above it (a
/// detail subtree is one cluster), or itself.
fn cluster_keys(tree: &Tree) -> Vec<u32> {
    let mut root: Vec<Option<u32>> = vec![None; tree.nodes.len()];
    for (i, n) in tree.nodes.iter().enumerate() {
        if let TreeNode::Node { children, detail, .. } = n {
            let r = root[i].or(detail.then_some(i as u32));
            for c in children {
                root[*c as usize] = r;
            }
        }
    }
    root.iter().enumerate().map(|(i, r)| r.unwrap_or(i as u32)).collect()
}

fn mark(tree: &Tree, i: u32, leaf: u32, leaf_map: &mut [u32]) {
    leaf_map[i as usize] = leaf;
    if let TreeNode::Node { children, .. } = &tree.nodes[i as usize] {
        mark(tree, children[0], leaf, leaf_map);
        mark(tree, children[1], leaf, leaf_map);
    }
}

/// Collect the leaves a polygon on plane `face_plane` touches on its front side.
pub fn touch(tree: &Tree, planes: &PlaneSet, i: u32, w: &Winding, face_plane: u32, out: &mut Vec<u32>) {
    match &tree.nodes[i as usize] {
        TreeNode::Leaf { .. } => out.push(i),
        TreeNode::Node { plane, children, .. } => {
            if face_plane & !1 == *plane {
                let child = if face_plane == *plane { children[0] } else { children[1] };
                return touch(tree, planes, child, w, face_plane, out);
            }
            let split = w.split(planes.get(*plane as usize), ON_EPSILON);
            if let Some(f) = split.front {
                touch(tree, planes, children[0], &f, face_plane, out);
            }
            if let Some(k) = split.back {
                touch(tree, planes, children[1], &k, face_plane, out);
            }
        }
    }
}
