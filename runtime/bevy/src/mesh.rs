//! Bevy meshes from a level's draw data: the world's faces grouped by cluster, and one mesh per
//! brush model.
//!
//! # Conventions
//! - **Groups**: world face `f` (model 0) goes to the group of the lowest cluster whose leaves
//!   list it ([`sightline_runtime::DrawData::cluster_faces`]). A face listed by several clusters
//!   is drawn once, so its group records **every** cluster that lists one of its faces
//!   ([`MeshGroup::clusters`], ascending): the group is potentially visible when any of them is.
//!   World faces no cluster lists (in no open leaf) form a last group with no clusters, which is
//!   never culled.
//! - Faces with a tool texture (`clip`, `trigger`, `skip`, `hint`, `origin`:
//!   [`TextureKind::draws`]), fewer than three corners or a non-finite corner are not meshed.
//! - Vertices are in Bevy's axes ([`crate::coords`]), in level units, corners reversed so that
//!   the front is counter-clockwise; triangles are fans. Attributes: position, normal (the face
//!   plane's), `UV_0` (Quake's texel coordinates divided by the texture size, or by 64 when the
//!   level has no sizes or no texture axes, then projected on the plane's dominant axis), and a
//!   flat colour per texture name ([`texture_color`]). Indices are `u32`.

use bevy::asset::RenderAssetUsages;
use bevy::math::Vec3;
use bevy::mesh::{Indices, Mesh, PrimitiveTopology};
use sightline_formats::texture::TextureKind;
use sightline_runtime::{DrawData, FaceView, World};

use crate::coords::to_bevy;

/// Texels per texture repeat when the level does not size its textures.
const DEFAULT_TEXTURE_SIZE: f32 = 64.0;

/// One mesh of world faces and the clusters it is seen from.
#[derive(Debug, Clone)]
pub struct MeshGroup {
    /// Clusters whose leaves list one of its faces, ascending; empty for the group that is never
    /// culled.
    pub clusters: Vec<u32>,
    /// The faces.
    pub mesh: Mesh,
}

/// One brush model's mesh (a door, a lift), as compiled (not moved by its entity).
#[derive(Debug, Clone)]
pub struct ModelMesh {
    /// Its model number (`*N` in the entity text; `1..`).
    pub model: u32,
    /// The faces.
    pub mesh: Mesh,
}

/// All meshes of a level; see the module docs.
#[derive(Debug, Clone, Default)]
pub struct LevelMeshes {
    /// The world, by cluster.
    pub groups: Vec<MeshGroup>,
    /// Brush models with drawn faces.
    pub models: Vec<ModelMesh>,
}

/// A flat colour for a texture name: sky light blue, liquids by kind, other names a stable hue
/// from the name's bytes (FNV-1a), as linear RGBA.
pub fn texture_color(name: &str) -> [f32; 4] {
    match TextureKind::of(name) {
        TextureKind::Sky => return [0.45, 0.6, 0.95, 1.0],
        TextureKind::Water => return [0.15, 0.3, 0.7, 1.0],
        TextureKind::Slime => return [0.2, 0.6, 0.15, 1.0],
        TextureKind::Lava => return [0.9, 0.3, 0.05, 1.0],
        _ => {}
    }
    let hash = name
        .bytes()
        .map(|b| b.to_ascii_lowercase())
        .fold(0x811c_9dc5u32, |h, b| (h ^ u32::from(b)).wrapping_mul(0x0100_0193));
    let channel = |shift: u32| 0.25 + 0.6 * f32::from((hash >> shift) as u8) / 255.0;
    [channel(0), channel(8), channel(16), 1.0]
}

/// Vertex and index buffers being filled.
#[derive(Default)]
struct Buffers {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    uvs: Vec<[f32; 2]>,
    colors: Vec<[f32; 4]>,
    indices: Vec<u32>,
}

