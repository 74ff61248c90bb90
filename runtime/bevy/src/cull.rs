//! Per-camera PVS culling: after Bevy's own visibility check has filled each view's
//! `VisibleEntities`, the plugin removes, **from the lists of cameras with [`PvsCamera`] only**,
//! the level's entities that no sightline from the eye can reach. Other cameras, shadow views and
//! `ViewVisibility` are left alone, so a light still casts the shadow of a hidden mesh.
//!
//! # What one frame does, per camera
//! 1. The eye (the camera's translation) and the frustum (its `Projection` and
//!    `GlobalTransform`, the planes Bevy culls with) are mapped into the level's space: through the
//!    inverse of the [`LevelRoot`]'s `GlobalTransform`, then to Quake's axes ([`crate::coords`]).
//! 2. The eye leaf: in solid, outside the world, or in a level without visdata, nothing is hidden
//!    (as in Quake). Otherwise the runtime's PVS backend walks the eye cluster's PVS front to back,
//!    keeping the leaves whose boxes meet the frustum.
//! 3. A [`ClusterMesh`] stays when one of its clusters has a kept leaf (the never-culled group
//!    always stays); a [`PvsCulled`] entity stays when one of the leaves its box touches
//!    ([`TouchedLeaves`]) is kept, when one of them has no cluster, or when it touches none (it is
//!    out of the level: not the level's to hide). Every other entity is untouched.
//!
//! Rounding goes toward visible: the leaves an entity touches are found with the runtime's
//! conservative box descent, and a leaf is kept when its box reaches into the frustum at all.
//!
//! No allocation per frame once warm: each camera keeps its runtime scratch, output lists and
//! bit sets in [`PvsCameraState`], and an entity's leaf list is reused when it moves.

use std::time::{Duration, Instant};

use bevy::asset::Assets;
use bevy::camera::primitives::Aabb;
use bevy::camera::visibility::VisibleEntities;
use bevy::camera::{Camera, Projection};
use bevy::ecs::prelude::*;
use bevy::math::{Affine3A, Mat4, Vec3A};
use bevy::transform::components::GlobalTransform;
use sightline_runtime::backend::{Backend, pvs::Pvs};
use sightline_runtime::camera::ClipDepth;
use sightline_runtime::{Bitset, Scratch, View, Visible, World};

use crate::asset::LevelAsset;
use crate::components::{ClusterMesh, LevelRoot, LevelSpawned, PvsCulled, TouchedLeaves};
use crate::coords::bevy_from_quake;

/// Opts a camera in to PVS culling. `freeze: true` keeps culling with the eye and frustum of the
/// frame it was set on, so one can fly out and look at what was drawn; setting it back to `false`
/// resumes. `off: true` hides nothing but still counts (its [`ViewStats::drawn`] is then every
/// level mesh Bevy's frustum kept), to show what the culling saves.
#[derive(Component, Debug, Clone, Copy, Default, PartialEq, Eq)]
#[require(PvsCameraState)]
pub struct PvsCamera {
    /// Keep the view of the frame this was set on.
    pub freeze: bool,
    /// Hide nothing (count only).
    pub off: bool,
}

/// A [`PvsCamera`]'s working memory and its last frame's counts.
#[derive(Component, Debug, Default)]
pub struct PvsCameraState {
    scratch: Scratch,
    visible: Visible,
    leaves: Bitset,
    clusters: Bitset,
    frozen: Option<View>,
    stats: ViewStats,
}

impl PvsCameraState {
    /// What the last frame did for this camera.
    pub fn stats(&self) -> ViewStats {
        self.stats
    }

    /// The frozen eye, in the level's Quake-axis space, while [`PvsCamera::freeze`] is set.
    pub fn frozen_eye(&self) -> Option<[f32; 3]> {
        self.frozen.map(|v| v.eye.to_array())
    }
}

