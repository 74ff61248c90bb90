//! Draw data: the faces, textures and brush models an engine draws, in the index spaces the
//! culling results use ([`crate::Visible::faces`], [`crate::World::leaf_faces`]).
//!
//! # Conventions
//! - **Face index space**: face `i` is face `i` of the source [`Level`] (`Level::faces`). For a
//!   level loaded from a Quake `.bsp` that is face `i` of the BSP ([`sightline_formats::bsp::to_level`]
//!   keeps the order), so a BSP engine can use its own face tables with these indices.
//! - **Vertices** are world units (`f32`), **clockwise seen from the front** of the face's plane
//!   (Quake's order); the face is seen from the front, where `normal · p - dist > 0`. A BSP face
//!   that Quake stores as seen from the back of its plane comes with the flipped plane.
//! - **Texture projection** ([`FaceDraw`]): `s = s[0..3] · p + s[3]` and `t = t[0..3] · p + t[3]`
//!   in texels (Quake's texinfo); divide by [`DrawData::texture_size`] for normalised
//!   coordinates. Levels written before draw data existed have none ([`DrawData::face`] gives
//!   `draw: None`).
//! - **Light maps**: `FaceDraw::light_offset` is a byte offset into the source BSP's lighting lump
//!   (the level does not carry light maps); -1 and Sightline's own compiles have none.
//! - **Models**: model 0 is the world; models `1..` are brush entities (doors, lifts) whose faces
//!   are the range [`BrushModel::faces`]. [`BrushModel::origin`] is the `origin` of the entity
//!   whose `"model"` is `"*N"` (zero when there is none), where the engine places the model: a
//!   model built with an origin brush (Quake 2, Quake 3, Half-Life, rotating Quake entities) is
//!   stored around zero and placed at that origin; a model without one sits where it was built.
//!   The entities themselves are [`DrawData::entity_list`] ([`sightline_formats::entities`]).

use std::ops::Range;

use glam::Vec3A;
use sightline_formats::entities::{self, Entity};
use sightline_formats::level::{FaceDraw, Level};

use crate::error::LoadError;
use crate::tree::{Csr, Tree};

/// A face as the engine draws it; see the module docs for the conventions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaceView<'a> {
    /// Unit normal of the face's plane, pointing to the side the face is seen from.
    pub normal: Vec3A,
    /// `normal · p` for points on the face.
    pub dist: f32,
    /// Corners, clockwise seen from the front, world units.
    pub vertices: &'a [[f32; 3]],
    /// Index of its first corner in [`DrawData::vertices`] (the corners are the next
    /// `vertices.len()` entries there), for engines that upload one vertex buffer.
    pub first_vertex: u32,
    /// Index of its texture ([`DrawData::texture_name`]).
    pub texture: u32,
    /// Texture projection and light map, when the level has them.
    pub draw: Option<&'a FaceDraw>,
}

/// A brush model: the world (model 0) or a brush entity.
#[derive(Debug, Clone, PartialEq)]
pub struct BrushModel {
    /// Smallest corner of its bounds, world units (where the model sits as compiled).
    pub mins: Vec3A,
    /// Largest corner of its bounds.
    pub maxs: Vec3A,
    /// Its faces, in the face index space.
    pub faces: Range<u32>,
    /// The `origin` of the entity whose `"model"` is `"*N"` (the last such entity), world units;
    /// zero when no entity names the model or it has no origin.
    pub origin: Vec3A,
}

#[derive(Debug, Clone, Copy)]
struct DFace {
    normal: Vec3A,
    dist: f32,
    first_vertex: u32,
    num_vertices: u32,
    texture: u32,
}

/// The level's draw data, kept by the [`crate::World`] ([`crate::World::draw`]).
#[derive(Debug, Clone, Default)]
pub struct DrawData {
    faces: Vec<DFace>,
    vertices: Vec<[f32; 3]>,
    draw: Vec<FaceDraw>,
    textures: Vec<String>,
    texture_sizes: Vec<[u32; 2]>,
    models: Vec<BrushModel>,
    entities: String,
    entity_list: Vec<Entity>,
    /// Faces of each cluster's world leaves, each once, ascending.
    cluster_faces: Csr,
}