impl Buffers {
    /// Append face `face` unless it is not drawn (see the module docs).
    fn push_face(&mut self, draw: &DrawData, face: &FaceView<'_>) {
        let name = draw.texture_name(face.texture).unwrap_or("");
        let corners = face.vertices;
        if corners.len() < 3
            || !TextureKind::of(name).draws()
            || corners.iter().flatten().any(|c| !c.is_finite())
            || u32::try_from(self.positions.len() + corners.len()).is_err()
        {
            return;
        }
        let size = draw.texture_size(face.texture).map_or([DEFAULT_TEXTURE_SIZE; 2], |s| s.map(|v| v as f32));
        let normal = to_bevy(face.normal.to_array()).to_array();
        let color = texture_color(name);
        let first = self.positions.len() as u32;
        // Reversed: clockwise from the front (Quake) becomes counter-clockwise (Bevy).
        for &p in corners.iter().rev() {
            let [s, t] = texel(face, p);
            self.positions.push(to_bevy(p).to_array());
            self.normals.push(normal);
            self.uvs.push([s / size[0], t / size[1]]);
            self.colors.push(color);
        }
        for i in 1..corners.len() as u32 - 1 {
            self.indices.extend([first, first + i, first + i + 1]);
        }
    }

    fn into_mesh(self) -> Mesh {
        Mesh::new(PrimitiveTopology::TriangleList, RenderAssetUsages::default())
            .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, self.positions)
            .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, self.normals)
            .with_inserted_attribute(Mesh::ATTRIBUTE_UV_0, self.uvs)
            .with_inserted_attribute(Mesh::ATTRIBUTE_COLOR, self.colors)
            .with_inserted_indices(Indices::U32(self.indices))
    }
}

/// Texel coordinates of corner `p`: Quake's texinfo when the face has one, else the corner
/// projected along the plane's dominant axis.
fn texel(face: &FaceView<'_>, p: [f32; 3]) -> [f32; 2] {
    let p = Vec3::from_array(p);
    if let Some(d) = face.draw {
        let axis = |a: [f32; 4]| Vec3::new(a[0], a[1], a[2]).dot(p) + a[3];
        return [axis(d.s), axis(d.t)];
    }
    let n = face.normal.abs();
    if n.z >= n.x && n.z >= n.y {
        [p.x, -p.y]
    } else if n.x >= n.y {
        [p.y, -p.z]
    } else {
        [p.x, -p.z]
    }
}