/// One camera's last frame.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ViewStats {
    /// False when nothing was hidden on purpose (no level, eye in solid or outside, no visdata,
    /// [`PvsCamera::off`]).
    pub culled: bool,
    /// The eye's cluster (`None`: no level, eye in solid or outside, no visdata).
    pub cluster: Option<u32>,
    /// The plugin's entities (cluster meshes and [`PvsCulled`]) left in the view's lists.
    pub drawn: u32,
    /// The plugin's entities removed from them.
    pub hidden: u32,
    /// Leaves of the PVS walk (PVS and frustum).
    pub leaves: u32,
}

/// Totals of the last frame over every [`PvsCamera`], and the plugin's time.
#[derive(Resource, Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CullStats {
    /// Cameras culled.
    pub cameras: u32,
    /// Entities left in the views' lists (summed over cameras).
    pub drawn: u32,
    /// Entities removed from them.
    pub hidden: u32,
    /// Time in the leaf update of moved [`PvsCulled`] entities.
    pub leaves_time: Duration,
    /// Time in the per-camera culling.
    pub cull_time: Duration,
}

/// The spawned level roots.
type Roots<'w, 's> =
    Query<'w, 's, (Entity, &'static LevelRoot, Ref<'static, GlobalTransform>), With<LevelSpawned>>;

/// What the leaf update reads and writes of a [`PvsCulled`] entity.
type Placed = (Ref<'static, GlobalTransform>, Option<Ref<'static, Aabb>>, &'static mut TouchedLeaves);

/// What the culling reads and writes of a [`PvsCamera`].
type CameraItem = (
    &'static Camera,
    &'static PvsCamera,
    &'static mut PvsCameraState,
    &'static mut VisibleEntities,
    &'static GlobalTransform,
    &'static Projection,
);

/// The one level the plugin culls against: its root, asset and level-from-world map.
fn active_level<'a>(
    roots: &Roots,
    levels: &'a Assets<LevelAsset>,
    warned: &mut bool,
) -> Option<(Entity, &'a LevelAsset, Affine3A, bool)> {
    let mut iter = roots.iter();
    let (root, handle, transform) = iter.next()?;
    if iter.next().is_some() {
        if !*warned {
            tracing::warn!("sightline: more than one LevelRoot is spawned; PVS culling is off");
            *warned = true;
        }
        return None;
    }
    let level = levels.get(&handle.0)?;
    // Quake axes of the level from Bevy's world: undo the root's placement, then the axes.
    let quake_from_world = bevy_from_quake().inverse() * transform.affine().inverse();
    Some((root, level, quake_from_world, transform.is_changed()))
}

/// Find again the leaves of [`PvsCulled`] entities that moved (or all, when the level did).
pub(crate) fn update_touched_leaves(
    roots: Roots,
    levels: Res<Assets<LevelAsset>>,
    mut entities: Query<Placed, With<PvsCulled>>,
    mut stats: ResMut<CullStats>,
    mut warned: Local<bool>,
) {
    let start = Instant::now();
    if let Some((root, level, quake_from_world, root_moved)) = active_level(&roots, &levels, &mut warned) {
        let world = level.world();
        for (transform, aabb, mut touched) in &mut entities {
            let moved = transform.is_changed() || aabb.as_ref().is_some_and(|a| a.is_changed());
            if !(moved || root_moved || touched.level != Some(root)) {
                continue;
            }
            let (center, half) = aabb.map_or((Vec3A::ZERO, Vec3A::ZERO), |a| (a.center, a.half_extents));
            let m = quake_from_world * transform.affine();
            let c = m.transform_point3a(center);
            let h = m.matrix3.abs() * half;
            let touched = touched.as_mut();
            touched.level = Some(root);
            world.leaves_touching((c - h).to_array(), (c + h).to_array(), &mut touched.leaves);
        }
    }
    stats.leaves_time = start.elapsed();
}