impl DrawData {
    /// From a validated level and its tree (for the cluster lists). Planes come renormalised, so
    /// a face's normal is unit length (a zero normal stays zero). Fails when the entity text does
    /// not parse or a brush entity's origin is not three finite numbers.
    pub(crate) fn new(level: &Level, tree: &Tree) -> Result<Self, LoadError> {
        let entity_list = entities::parse(&level.entities).map_err(LoadError::Entities)?;
        let mut origins = vec![Vec3A::ZERO; level.models.len()];
        for e in &entity_list {
            if let Some(slot) = e.model().and_then(|m| origins.get_mut(m as usize)) {
                *slot = match e.origin() {
                    Some(o) => Vec3A::from_array(o.map_err(LoadError::Entities)?),
                    None => Vec3A::ZERO,
                };
            }
        }
        let faces = level
            .faces
            .iter()
            .map(|f| {
                let p = level.planes.get(f.plane as usize);
                let n = Vec3A::from_array(p.map_or([0.0; 3], |p| p.normal));
                let len = n.length();
                let scale = if len > 0.0 { 1.0 / len } else { 0.0 };
                DFace {
                    normal: n * scale,
                    dist: p.map_or(0.0, |p| p.dist) * scale,
                    first_vertex: f.first_vertex,
                    num_vertices: f.num_vertices,
                    texture: f.texture,
                }
            })
            .collect();
        let models = level
            .models
            .iter()
            .zip(origins)
            .map(|(m, origin)| BrushModel {
                mins: Vec3A::from_array(m.mins),
                maxs: Vec3A::from_array(m.maxs),
                faces: m.first_face..m.first_face.saturating_add(m.num_faces),
                origin,
            })
            .collect();
        let mut entries = Vec::new();
        for cluster in 0..tree.num_clusters {
            for &leaf in tree.cluster_leaves.get(cluster as usize) {
                if let Some(l) = tree.leaves.get(leaf as usize) {
                    let first = l.first_face as usize;
                    let list = tree.leaf_faces.get(first..first + l.num_faces as usize).unwrap_or(&[]);
                    entries.extend(list.iter().map(|&f| (cluster, f)));
                }
            }
        }
        entries.sort_unstable();
        entries.dedup();
        Ok(Self {
            faces,
            vertices: level.vertices.clone(),
            draw: level.face_draw.clone(),
            textures: level.textures.clone(),
            texture_sizes: level.texture_sizes.clone(),
            models,
            entities: level.entities.clone(),
            entity_list,
            cluster_faces: Csr::build(tree.num_clusters as usize, &entries),
        })
    }

    /// Number of faces (face indices are `0..num_faces`).
    pub fn num_faces(&self) -> usize {
        self.faces.len()
    }

    /// Face `face`; `None` when out of range.
    pub fn face(&self, face: u32) -> Option<FaceView<'_>> {
        let f = self.faces.get(face as usize)?;
        let start = f.first_vertex as usize;
        Some(FaceView {
            normal: f.normal,
            dist: f.dist,
            vertices: self.vertices.get(start..start + f.num_vertices as usize).unwrap_or(&[]),
            first_vertex: f.first_vertex,
            texture: f.texture,
            draw: self.draw.get(face as usize),
        })
    }

    /// Every face's corners in one array (world units): face `f`'s are
    /// `vertices()[first_vertex..first_vertex + n]` ([`FaceView::first_vertex`]).
    pub fn vertices(&self) -> &[[f32; 3]] {
        &self.vertices
    }

    /// The plane of face `face` as `(normal, dist)`; `None` when out of range.
    #[inline]
    pub fn face_plane(&self, face: u32) -> Option<(Vec3A, f32)> {
        self.faces.get(face as usize).map(|f| (f.normal, f.dist))
    }

    /// True when faces carry texture projections ([`FaceView::draw`] is `Some`).
    pub fn has_face_draw(&self) -> bool {
        !self.draw.is_empty()
    }

    /// Number of textures.
    pub fn num_textures(&self) -> usize {
        self.textures.len()
    }

    /// Name of texture `texture` (empty for a texture missing from a BSP); `None` when out of
    /// range.
    pub fn texture_name(&self, texture: u32) -> Option<&str> {
        self.textures.get(texture as usize).map(String::as_str)
    }

    /// Size of texture `texture` in texels (`[width, height]`); `None` when out of range or when
    /// the level does not size its textures (a level compiled from a `.map`).
    pub fn texture_size(&self, texture: u32) -> Option<[u32; 2]> {
        self.texture_sizes.get(texture as usize).copied().filter(|&s| s != [0, 0])
    }

    /// The brush models; model 0 is the world.
    pub fn models(&self) -> &[BrushModel] {
        &self.models
    }

    /// The level's entity text (Quake `.map` syntax without brushes).
    pub fn entities(&self) -> &str {
        &self.entities
    }

    /// The entities of [`DrawData::entities`], parsed ([`sightline_formats::entities`]), in text
    /// order.
    pub fn entity_list(&self) -> &[Entity] {
        &self.entity_list
    }

    /// Faces of the world leaves of `cluster`, each once, ascending (empty out of range).
    pub fn cluster_faces(&self, cluster: u32) -> &[u32] {
        self.cluster_faces.get(cluster as usize)
    }
}
