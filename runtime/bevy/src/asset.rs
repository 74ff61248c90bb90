//! The level as a Bevy asset: [`LevelAsset`], loaded from `.bsp` or `.slvl` bytes by
//! [`LevelLoader`], or made from a [`World`] already in memory ([`LevelAsset::from_world`]).
//!
//! # What is loaded
//! - The bytes go to [`sightline_runtime::load::load_bytes`]: a `.slvl` (told by its magic), else
//!   a Quake-family `.bsp` (Quake 1, BSP2, Half-Life, Quake 2, Quake 3) with its own visdata.
//! - A level **without visdata** (an unvised `.bsp`) loads, with a warning: the PVS of every
//!   cluster is then everything, so the plugin hides nothing (the frustum still culls, through
//!   Bevy). A `.prt` beside the `.bsp` is not read: portals would serve the runtime's portal
//!   backend, not the PVS the plugin culls with; run `sightline vis` on the file instead.
//! - The meshes ([`crate::mesh::build`]) are labeled sub-assets: `group{i}` for the world's
//!   cluster groups and `model{N}` for brush model `N` (`model{N}.sky`, `model{N}.liquid` for its
//!   sky and liquid faces).
//! - Errors name the asset path and what was wrong (from [`sightline_runtime::LoadError`], which
//!   gives the lump or offset).

use std::sync::Arc;

use bevy::asset::io::Reader;
use bevy::asset::{Asset, AssetLoader, Assets, Handle, LoadContext};
use bevy::mesh::Mesh;
use bevy::reflect::TypePath;
use sightline_runtime::{LoadError, World, load};

use crate::mesh::{self, LevelMeshes, Surface};

/// A loaded level: the runtime's [`World`] (shared, immutable) and its meshes.
#[derive(Asset, TypePath, Debug)]
pub struct LevelAsset {
    world: Arc<World>,
    groups: Vec<GroupMesh>,
    models: Vec<ModelPart>,
}

/// A brush model's mesh of one surface ([`crate::mesh::ModelMesh`]).
#[derive(Debug, Clone)]
pub struct ModelPart {
    /// Model number (`*N` in the entity text; `1..`).
    pub model: u32,
    /// What its faces are.
    pub surface: Surface,
    /// The mesh.
    pub mesh: Handle<Mesh>,
}

/// A world mesh and the clusters it is seen from ([`crate::mesh::MeshGroup`]).
#[derive(Debug, Clone)]
pub struct GroupMesh {
    /// Clusters, ascending; empty when never culled.
    pub clusters: Vec<u32>,
    /// What its faces are.
    pub surface: Surface,
    /// The mesh.
    pub mesh: Handle<Mesh>,
}

impl LevelAsset {
    /// A level from a world in memory, its meshes added to `meshes`.
    pub fn from_world(world: World, meshes: &mut Assets<Mesh>) -> Self {
        let built = mesh::build(&world);
        Self::assemble(world, built, |_, m| meshes.add(m))
    }

    fn assemble(world: World, built: LevelMeshes, mut add: impl FnMut(String, Mesh) -> Handle<Mesh>) -> Self {
        let groups = built
            .groups
            .into_iter()
            .enumerate()
            .map(|(i, g)| GroupMesh {
                clusters: g.clusters,
                surface: g.surface,
                mesh: add(format!("group{i}"), g.mesh),
            })
            .collect();
        let models = built
            .models
            .into_iter()
            .map(|m| {
                let suffix = match m.surface {
                    Surface::Solid => "",
                    Surface::Sky => ".sky",
                    Surface::Liquid => ".liquid",
                };
                ModelPart {
                    model: m.model,
                    surface: m.surface,
                    mesh: add(format!("model{}{suffix}", m.model), m.mesh),
                }
            })
            .collect();
        Self { world: Arc::new(world), groups, models }
    }

    /// The runtime's world (for your own queries: traces, `leaf_at`, the entity text).
    pub fn world(&self) -> &Arc<World> {
        &self.world
    }

    /// The world's meshes by cluster group.
    pub fn groups(&self) -> &[GroupMesh] {
        &self.groups
    }

    /// The brush models' meshes, by model number, then surface.
    pub fn models(&self) -> &[ModelPart] {
        &self.models
    }
}

/// Why a level asset did not load.
#[derive(Debug, thiserror::Error)]
pub enum LevelLoadError {
    /// The asset reader failed.
    #[error("{path}: cannot read: {source}")]
    Io {
        /// The asset path.
        path: String,
        /// The reader's error.
        source: std::io::Error,
    },
    /// The bytes are not a level the runtime accepts.
    #[error("{path}: {source}")]
    Level {
        /// The asset path.
        path: String,
        /// What is wrong, and where.
        source: LoadError,
    },
}

/// Loads `.bsp` and `.slvl` files as [`LevelAsset`]s; see the module docs.
#[derive(Debug, Default, TypePath)]
pub struct LevelLoader;

impl AssetLoader for LevelLoader {
    type Asset = LevelAsset;
    type Settings = ();
    type Error = LevelLoadError;

    async fn load(
        &self,
        reader: &mut dyn Reader,
        _settings: &(),
        ctx: &mut LoadContext<'_>,
    ) -> Result<LevelAsset, LevelLoadError> {
        let path = ctx.path().to_string();
        let mut bytes = Vec::new();
        reader
            .read_to_end(&mut bytes)
            .await
            .map_err(|source| LevelLoadError::Io { path: path.clone(), source })?;
        let world = load::load_bytes(&bytes)
            .map_err(|source| LevelLoadError::Level { path: path.clone(), source })?;
        if !world.has_vis() {
            tracing::warn!(
                "{path}: the level has no visdata; PVS culling will hide nothing (run `sightline vis` on it)"
            );
        }
        let built = mesh::build(&world);
        Ok(LevelAsset::assemble(world, built, |label, m| ctx.add_labeled_asset(label, m)))
    }

    fn extensions(&self) -> &[&str] {
        &["bsp", "slvl"]
    }
}
