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
//! - **Surfaces**: each group and model is split by [`Surface`] (solid, sky, liquid), so that a
//!   material can draw sky and liquids as Quake does (unlit, liquids from both sides) apart from
//!   the lit walls; a group is one (owning cluster, surface) pair.
//! - Faces with a tool texture (`clip`, `trigger`, `skip`, `hint`, `origin`:
//!   [`TextureKind::draws`]), fewer than three corners or a non-finite corner are not meshed.
//! - Vertices are in Bevy's axes ([`crate::coords`]), in level units, corners reversed so that
//!   the front is counter-clockwise; triangles are fans. Attributes: position, normal (the face
//!   plane's), `UV_0` (Quake's texel coordinates divided by the texture size, or by 64 when the
//!   level has no sizes or no texture axes, then projected on the plane's dominant axis), and a
//!   flat colour per texture name ([`texture_color`]). Indices are `u32`.

use bevy::asset::RenderAssetUsages;
use bevy::ecs::component::Component;
use bevy::math::Vec3;
use bevy::mesh::{Indices, Mesh, PrimitiveTopology};
use sightline_formats::texture::TextureKind;
use sightline_runtime::{DrawData, FaceView, World};

use crate::coords::to_bevy;

/// Texels per texture repeat when the level does not size its textures.
const DEFAULT_TEXTURE_SIZE: f32 = 64.0;

/// What a mesh's faces are, from their texture names ([`TextureKind`]); set on every spawned
/// level mesh, for materials to tell them apart.
#[derive(Component, Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub enum Surface {
    /// Walls, floors, everything lit.
    #[default]
    Solid,
    /// `sky…`: drawn by Quake without lighting.
    Sky,
    /// `*…` (water, slime, lava): drawn by Quake without lighting, and seen from both sides.
    Liquid,
}

impl Surface {
    /// The surface of a texture name.
    pub fn of(name: &str) -> Self {
        match TextureKind::of(name) {
            TextureKind::Sky => Surface::Sky,
            TextureKind::Water | TextureKind::Slime | TextureKind::Lava => Surface::Liquid,
            _ => Surface::Solid,
        }
    }

    /// Every surface, in mesh order.
    pub const ALL: [Surface; 3] = [Surface::Solid, Surface::Sky, Surface::Liquid];

    /// Index in [`Surface::ALL`].
    fn index(self) -> usize {
        self as usize
    }
}

/// One mesh of world faces of one surface, and the clusters it is seen from.
#[derive(Debug, Clone)]
pub struct MeshGroup {
    /// Clusters whose leaves list one of its faces, ascending; empty for the groups that are
    /// never culled.
    pub clusters: Vec<u32>,
    /// What its faces are.
    pub surface: Surface,
    /// The faces.
    pub mesh: Mesh,
}

/// One brush model's mesh of one surface (a door, a lift), as compiled (not moved by its entity).
#[derive(Debug, Clone)]
pub struct ModelMesh {
    /// Its model number (`*N` in the entity text; `1..`).
    pub model: u32,
    /// What its faces are.
    pub surface: Surface,
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

/// A mesh's buffers, one per [`Surface`].
#[derive(Default)]
struct BySurface([Buffers; 3]);

impl BySurface {
    /// Append face `face` to its surface's buffers (see [`Buffers::push_face`]).
    fn push_face(&mut self, draw: &DrawData, face: &FaceView<'_>) {
        let surface = Surface::of(draw.texture_name(face.texture).unwrap_or(""));
        if let Some(b) = self.0.get_mut(surface.index()) {
            b.push_face(draw, face);
        }
    }

    /// The meshes of the surfaces that have faces, in [`Surface::ALL`] order.
    fn into_meshes(self) -> impl Iterator<Item = (Surface, Mesh)> {
        Surface::ALL
            .into_iter()
            .zip(self.0)
            .filter(|(_, b)| !b.positions.is_empty())
            .map(|(s, b)| (s, b.into_mesh()))
    }
}

/// The meshes of `world`; see the module docs. Deterministic: groups ascend by owning cluster
/// (the never-culled groups last), then by surface; models by number, then by surface.
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
    // One slot per owning cluster: the clusters it is seen from, and its faces by surface.
    let mut slots: Vec<(Vec<u32>, BySurface)> = Vec::new();
    let mut slot_of_cluster = vec![u32::MAX; world.num_clusters() as usize];
    for &(o, c) in &seen_from {
        let Some(slot) = slot_of_cluster.get_mut(o as usize) else { continue };
        if *slot == u32::MAX {
            *slot = slots.len() as u32;
            slots.push((Vec::new(), BySurface::default()));
        }
        if let Some((clusters, _)) = slots.get_mut(*slot as usize) {
            clusters.push(c);
        }
    }
    let mut unlisted = BySurface::default();
    for f in world_faces.clone() {
        let Some(face) = draw.face(f) else { continue };
        let slot = owner.get(f as usize).and_then(|&o| slot_of_cluster.get(o as usize)).copied();
        match slot.and_then(|s| slots.get_mut(s as usize)) {
            Some((_, b)) => b.push_face(draw, &face),
            None => unlisted.push_face(draw, &face),
        }
    }
    // A cluster whose faces are all tool textures meshes nothing: no group for it.
    let mut groups: Vec<MeshGroup> = Vec::new();
    for (clusters, b) in slots {
        for (surface, mesh) in b.into_meshes() {
            groups.push(MeshGroup { clusters: clusters.clone(), surface, mesh });
        }
    }
    for (surface, mesh) in unlisted.into_meshes() {
        groups.push(MeshGroup { clusters: Vec::new(), surface, mesh });
    }
    let mut models = Vec::new();
    for (m, model) in draw.models().iter().enumerate().skip(1) {
        let mut b = BySurface::default();
        for f in model.faces.clone() {
            if let Some(face) = draw.face(f) {
                b.push_face(draw, &face);
            }
        }
        for (surface, mesh) in b.into_meshes() {
            models.push(ModelMesh { model: m as u32, surface, mesh });
        }
    }
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
        assert!(built.groups.iter().all(|g| g.surface == Surface::Solid));
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

    /// On a level with texture names (id's E1M1: sky, water, slime), every drawn world face of
    /// each surface is meshed in groups of that surface, corner for corner.
    #[test]
    fn sky_and_liquid_faces_are_meshed_in_groups_of_their_surface() {
        let Some(path) = sightline_tests::shared_map("id_bsp_orig/e1m1.bsp") else { return };
        let world = sightline_runtime::load::load_path(&path).expect("id's E1M1 loads");
        let draw = world.draw();
        let mut want = [0usize; 3];
        for f in draw.models()[0].faces.clone() {
            let face = draw.face(f).expect("face");
            let name = draw.texture_name(face.texture).unwrap_or("");
            if face.vertices.len() >= 3 && TextureKind::of(name).draws() {
                want[Surface::of(name).index()] += face.vertices.len();
            }
        }
        let mut got = [0usize; 3];
        for g in &build(&world).groups {
            got[g.surface.index()] += g.mesh.count_vertices();
        }
        assert_eq!(got, want);
        assert!(want[Surface::Sky.index()] > 0 && want[Surface::Liquid.index()] > 0, "{want:?}");
    }

    #[test]
    fn texture_colours_are_stable_and_tool_textures_are_not_meshed() {
        assert_eq!(texture_color("WALL1"), texture_color("wall1"));
        assert_ne!(texture_color("wall1"), texture_color("wall2"));
        assert!(!TextureKind::of("trigger").draws() && TextureKind::of("sky1").draws());
    }
}
