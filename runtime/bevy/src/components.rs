//! The plugin's components, shared by spawning ([`crate::spawn`]) and culling ([`crate::cull`]):
//! the level root and the meshes spawned under it, and the marker of entities culled by the
//! leaves they touch.

use bevy::asset::Handle;
use bevy::camera::visibility::Visibility;
use bevy::ecs::prelude::*;
use bevy::transform::components::Transform;
use sightline_runtime::LeafId;

use crate::asset::LevelAsset;

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

/// Marks an entity (a monster, a pickup, a brush model) to be culled by the level leaves its
/// world-space `Aabb` touches (its translation alone when it has no `Aabb`). The leaves are found
/// again only when its `GlobalTransform` or `Aabb` changes, or the level does.
#[derive(Component, Debug, Clone, Copy, Default)]
#[require(TouchedLeaves)]
pub struct PvsCulled;

/// The open leaves of the level that a [`PvsCulled`] entity's box touches (kept by the plugin).
#[derive(Component, Debug, Clone, Default)]
pub struct TouchedLeaves {
    pub(crate) leaves: Vec<LeafId>,
    /// The level root they were found in.
    pub(crate) level: Option<Entity>,
}

impl TouchedLeaves {
    /// The leaves, in the runtime's leaf numbering (empty: outside the level, or not yet placed).
    pub fn leaves(&self) -> &[LeafId] {
        &self.leaves
    }
}
