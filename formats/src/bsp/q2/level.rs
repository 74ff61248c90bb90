//! A whole Quake 2 BSP (`IBSP` 38) as Sightline's [`Level`]: what the runtime, `validate` and
//! `info` need beyond vis (planes, nodes, faces, leaves, models), decoded and checked when the file
//! is read ([`super::read`]: vis takes exactly the files the other readers take).
//!
//! # Conventions
//! - Records (Quake 2's `qfiles.h`): planes 20 bytes (as Quake 1), vertices 12, nodes 28 (`int32`
//!   plane and children, `int16` bounds, `uint16` face range), texinfo 76 (two axes, flags, value,
//!   a 32-byte texture name, next), faces 20 (as BSP29), leaves 28 ([`super::LEAF_BYTES`]),
//!   leaf faces `uint16`, edges two `uint16`, surfedges `int32`, models 48 (bounds, origin, head
//!   node, face range). Every index is checked when the file is read, so the level passes
//!   [`crate::slvl::validate`] and nothing here can panic on a hostile file; faces may not list
//!   more corners in all than there are surfedges (each face has its own edge list in compiler
//!   output), which keeps the level linear in the file.
//! - Node children use Quake's encoding (`c < 0` is leaf `-(c + 1)`), as the level does.
//! - Clusters are the file's: a leaf's `cluster` is its level cluster, `num_clusters` the
//!   visibility lump's (or, before vis, the largest leaf cluster plus one), and PVS row `c` is
//!   the lump's row `c`, whose bit `j` means cluster `j` (the level's convention too). The PHS
//!   has no place in a level; the runtime reads it from the lump itself.
//! - Contents: Quake 2's are bit sets. A leaf with `CONTENTS_SOLID` (1) is solid (and has no
//!   cluster); otherwise lava (8), slime (16) and water (32) give those contents, and every
//!   other leaf (empty, window 2, mist 64, detail, ...) is open air. Quake 2's qbsp writes no
//!   portal between different visible contents unless one is translucent (an opaque liquid
//!   surface, a `func_illusionary_visblocker`'s mist); the level has no "opaque liquid", so such
//!   a leaf is see-through here: a validator may then report sight lines through it that no
//!   Quake 2 vis claims (stricter, never looser).
//! - Textures: one level texture per texinfo (its name), so a face's texture is its texinfo.
//! - Draw data: `face_draw[i]` is face `i`'s texinfo (s/t axes and offsets in texels, Quake 2's
//!   `SURF_*` flags; zero axes when one is not finite) with the face's light styles and lighting
//!   offset. The texinfo's `value` (light emission) and `nexttexinfo` (animation chain) are not
//!   kept. `texture_sizes` is empty: Quake 2 textures are external `.wal` files (their width and
//!   height are in the `.wal` header), so the level does not know their sizes.

use super::{LEAF_BYTES, Q2Bsp, Q2Vis, lump};
use crate::bsp::convert::Polygons;
use crate::bsp::lumps::{invalid, lump_records};
use crate::bsp::parse::{check_index, check_range, non_negative};
use crate::bsp::{BspError, LumpEntry, bounds};
use crate::level::{Contents, FaceDraw, Leaf, Level, Model, Node};
use crate::tree_check::find_cycle;

/// Lump indices beyond the ones vis needs.
mod more {
    pub const ENTITIES: usize = 0;
    pub const PLANES: usize = 1;
    pub const VERTICES: usize = 2;
    pub const NODES: usize = 4;
    pub const TEXINFO: usize = 5;
    pub const FACES: usize = 6;
    pub const LEAFFACES: usize = 9;
    pub const EDGES: usize = 11;
    pub const SURFEDGES: usize = 12;
    pub const MODELS: usize = 13;
}

/// Quake 2's `CONTENTS_SOLID`.
pub const CONTENTS_SOLID: i32 = 1;
/// Quake 2's `CONTENTS_LAVA`.
pub const CONTENTS_LAVA: i32 = 8;
/// Quake 2's `CONTENTS_SLIME`.
pub const CONTENTS_SLIME: i32 = 16;
/// Quake 2's `CONTENTS_WATER`.
pub const CONTENTS_WATER: i32 = 32;

