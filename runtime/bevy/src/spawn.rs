//! Spawning a loaded level: a [`LevelRoot`] entity gets, once its [`LevelAsset`] is loaded, one
//! child per world mesh group ([`ClusterMesh`]) and one per brush model ([`BrushModelMesh`]).
//!
//! Children sit at the identity relative to the root, so the root's `Transform` places (and may
//! scale) the whole level; a brush model's own `Transform` is the offset its entity moves it by
//! (a door opening), relative to where it was compiled.

use bevy::asset::{Assets, Handle};
use bevy::camera::visibility::Visibility;
use bevy::ecs::prelude::*;
use bevy::mesh::Mesh3d;
use bevy::transform::components::Transform;

use crate::asset::LevelAsset;
use crate::cull::PvsCulled;

/// A level in the scene. Spawn it with the level's handle; the plugin spawns its meshes as
/// children when the asset is loaded. The plugin culls against one level at a time: with
/// several spawned roots it hides nothing (and warns once).
#[derive(Component, Debug, Clone)]
#[require(Transform, Visibility)]
pub struct LevelRoot(pub Handle<LevelAsset>);

/// Set by the plugin on a [`LevelRoot`] whose children are spawned.
#[derive(Component, Debug, Clone, Copy, Default)]
pub struct LevelSpawned;

/// A world mesh of a level, culled by the clusters it is seen from
/// ([`crate::asset::GroupMesh::clusters`]).
#[derive(Component, Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClusterMesh {
    /// The [`LevelRoot`] entity.
    pub level: Entity,
    /// Index in [`LevelAsset::groups`].
    pub group: u32,
}

/// A brush model of a level (a door, a lift), culled like any [`PvsCulled`] entity by the leaves
/// its box touches, wherever its `Transform` moves it.
#[derive(Component, Debug, Clone, Copy, PartialEq, Eq)]
#[require(PvsCulled)]
pub struct BrushModelMesh {
    /// The [`LevelRoot`] entity.
    pub level: Entity,
    /// Model number (`*N` in the level's entity text).
    pub model: u32,
}

/// Spawn the children of every level root whose asset has loaded.
pub(crate) fn spawn_levels(
    mut commands: Commands,
    roots: Query<(Entity, &LevelRoot), Without<LevelSpawned>>,
    levels: Res<Assets<LevelAsset>>,
) {
    for (root, handle) in &roots {
        let Some(level) = levels.get(&handle.0) else { continue };
        commands.entity(root).insert(LevelSpawned).with_children(|children| {
            for (i, group) in level.groups().iter().enumerate() {
                children.spawn((Mesh3d(group.mesh.clone()), ClusterMesh { level: root, group: i as u32 }));
            }
            for (model, mesh) in level.models() {
                children.spawn((Mesh3d(mesh.clone()), BrushModelMesh { level: root, model: *model }));
            }
        });
    }
}
