//! PVS-accelerated ray tracing with a correctness gate (the GVS thesis' §6.4), on levels and (in
//! [`mesh`]) on triangle meshes, whose visible set is the GVS set of the eye's grid cell; [`walk`]
//! makes camera paths for walkthroughs.
//!
//! Primary rays are cast twice on the same rays: against a BVH over the whole world (model 0's
//! faces, fan-triangulated, [`scene::LevelScene`]) and against a BVH over only the faces the eye
//! cluster's PVS names (cluster → PVS clusters → their leaves' faces, [`cells::CellSet`]), built
//! when the camera enters a cluster and cached per cluster ([`cells::CellCache`]).
//!
//! The **gate** ([`gate::compare`]) compares the two per pixel. The PVS set is a subset of the
//! world, so its nearest hit is never nearer; a pixel whose full-scene hit is missing from the
//! PVS set (nothing hit, or something farther) is a visibility bug, reported with the pixel, the
//! triangle and face, the cluster of the hit point and the eye cluster. Two different faces hit at
//! bit-equal distance are a **tie** (a ray through the edge the faces share, both visible; each BVH
//! picks the first it finds): counted, not a failure. So is a **graze** ([`gate::GRAZE`]): the
//! seen face is missing from the PVS set but the ray hits it on its outline, slipping through the
//! zero-width crack where it meets an occluder's edge, which vis rightly treats as closed.
//!
//! # Conventions
//! - Cameras are [`Camera`]s as `sightline render --view` takes them (Quake angles in degrees, the
//!   field of view horizontal); the ray through pixel `(x, y)` starts at the eye and goes through
//!   the pixel's centre ([`Camera::ray`], in `f32`). Hits count for `0 < t`, `t` in units of the
//!   (unnormalised) direction.
//! - Faces are one-sided: a ray meets a face only from its front (the engine culls back faces), so
//!   the two faces of a water surface are each seen from their own side.
//! - Triangles are numbered in the order of [`scene::LevelScene::triangles`] (face order, each
//!   face's fan in order); a PVS set keeps that order.
//! - Only the world model's faces are traced (brush entities such as doors are left out).

pub mod cells;
pub mod frame;
pub mod gate;
pub mod mesh;
pub mod scene;
pub mod shadow;
pub mod walk;

use glam::{DVec3, Vec3};

use crate::ValidateError;
use crate::render::RenderError;
pub use crate::render::view::Camera;

/// What a traced scene is made of: triangles, each of a face (a level's face, or the triangle
/// itself in a mesh).
pub trait Surfaces: Sync {
    /// Every triangle.
    fn triangles(&self) -> &[[Vec3; 3]];
    /// The face of triangle `t`.
    fn face_of(&self, t: u32) -> Option<u32>;
    /// True when a ray meets a triangle only from its front (`(v1 - v0) × (v2 - v0)` towards it).
    fn one_sided(&self) -> bool;
    /// True when face `face` is sky (drawn light blue).
    fn is_sky(&self, face: u32) -> bool {
        let _ = face;
        false
    }
    /// Unit normal of triangle `t` (zero for a degenerate or unknown triangle).
    fn normal(&self, t: u32) -> DVec3 {
        self.triangles().get(t as usize).map_or(DVec3::ZERO, |[a, b, c]| {
            (*b - *a).as_dvec3().cross((*c - *a).as_dvec3()).normalize_or_zero()
        })
    }
}

/// Why a level could not be traced.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum TraceError {
    /// The level's tree or faces are unusable.
    #[error(transparent)]
    Level(#[from] ValidateError),
    /// The camera or picture is unusable (size, field of view, eye in solid or outside clusters).
    #[error(transparent)]
    Camera(#[from] RenderError),
    /// The grid of view cells of a mesh is unusable (cell size).
    #[error("view cells")]
    Grid(#[from] sightline_gvs::cells::GridError),
    /// The GVS parameters of a mesh's cell sets are unusable.
    #[error("GVS parameters")]
    Gvs(#[from] sightline_gvs::ParamError),
    /// The eye of a mesh camera is outside the grid of view cells.
    #[error("eye ({:.2}, {:.2}, {:.2}) is outside the grid of view cells", eye[0], eye[1], eye[2])]
    EyeOutsideGrid {
        /// The eye.
        eye: [f64; 3],
    },
}

use std::sync::Arc;

use self::cells::{CellCache, CellSet};
use self::frame::{Frame, Rays, cast};
use self::gate::{GateReport, compare};
use self::scene::LevelScene;
use crate::pvs::BitMatrix;

/// One camera traced in both modes and gated.
#[derive(Debug, Clone)]
pub struct Traced {
    /// The rays (shared by both modes).
    pub rays: Rays,
    /// Leaf of the eye.
    pub eye_leaf: usize,
    /// Cluster of the eye leaf.
    pub eye_cluster: u32,
    /// The whole scene's frame.
    pub full: Frame,
    /// The eye cluster's PVS set.
    pub set: Arc<CellSet>,
    /// True when the set came from the cache (built for an earlier camera in the same cluster).
    pub cached: bool,
    /// The PVS set's frame.
    pub pvs: Frame,
    /// The gate's verdict.
    pub gate: GateReport,
}

/// Trace `camera` against the whole scene and against its cluster's PVS set (from `cache`, built
/// there on first use), and gate the two.
pub fn trace_camera(
    scene: &LevelScene<'_>,
    pvs: &BitMatrix,
    cache: &mut CellCache,
    camera: &Camera,
) -> Result<Traced, TraceError> {
    let rays = Rays::new(camera)?;
    let tree = scene.tree();
    let eye_leaf = tree.leaf_at(camera.eye);
    if !tree.is_open(eye_leaf) {
        return Err(RenderError::EyeInSolid { eye: camera.eye.to_array(), leaf: eye_leaf }.into());
    }
    let eye_cluster = tree.cluster(eye_leaf).ok_or(RenderError::EyeOutsideClusters)?;
    let (set, cached) = cache.get(scene, pvs, eye_cluster);
    let full = cast(scene, scene.bvh(), None, &rays);
    let reduced = cast(scene, &set.bvh, Some(&set.triangles), &rays);
    let gate = compare(scene, &rays, &full, &reduced);
    Ok(Traced { rays, eye_leaf, eye_cluster, full, set, cached, pvs: reduced, gate })
}
