//! Spawning a loaded level: a [`LevelRoot`] entity gets, once its [`LevelAsset`] is loaded, one
//! child per world mesh group ([`ClusterMesh`]) and one per brush model and surface
//! ([`BrushModelMesh`]), each with its [`crate::mesh::Surface`].
//!
//! Children sit at the identity relative to the root, so the root's `Transform` places (and may
//! scale) the whole level; a brush model's own `Transform` is the offset its entity moves it by
//! (a door opening), relative to where it was compiled.

use bevy::asset::Assets;
use bevy::ecs::prelude::*;
use bevy::mesh::Mesh3d;

use crate::asset::LevelAsset;
use crate::components::{BrushModelMesh, ClusterMesh, LevelRoot, LevelSpawned};

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
                children.spawn((
                    Mesh3d(group.mesh.clone()),
                    ClusterMesh { level: root, group: i as u32 },
                    group.surface,
                ));
            }
            for part in level.models() {
                children.spawn((
                    Mesh3d(part.mesh.clone()),
                    BrushModelMesh { level: root, model: part.model },
                    part.surface,
                ));
            }
        });
    }
}
