//! The level as triangles: the world model's faces, fan-triangulated with the face's normal as
//! each triangle's `(v1 - v0) × (v2 - v0)`, with the face of every triangle and a BVH over all
//! of them.

use std::time::{Duration, Instant};

use glam::Vec3;
use sightline_formats::texture::TextureKind;
use sightline_raycast::Bvh;

use super::Surfaces;
use crate::ValidateError;
use crate::bsp::BspTree;
use crate::mesh::{fan, world_faces};

/// The world's triangles and the whole-scene BVH.
#[derive(Debug)]
pub struct LevelScene<'a> {
    tree: &'a BspTree<'a>,
    triangles: Vec<[Vec3; 3]>,
    /// Face (index into the level's faces) of every triangle.
    faces: Vec<u32>,
    /// First triangle of every face of the level (`faces.len() + 1` entries; faces outside the
    /// world model have none).
    face_first: Vec<u32>,
    bvh: Bvh,
    build: Duration,
}

impl<'a> LevelScene<'a> {
    /// Triangulate the world model's faces and build the whole-scene BVH.
    pub fn new(tree: &'a BspTree<'a>) -> Result<Self, ValidateError> {
        let level = tree.level();
        let world = world_faces(level).map_err(|source| ValidateError::Mesh { source })?;
        let (mut triangles, mut faces) = (Vec::new(), Vec::new());
        let mut face_first = vec![0u32; level.faces.len() + 1];
        let mut next = 0;
        for (face, _, corners) in world {
            while next <= face {
                face_first[next] = triangles.len() as u32;
                next += 1;
            }
            // Corners run clockwise seen from the front; the reversed fan runs counter-clockwise,
            // so each triangle's `(v1 - v0) × (v2 - v0)` is the face's normal.
            for [a, b, c] in fan(corners) {
                triangles.push([a, c, b]);
                faces.push(face as u32);
            }
        }
        for f in &mut face_first[next..] {
            *f = triangles.len() as u32;
        }
        if triangles.is_empty() {
            return Err(ValidateError::Mesh { source: crate::mesh::MeshError::NoFaces });
        }
        let start = Instant::now();
        let bvh = Bvh::build(&triangles);
        Ok(Self { tree, triangles, faces, face_first, bvh, build: start.elapsed() })
    }

    /// The level's tree.
    pub fn tree(&self) -> &'a BspTree<'a> {
        self.tree
    }

    /// Every triangle, in face order.
    pub fn triangles(&self) -> &[[Vec3; 3]] {
        &self.triangles
    }

    /// The face of triangle `t`.
    pub fn face_of(&self, t: u32) -> Option<u32> {
        self.faces.get(t as usize).copied()
    }

    /// The triangles of face `face` (empty for faces outside the world model).
    pub fn face_triangles(&self, face: usize) -> std::ops::Range<u32> {
        match (self.face_first.get(face), self.face_first.get(face + 1)) {
            (Some(&a), Some(&b)) => a..b,
            _ => 0..0,
        }
    }

    /// The whole-scene BVH.
    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// How long the whole-scene BVH took to build.
    pub fn build_time(&self) -> Duration {
        self.build
    }

    /// Clusters of the leaves that list face `face` (ascending, each once).
    pub fn face_clusters(&self, face: u32) -> Vec<u32> {
        let level = self.tree.level();
        let mut out: Vec<u32> = (0..level.leaves.len())
            .filter(|&l| {
                let leaf = &level.leaves[l];
                let first = leaf.first_face as usize;
                level
                    .leaf_faces
                    .get(first..first.saturating_add(leaf.num_faces as usize))
                    .is_some_and(|s| s.contains(&face))
            })
            .filter_map(|l| self.tree.cluster(l))
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }
}

impl Surfaces for LevelScene<'_> {
    fn triangles(&self) -> &[[Vec3; 3]] {
        LevelScene::triangles(self)
    }

    fn face_of(&self, t: u32) -> Option<u32> {
        LevelScene::face_of(self, t)
    }

    fn one_sided(&self) -> bool {
        true
    }

    fn is_sky(&self, face: u32) -> bool {
        let level = self.tree.level();
        level
            .faces
            .get(face as usize)
            .and_then(|f| level.textures.get(f.texture as usize))
            .is_some_and(|t| TextureKind::of(t) == TextureKind::Sky)
    }
}