/// The meshes of `world`; see the module docs. Deterministic: groups ascend by owning cluster
/// (the never-culled group last), models by number.
pub fn build(world: &World) -> LevelMeshes {
    let draw = world.draw();
    let num_faces = draw.num_faces();
    let world_faces = draw.models().first().map_or(0..num_faces as u32, |m| m.faces.clone());
    let in_world = |f: u32| world_faces.contains(&f);
    // Owner: the lowest cluster listing the face.
    let mut owner = vec![u32::MAX; num_faces];
    let mut seen_from: Vec<(u32, u32)> = Vec::new();
    for cluster in 0..world.num_clusters() {
        for &f in draw.cluster_faces(cluster) {
            if let Some(o) = owner.get_mut(f as usize).filter(|_| in_world(f)) {
                if *o == u32::MAX {
                    *o = cluster;
                }
                seen_from.push((*o, cluster));
            }
        }
    }
    seen_from.sort_unstable();
    seen_from.dedup();
    let mut buffers: Vec<Buffers> = Vec::new();
    let mut group_of_cluster = vec![u32::MAX; world.num_clusters() as usize];
    let mut groups: Vec<MeshGroup> = Vec::new();
    for &(o, c) in &seen_from {
        let Some(slot) = group_of_cluster.get_mut(o as usize) else { continue };
        if *slot == u32::MAX {
            *slot = groups.len() as u32;
            groups.push(MeshGroup {
                clusters: Vec::new(),
                mesh: Mesh::new(PrimitiveTopology::TriangleList, RenderAssetUsages::default()),
            });
            buffers.push(Buffers::default());
        }
        if let Some(g) = groups.get_mut(*slot as usize) {
            g.clusters.push(c);
        }
    }
    let mut unlisted = Buffers::default();
    for f in world_faces.clone() {
        let Some(face) = draw.face(f) else { continue };
        let group = owner.get(f as usize).and_then(|&o| group_of_cluster.get(o as usize)).copied();
        match group.and_then(|g| buffers.get_mut(g as usize)) {
            Some(b) => b.push_face(draw, &face),
            None => unlisted.push_face(draw, &face),
        }
    }
    for (g, b) in groups.iter_mut().zip(buffers) {
        g.mesh = b.into_mesh();
    }
    // A cluster whose faces are all tool textures meshes nothing: no entity for it.
    groups.retain(|g| g.mesh.count_vertices() > 0);
    if !unlisted.positions.is_empty() {
        groups.push(MeshGroup { clusters: Vec::new(), mesh: unlisted.into_mesh() });
    }
    let models = draw
        .models()
        .iter()
        .enumerate()
        .skip(1)
        .filter_map(|(m, model)| {
            let mut b = Buffers::default();
            for f in model.faces.clone() {
                if let Some(face) = draw.face(f) {
                    b.push_face(draw, &face);
                }
            }
            (!b.positions.is_empty()).then(|| ModelMesh { model: m as u32, mesh: b.into_mesh() })
        })
        .collect();
    LevelMeshes { groups, models }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::mesh::VertexAttributeValues;
    use sightline_tests::synth::grid_level;

    /// Three open cells in a row; cell 1's leaf also lists a face of cell 0 (as a leaf lists a
    /// face it shares with a neighbour).
    fn shared_face_world() -> World {
        let mut level = grid_level([3, 1, 1], 64.0, true, |_, _, _| false);
        let (l0, l1) = (level.leaves[0], level.leaves[1]);
        let first = l1.first_face as usize;
        let mut list = level.leaf_faces[first..first + l1.num_faces as usize].to_vec();
        list.push(level.leaf_faces[l0.first_face as usize]);
        level.leaves[1].first_face = level.leaf_faces.len() as u32;
        level.leaves[1].num_faces = list.len() as u32;
        level.leaf_faces.extend(list);
        World::new(&level).expect("valid")
    }

    #[test]
    fn a_face_is_meshed_once_and_its_group_is_seen_from_every_cluster_listing_it() {
        let world = shared_face_world();
        let built = build(&world);
        let clusters: Vec<Vec<u32>> = built.groups.iter().map(|g| g.clusters.clone()).collect();
        assert_eq!(clusters, vec![vec![0, 1], vec![1], vec![2]]);
        // Every face once: four corners and two triangles each.
        let corners: usize = built.groups.iter().map(|g| g.mesh.count_vertices()).sum();
        assert_eq!(corners, 4 * world.draw().num_faces());
        assert!(built.models.is_empty());
    }

    /// On a real map (Quake's order: clockwise from the front), every triangle of every mesh
    /// turns counter-clockwise around its normal, as Bevy's front faces do.
    #[test]
    fn corners_turn_counter_clockwise_around_the_normal_in_bevy_axes() {
        let Some(path) = sightline_tests::shared_maps().map(|d| d.join("ericw/e1m1.vis.bsp")) else {
            eprintln!("note: real maps not found (set SIGHTLINE_MAPS); the winding check is not run");
            return;
        };
        let Ok(world) = sightline_runtime::load::load_path(&path) else {
            eprintln!("note: {} missing; the winding check is not run", path.display());
            return;
        };
        let built = build(&world);
        let meshes = built.groups.iter().map(|g| &g.mesh).chain(built.models.iter().map(|m| &m.mesh));
        let mut triangles = 0;
        for mesh in meshes {
            let Some(VertexAttributeValues::Float32x3(p)) = mesh.attribute(Mesh::ATTRIBUTE_POSITION) else {
                panic!("positions")
            };
            let Some(VertexAttributeValues::Float32x3(n)) = mesh.attribute(Mesh::ATTRIBUTE_NORMAL) else {
                panic!("normals")
            };
            let Some(Indices::U32(idx)) = mesh.indices() else { panic!("indices") };
            for t in idx.chunks(3) {
                let [a, b, c] = [t[0], t[1], t[2]].map(|i| Vec3::from_array(p[i as usize]));
                let normal = Vec3::from_array(n[t[0] as usize]);
                // Slivers (collinear corners, common in Quake faces) have no reliable turn;
                // every other triangle must face its normal.
                let turn = (b - a).cross(c - a);
                if turn.length() > 1e-3 * (b - a).length() * (c - a).length() {
                    assert!(turn.dot(normal) > 0.0, "triangle {t:?} faces away from its normal");
                    triangles += 1;
                }
            }
        }
        assert!(triangles > 1000, "{triangles} triangles checked");
    }

    #[test]
    fn texture_colours_are_stable_and_tool_textures_are_not_meshed() {
        assert_eq!(texture_color("WALL1"), texture_color("wall1"));
        assert_ne!(texture_color("wall1"), texture_color("wall2"));
        assert!(!TextureKind::of("trigger").draws() && TextureKind::of("sky1").draws());
    }
}