/// The culling system; see the module docs.
pub(crate) fn cull_views(
    roots: Roots,
    levels: Res<Assets<LevelAsset>>,
    mut cameras: Query<CameraItem>,
    cluster_meshes: Query<&ClusterMesh>,
    touched: Query<&TouchedLeaves, With<PvsCulled>>,
    mut stats: ResMut<CullStats>,
    mut warned: Local<bool>,
) {
    let start = Instant::now();
    let level = active_level(&roots, &levels, &mut warned);
    let (mut cameras_culled, mut drawn, mut hidden) = (0, 0, 0);
    for (camera, settings, mut state, mut visible_entities, transform, projection) in &mut cameras {
        if !camera.is_active {
            continue;
        }
        cameras_culled += 1;
        let state = state.as_mut();
        let Some((root, level, quake_from_world, _)) = level else {
            state.frozen = None;
            state.stats = ViewStats::default();
            continue;
        };
        let world: &World = level.world();
        let group_clusters = |e: Entity| {
            let mesh = cluster_meshes.get(e).ok().filter(|m| m.level == root)?;
            level.groups().get(mesh.group as usize).map(|g| g.clusters.as_slice())
        };
        let view = match (settings.freeze, state.frozen) {
            (true, Some(view)) => view,
            (freeze, _) => {
                let view = level_view(quake_from_world, transform, projection);
                state.frozen = freeze.then_some(view);
                view
            }
        };
        let eye_cluster = world.leaf_cluster(world.leaf_at(view.eye)).filter(|_| world.has_vis());
        let mut view_stats = ViewStats { cluster: eye_cluster, ..ViewStats::default() };
        if eye_cluster.is_none() || settings.off {
            // Eye in solid or outside the world, no visdata, or culling off: everything stays.
            for list in visible_entities.entities.values() {
                view_stats.drawn +=
                    list.iter().filter(|&&e| group_clusters(e).is_some() || touched.contains(e)).count()
                        as u32;
            }
            state.stats = view_stats;
            drawn += view_stats.drawn;
            continue;
        }
        Pvs.cull(world, &view, &mut state.scratch, &mut state.visible);
        state.leaves.reset(world.num_leaves());
        state.clusters.reset(world.num_clusters() as usize);
        for &leaf in &state.visible.leaves {
            state.leaves.set(leaf as usize);
            if let Some(c) = world.leaf_cluster(leaf) {
                state.clusters.set(c as usize);
            }
        }
        let (leaves, clusters) = (&state.leaves, &state.clusters);
        let keep = |e: Entity| -> Option<bool> {
            if let Some(groups) = group_clusters(e) {
                return Some(groups.is_empty() || groups.iter().any(|&c| clusters.get(c as usize)));
            }
            let t = touched.get(e).ok()?;
            Some(
                t.level != Some(root)
                    || t.leaves.is_empty()
                    || t.leaves.iter().any(|&l| leaves.get(l as usize) || world.leaf_cluster(l).is_none()),
            )
        };
        for list in visible_entities.entities.values_mut() {
            list.retain(|&e| match keep(e) {
                Some(true) => {
                    view_stats.drawn += 1;
                    true
                }
                Some(false) => {
                    view_stats.hidden += 1;
                    false
                }
                None => true,
            });
        }
        view_stats.culled = true;
        view_stats.leaves = state.visible.leaves.len() as u32;
        state.stats = view_stats;
        drawn += view_stats.drawn;
        hidden += view_stats.hidden;
    }
    stats.cameras = cameras_culled;
    stats.drawn = drawn;
    stats.hidden = hidden;
    stats.cull_time = start.elapsed();
}

/// The camera's eye and frustum in the level's Quake-axis space. The projection is Bevy's
/// (reverse depth: `1` at the near plane, `0` at the far one or at infinity); its two depth
/// planes come out of the Gribb–Hartmann rows as the runtime's `ZeroToOne` near and far, swapped,
/// which bound the same space. An infinite far plane has a zero normal and culls nothing.
fn level_view(quake_from_world: Affine3A, camera: &GlobalTransform, projection: &Projection) -> View {
    let world_from_quake = quake_from_world.inverse();
    let clip_from_quake = projection.get_clip_from_view()
        * Mat4::from(camera.affine().inverse())
        * Mat4::from(world_from_quake);
    let eye = quake_from_world.transform_point3(camera.translation());
    View::from_view_projection(
        glam::Vec3::from_array(eye.to_array()),
        glam::Mat4::from_cols_array(&clip_from_quake.to_cols_array()),
        ClipDepth::ZeroToOne,
    )
}