/// The level contents of Quake 2 contents bits (see the module docs).
pub fn contents(bits: i32) -> Contents {
    if bits & CONTENTS_SOLID != 0 {
        Contents::Solid
    } else if bits & CONTENTS_LAVA != 0 {
        Contents::Lava
    } else if bits & CONTENTS_SLIME != 0 {
        Contents::Slime
    } else if bits & CONTENTS_WATER != 0 {
        Contents::Water
    } else {
        Contents::Empty
    }
}

#[derive(Debug, Clone, PartialEq)]
struct RawFace {
    plane: u32,
    back: bool,
    first_edge: u32,
    num_edges: u32,
    texinfo: u32,
    styles: [u8; 4],
    light_offset: i32,
}

/// Every lump a level needs beyond vis, decoded and checked by [`super::read`] (see the module
/// docs): what [`to_level`] builds from.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Geometry {
    entities: String,
    planes: Vec<([f32; 3], f32)>,
    vertices: Vec<[f32; 3]>,
    edges: Vec<[u16; 2]>,
    surfedges: Vec<i32>,
    texture_names: Vec<String>,
    texinfo: Vec<FaceDraw>,
    faces: Vec<RawFace>,
    leaf_faces: Vec<u32>,
    leaves: Vec<Leaf>,
    nodes: Vec<Node>,
    models: Vec<Model>,
    /// The visibility lump's clusters, or before vis the clusters the leaves name.
    num_clusters: u32,
}

