//! Turning a Quake BSP into Sightline's [`Level`].

use super::{Bsp, bounds};
use crate::bits;
use crate::level::{Contents, Face, FaceDraw, Leaf, Level, LevelPlane, Model, Node};
use crate::rle;
use std::collections::HashMap;

/// Builds a [`Level`] from a validated BSP.
///
/// - Planes, nodes (children keep Quake's encoding), leaves and models map one to one; leaf `i`
///   of the level is leaf `i` of the BSP, so leaf 0 is the shared solid leaf.
/// - Clusters: the PVS of a BSP has one bit per vis leaf, so vis leaf `i` (`1..=visleafs`) gets
///   cluster `i - 1` and `num_clusters = visleafs`. Leaf 0, solid leaves and the leaves of brush
///   models (beyond `visleafs`) get cluster -1.
/// - PVS: `pvs_data` is the BSP's visdata unchanged and `pvs_offsets[i - 1]` is leaf `i`'s
///   `visofs`; leaves stored with `visofs == -1` ("see everything") share one all-visible row
///   appended to `pvs_data`. A BSP without any row (no vis run) gives a level without PVS.
/// - Faces become polygons with their own corner vertices (surfedges resolved). A face seen from
///   the back of its plane gets a flipped copy of the plane, appended after the BSP's planes, so
///   every level face is seen from its plane's front. Texture names come from the miptex
///   directory; a texture missing from the file (offset -1) has an empty name.
/// - Unknown contents codes (none of Quake's six) become [`Contents::Empty`] (open).
/// - Face `i` of the level is face `i` of the BSP. `face_draw[i]` holds its texinfo's s/t axes
///   and flags (zero axes when one is not finite) and its light styles and lighting offset;
///   `texture_sizes` the miptex sizes.
/// - `leaf_faces` are the BSP's marksurfaces; the level has no portals and no GVS cells.
/// - Node, leaf and model bounds are the stored ones where they are usable; [`bounds`] replaces
///   the others (and [`super::CompiledMap::to_level_with_repairs`] says which).
pub fn to_level(bsp: &Bsp) -> Level {
    let mut level = level_as_stored(bsp);
    bounds::repair(&mut level);
    level
}

/// [`to_level`] with the stored bounds as they are, usable or not.
pub(super) fn level_as_stored(bsp: &Bsp) -> Level {
    let textures: Vec<String> =
        bsp.textures.iter().map(|t| t.as_ref().map(|t| t.name.clone()).unwrap_or_default()).collect();
    let mut polygons = Polygons::new(bsp.planes.iter().map(|p| (p.normal, p.dist)), bsp.faces.len());
    for f in &bsp.faces {
        let corners = bsp.face_vertex_indices(f).map(|v| bsp.vertices[v as usize]);
        polygons.push(f.plane, f.back, corners, bsp.texinfo[f.texinfo as usize].miptex);
    }
    let Polygons { planes, vertices, faces, .. } = polygons;

    let nodes = bsp
        .nodes
        .iter()
        .map(|n| Node { plane: n.plane, children: n.children, mins: n.mins, maxs: n.maxs })
        .collect();
    let visleafs = bsp.visleafs();
    let leaves = bsp
        .leaves
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let contents = Contents::from_code(l.contents).unwrap_or(Contents::Empty);
            let cluster =
                if (1..=visleafs).contains(&i) && contents != Contents::Solid { i as i32 - 1 } else { -1 };
            Leaf {
                contents,
                cluster,
                mins: l.mins,
                maxs: l.maxs,
                first_face: l.first_marksurface,
                num_faces: l.num_marksurfaces,
            }
        })
        .collect();

    let (pvs_offsets, pvs_data) = pvs(bsp, visleafs);
    let models = bsp
        .models
        .iter()
        .map(|m| Model {
            head_node: m.head_nodes[0],
            mins: m.mins,
            maxs: m.maxs,
            first_face: m.first_face,
            num_faces: m.num_faces,
        })
        .collect();
    let face_draw = bsp
        .faces
        .iter()
        .map(|f| {
            let info = &bsp.texinfo[f.texinfo as usize];
            // Texinfo is not checked by `read` (vis never uses it): a non-finite axis becomes
            // "no projection" rather than a level that fails validation.
            let finite = info.vecs.as_flattened().iter().all(|v| v.is_finite());
            let [s, t] = if finite { info.vecs } else { [[0.0; 4]; 2] };
            FaceDraw { s, t, flags: info.flags as u32, styles: f.styles, light_offset: f.light_offset }
        })
        .collect();
    let texture_sizes =
        bsp.textures.iter().map(|t| t.as_ref().map_or([0, 0], |t| [t.width, t.height])).collect();
    Level {
        entities: bsp.entities.clone(),
        textures,
        texture_sizes,
        face_draw,
        planes,
        nodes,
        leaves,
        leaf_faces: bsp.marksurfaces.clone(),
        faces,
        vertices,
        portals: Vec::new(),
        models,
        num_clusters: visleafs as u32,
        pvs_offsets,
        pvs_data,
        gvs_cells: Vec::new(),
        gvs_faces: Vec::new(),
        portal_file: None,
    }
}

