//! `sightline-bevy`: Quake-family levels in Bevy, culled per camera by their PVS.
//!
//! ```no_run
//! use bevy::prelude::*;
//! use sightline_bevy::{LevelRoot, PvsCamera, PvsCulled, SightlinePlugin};
//!
//! fn setup(mut commands: Commands, assets: Res<AssetServer>) {
//!     commands.spawn(LevelRoot(assets.load("maps/e1m1.bsp")));
//!     commands.spawn((Camera3d::default(), PvsCamera::default(), Transform::from_xyz(480.0, 88.0, 352.0)));
//!     // A monster: culled by the leaves its box touches.
//!     // commands.spawn((Mesh3d(..), MeshMaterial3d(..), PvsCulled, Transform::from_xyz(..)));
//! }
//! # let _ = (setup, PvsCulled);
//! ```
//!
//! - [`SightlinePlugin`] registers the [`LevelAsset`] type and its loader ([`LevelLoader`]:
//!   `.bsp`, `.slvl`), spawns a [`LevelRoot`]'s meshes when loaded ([`crate::spawn`]; the
//!   components are in [`crate::components`]), keeps
//!   the leaves of [`PvsCulled`] entities, and culls the views of [`PvsCamera`]s ([`crate::cull`]).
//! - Coordinates: Quake's Z-up axes become Bevy's Y-up ones by the one rule in [`crate::coords`].
//! - Systems run in `PostUpdate`, in [`SightlineSystems`], which you can order against.
//! - With feature `pbr`, [`material::LevelMaterialPlugin`] gives the level's meshes a
//!   vertex-coloured checker material.

#![forbid(unsafe_code)]

pub mod asset;
pub mod components;
pub mod coords;
pub mod cull;
#[cfg(feature = "pbr")]
pub mod material;
pub mod mesh;
pub mod spawn;

use bevy::app::{App, Plugin, PostUpdate};
use bevy::asset::{AssetApp, AssetEventSystems};
use bevy::camera::visibility::VisibilitySystems;
use bevy::ecs::schedule::{IntoScheduleConfigs, SystemSet};
use bevy::transform::TransformSystems;

pub use asset::{GroupMesh, LevelAsset, LevelLoadError, LevelLoader, ModelPart};
pub use components::{BrushModelMesh, ClusterMesh, LevelRoot, LevelSpawned, PvsCulled, TouchedLeaves};
pub use cull::{CullStats, PvsCamera, PvsCameraState, ViewStats};
pub use mesh::Surface;

/// The plugin's systems, all in `PostUpdate`, in this order.
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SightlineSystems {
    /// Spawn the meshes of loaded levels (before transforms propagate).
    Spawn,
    /// Find the leaves of moved [`PvsCulled`] entities (after transforms and bounds).
    UpdateLeaves,
    /// Filter each [`PvsCamera`]'s `VisibleEntities` (after Bevy's visibility check).
    Cull,
}

/// Registers the level asset and loader, and the spawn, leaf and culling systems; needs Bevy's
/// asset, mesh, transform and camera plugins (all in `DefaultPlugins`).
#[derive(Debug, Clone, Copy, Default)]
pub struct SightlinePlugin;

impl Plugin for SightlinePlugin {
    fn build(&self, app: &mut App) {
        app.init_asset::<LevelAsset>()
            .register_asset_loader(LevelLoader)
            .init_resource::<CullStats>()
            .configure_sets(
                PostUpdate,
                (
                    SightlineSystems::Spawn.after(AssetEventSystems).before(TransformSystems::Propagate),
                    SightlineSystems::UpdateLeaves
                        .after(TransformSystems::Propagate)
                        .after(VisibilitySystems::CalculateBounds)
                        .before(VisibilitySystems::CheckVisibility),
                    SightlineSystems::Cull
                        .after(VisibilitySystems::CheckVisibility)
                        .after(SightlineSystems::UpdateLeaves)
                        .before(VisibilitySystems::MarkNewlyHiddenEntitiesInvisible),
                ),
            )
            .add_systems(
                PostUpdate,
                (
                    spawn::spawn_levels.in_set(SightlineSystems::Spawn),
                    cull::update_touched_leaves.in_set(SightlineSystems::UpdateLeaves),
                    cull::cull_views.in_set(SightlineSystems::Cull),
                ),
            );
    }
}