/// Decodes and checks every lump of a Quake 2 BSP that a level needs (`bytes` with the header
/// `lumps`, whose leaves name `leaf_clusters` and whose visibility lump is `vis`): every index in
/// range, planes and vertices finite, the node graph acyclic, a world model. Bounds are taken as
/// stored ([`crate::bsp::bounds`] repairs them in the level).
pub(super) fn read_geometry(
    bytes: &[u8],
    lumps: &[LumpEntry; super::NUM_LUMPS],
    leaf_clusters: &[i32],
    vis: Option<&Q2Vis>,
) -> Result<Geometry, BspError> {
    let recs = |index: usize, size: usize| lump_records(bytes, lumps, &lump::NAMES, index, size);

    let ents = lumps[more::ENTITIES];
    let ent = bytes.get(ents.offset..ents.end()).unwrap_or_default();
    let ent = &ent[..ent.iter().position(|&b| b == 0).unwrap_or(ent.len())];
    let entities = String::from_utf8_lossy(ent).into_owned();

    let mut planes = Vec::new();
    for (at, mut r) in recs(more::PLANES, 20)? {
        let (normal, dist) = (r.vec3(), r.f32());
        if !normal.iter().chain([&dist]).all(|c| c.is_finite()) {
            return Err(invalid(at, format!("plane {}", planes.len()), "not finite"));
        }
        planes.push((normal, dist));
    }
    let mut vertices = Vec::new();
    for (at, mut r) in recs(more::VERTICES, 12)? {
        let v = r.vec3();
        if !v.iter().all(|c| c.is_finite()) {
            return Err(invalid(at, format!("vertex {}", vertices.len()), "not finite"));
        }
        vertices.push(v);
    }
    let mut edges = Vec::new();
    for (at, mut r) in recs(more::EDGES, 4)? {
        let e = [r.u16(), r.u16()];
        for v in e {
            check_index(at, "edge", edges.len(), v.into(), vertices.len(), "vertices")?;
        }
        edges.push(e);
    }
    let surfedges: Vec<i32> = recs(more::SURFEDGES, 4)?.map(|(_, mut r)| r.i32()).collect();
    for (i, &e) in surfedges.iter().enumerate() {
        let at = lumps[more::SURFEDGES].offset + 4 * i;
        check_index(at, "surfedge", i, e.unsigned_abs().into(), edges.len(), "edges")?;
    }
    let mut texture_names = Vec::new();
    let mut texinfo = Vec::new();
    for (_, mut r) in recs(more::TEXINFO, 76)? {
        let s = [r.f32(), r.f32(), r.f32(), r.f32()];
        let t = [r.f32(), r.f32(), r.f32(), r.f32()];
        let flags = r.i32() as u32;
        let _value: [u8; 4] = r.take();
        let name: [u8; 32] = r.take();
        let len = name.iter().position(|&b| b == 0).unwrap_or(name.len());
        texture_names.push(String::from_utf8_lossy(&name[..len]).into_owned());
        // As for Quake 1: a non-finite axis is "no projection", not a level that fails validation.
        let finite = s.iter().chain(&t).all(|v| v.is_finite());
        let (s, t) = if finite { (s, t) } else { ([0.0; 4], [0.0; 4]) };
        texinfo.push(FaceDraw { flags, s, t, ..FaceDraw::NONE });
    }
    let mut faces = Vec::new();
    for (at, mut r) in recs(more::FACES, 20)? {
        let i = faces.len();
        let plane = u32::from(r.u16());
        let back = r.i16() != 0;
        let first_edge = non_negative(at, "face", i, "first edge", r.i32())?;
        let num_edges = u32::from(r.u16());
        let texinfo = u32::from(r.u16());
        let (styles, light_offset) = (r.take::<4>(), r.i32());
        check_index(at, "face", i, plane.into(), planes.len(), "planes")?;
        check_index(at, "face", i, texinfo.into(), texture_names.len(), "texinfo")?;
        if num_edges < 3 {
            return Err(invalid(at, format!("face {i}"), format!("{num_edges} edges")));
        }
        check_range(at, "face", i, first_edge.into(), num_edges.into(), surfedges.len(), "surfedges")?;
        faces.push(RawFace { plane, back, first_edge, num_edges, texinfo, styles, light_offset });
    }
    // Compilers give each face its own edge list; faces sharing lists could make the corners
    // (copied per face) grow with faces × surfedges from a small file.
    let corners: u64 = faces.iter().map(|f| u64::from(f.num_edges)).sum();
    if corners > surfedges.len() as u64 {
        let detail = format!("{corners} corners in all faces, more than the {} surfedges", surfedges.len());
        return Err(invalid(lumps[more::FACES].offset, "faces", detail));
    }
    let leaf_faces: Vec<u32> = recs(more::LEAFFACES, 2)?.map(|(_, mut r)| u32::from(r.u16())).collect();
    for (i, &f) in leaf_faces.iter().enumerate() {
        let at = lumps[more::LEAFFACES].offset + 2 * i;
        check_index(at, "leaf face", i, f.into(), faces.len(), "faces")?;
    }

    let mut leaves = Vec::with_capacity(leaf_clusters.len());
    for ((at, mut r), &cluster) in recs(lump::LEAVES, LEAF_BYTES)?.zip(leaf_clusters) {
        let i = leaves.len();
        let contents = contents(r.i32());
        let _cluster_area: [u8; 4] = r.take();
        let (mins, maxs) = (r.vec3_i16(), r.vec3_i16());
        let (first_face, num_faces) = (u32::from(r.u16()), u32::from(r.u16()));
        check_range(at, "leaf", i, first_face.into(), num_faces.into(), leaf_faces.len(), "leaf faces")?;
        let cluster = if contents == Contents::Solid { -1 } else { cluster };
        leaves.push(Leaf { contents, cluster, mins, maxs, first_face, num_faces });
    }

    let mut nodes = Vec::new();
    let mut node_at = Vec::new();
    for (at, mut r) in recs(more::NODES, 28)? {
        let i = nodes.len();
        let plane = non_negative(at, "node", i, "plane", r.i32())?;
        check_index(at, "node", i, plane.into(), planes.len(), "planes")?;
        let children = [r.i32(), r.i32()];
        let (mins, maxs) = (r.vec3_i16(), r.vec3_i16());
        let (first, count) = (u32::from(r.u16()), u32::from(r.u16()));
        check_range(at, "node", i, first.into(), count.into(), faces.len(), "faces")?;
        nodes.push(Node { plane, children, mins, maxs });
        node_at.push(at);
    }
    let child_ok = |c: i32| {
        if c >= 0 { (c as usize) < nodes.len() } else { ((-(i64::from(c) + 1)) as u64) < leaves.len() as u64 }
    };
    for (i, n) in nodes.iter().enumerate() {
        if let Some(&bad) = n.children.iter().find(|&&c| !child_ok(c)) {
            return Err(invalid(node_at[i], format!("node {i}"), format!("bad child {bad}")));
        }
    }
    let children: Vec<[i32; 2]> = nodes.iter().map(|n| n.children).collect();
    if let Some(i) = find_cycle(&children) {
        return Err(invalid(
            node_at.get(i).copied().unwrap_or(0),
            format!("node {i}"),
            "lies on a cycle of nodes",
        ));
    }

    let mut models = Vec::new();
    for (at, mut r) in recs(more::MODELS, 48)? {
        let i = models.len();
        let (mins, maxs, _origin) = (r.vec3(), r.vec3(), r.vec3());
        let head_node = r.i32();
        if !child_ok(head_node) {
            return Err(invalid(at, format!("model {i}"), format!("bad head node {head_node}")));
        }
        let first_face = non_negative(at, "model", i, "first face", r.i32())?;
        let num_faces = non_negative(at, "model", i, "face count", r.i32())?;
        check_range(at, "model", i, first_face.into(), num_faces.into(), faces.len(), "faces")?;
        models.push(Model { head_node, mins, maxs, first_face, num_faces });
    }
    if models.is_empty() {
        return Err(invalid(lumps[more::MODELS].offset, "models", "no world model"));
    }

    let num_clusters = vis.map_or_else(|| cluster_count(leaf_clusters), |v| v.num_clusters);
    // Each cluster holds a leaf; more clusters than leaves is a damaged count.
    let num_clusters =
        u32::try_from(num_clusters).ok().filter(|&n| n as usize <= leaves.len()).ok_or_else(|| {
            let detail = format!("{num_clusters} clusters for {} leaves", leaves.len());
            invalid(lumps[lump::VISIBILITY].offset, "visibility lump", detail)
        })?;
    Ok(Geometry {
        entities,
        planes,
        vertices,
        edges,
        surfedges,
        texture_names,
        texinfo,
        faces,
        leaf_faces,
        leaves,
        nodes,
        models,
        num_clusters,
    })
}