/// A BSP's faces as level faces, each with its own corners and seen from its plane's front: a
/// face seen from the back of its plane gets a flipped copy of the plane, appended after the
/// BSP's planes once per plane (Quake 1 and Quake 2 alike).
pub(super) struct Polygons {
    /// The BSP's planes, then the flipped copies.
    pub planes: Vec<LevelPlane>,
    /// Flipped copy of each plane flipped so far.
    flipped: HashMap<u32, u32>,
    /// Corners of every face, back to back.
    pub vertices: Vec<[f32; 3]>,
    /// The faces.
    pub faces: Vec<Face>,
}

impl Polygons {
    /// Starts from the BSP's planes (`(normal, dist)`), for about `faces` faces.
    pub fn new(planes: impl Iterator<Item = ([f32; 3], f32)>, faces: usize) -> Self {
        let planes = planes.map(|(normal, dist)| LevelPlane { normal, dist }).collect();
        Self { planes, flipped: HashMap::new(), vertices: Vec::new(), faces: Vec::with_capacity(faces) }
    }

    /// Adds a face on BSP plane `plane` (checked to exist), seen from its back when `back`.
    pub fn push(&mut self, plane: u32, back: bool, corners: impl Iterator<Item = [f32; 3]>, texture: u32) {
        let plane = if back {
            let planes = &mut self.planes;
            *self.flipped.entry(plane).or_insert_with(|| {
                let p = planes[plane as usize];
                planes.push(LevelPlane { normal: p.normal.map(|c| -c), dist: -p.dist });
                (planes.len() - 1) as u32
            })
        } else {
            plane
        };
        let first_vertex = self.vertices.len() as u32;
        self.vertices.extend(corners);
        let num_vertices = self.vertices.len() as u32 - first_vertex;
        self.faces.push(Face { plane, first_vertex, num_vertices, texture });
    }
}

/// Per-cluster row offsets and row data; empty when no vis leaf has a row.
fn pvs(bsp: &Bsp, visleafs: usize) -> (Vec<u32>, Vec<u8>) {
    let vis_leaves = bsp.leaves.get(1..=visleafs).unwrap_or_default();
    if bsp.visdata.is_empty() || vis_leaves.iter().all(|l| l.visofs < 0) {
        return (Vec::new(), Vec::new());
    }
    let mut data = bsp.visdata.clone();
    let mut all_visible_at = None;
    let offsets = vis_leaves
        .iter()
        .map(|l| match u32::try_from(l.visofs) {
            Ok(ofs) => ofs,
            Err(_) => *all_visible_at.get_or_insert_with(|| {
                let at = data.len() as u32;
                let mut row = vec![0u8; bits::bytes::len(visleafs)];
                bits::bytes::fill_prefix(&mut row, visleafs);
                rle::encode_row(&row, &mut data);
                at
            }),
        })
        .collect();
    (offsets, data)
}