/// Clusters `leaf_clusters` name: the largest plus one.
pub(super) fn cluster_count(leaf_clusters: &[i32]) -> usize {
    leaf_clusters.iter().map(|&c| (c + 1).max(0) as usize).max().unwrap_or(0)
}

/// A whole Quake 2 BSP, read and checked by [`super::read`], as a [`Level`] (see the module
/// docs); node, leaf and model bounds are the stored ones where usable, and [`bounds`] replaces
/// the others.
pub fn to_level(file: &Q2Bsp) -> Level {
    let mut level = level_as_stored(file);
    bounds::repair(&mut level);
    level
}

/// [`to_level`] with the stored bounds as they are, usable or not.
pub(crate) fn level_as_stored(file: &Q2Bsp) -> Level {
    let g = &file.geometry;
    let face_draw = g
        .faces
        .iter()
        .map(|f| {
            let info = g.texinfo.get(f.texinfo as usize).copied().unwrap_or(FaceDraw::NONE);
            FaceDraw { styles: f.styles, light_offset: f.light_offset, ..info }
        })
        .collect();
    let mut polygons = Polygons::new(g.planes.iter().copied(), g.faces.len());
    for f in &g.faces {
        let first = f.first_edge as usize;
        let list = g.surfedges.get(first..first + f.num_edges as usize).unwrap_or_default();
        let corners = list.iter().filter_map(|&e| {
            let edge = g.edges.get(e.unsigned_abs() as usize)?;
            g.vertices.get(usize::from(if e >= 0 { edge[0] } else { edge[1] })).copied()
        });
        polygons.push(f.plane, f.back, corners, f.texinfo);
    }
    let Polygons { planes, vertices, faces, .. } = polygons;
    let (pvs_offsets, pvs_data) = match &file.vis {
        Some(v) => (v.offsets.iter().map(|o| o[0]).collect(), v.data.clone()),
        None => (Vec::new(), Vec::new()),
    };
    Level {
        entities: g.entities.clone(),
        textures: g.texture_names.clone(),
        planes,
        nodes: g.nodes.clone(),
        leaves: g.leaves.clone(),
        leaf_faces: g.leaf_faces.clone(),
        faces,
        vertices,
        portals: Vec::new(),
        models: g.models.clone(),
        num_clusters: g.num_clusters,
        pvs_offsets,
        pvs_data,
        gvs_cells: Vec::new(),
        gvs_faces: Vec::new(),
        face_draw,
        // Quake 2 textures are external `.wal` files: the BSP does not size them.
        texture_sizes: Vec::new(),
        portal_file: None,
    }
}
