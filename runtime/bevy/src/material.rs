//! Feature `pbr`: materials for a level without its textures. [`LevelMaterialPlugin`] gives every
//! [`ClusterMesh`] and [`BrushModelMesh`] that has no material one of three shared
//! `StandardMaterial`s, by its [`Surface`], each tinted by the mesh's flat per-texture vertex
//! colours ([`crate::mesh::texture_color`]):
//! - solid: lit, a two-tone checker, one square per texture repeat (the mesh's `UV_0`, see
//!   [`crate::mesh`]);
//! - sky: unlit, flat (Quake draws its sky without lighting);
//! - liquid: unlit, flat, drawn from both sides (seen from below, a water surface is a surface,
//!   not a hole).
//!
//! Give the entity your own `MeshMaterial3d` before it is spawned, or replace it after, to use
//! real textures.

use bevy::app::{App, Plugin, PostUpdate};
use bevy::asset::{Assets, Handle, RenderAssetUsages};
use bevy::ecs::prelude::*;
use bevy::image::{Image, ImageAddressMode, ImageSampler, ImageSamplerDescriptor};
use bevy::pbr::{MeshMaterial3d, StandardMaterial};
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat};

use crate::{BrushModelMesh, ClusterMesh, SightlineSystems, Surface};

/// Checker squares per side of the texture.
const CHECKER: u32 = 2;
/// The two tones (sRGB bytes).
const TONES: [u8; 2] = [235, 190];

/// Adds the checker material to the level's meshes; see the module docs. Add it with
/// [`crate::SightlinePlugin`].
#[derive(Debug, Clone, Copy, Default)]
pub struct LevelMaterialPlugin;

/// The shared materials, by [`Surface`] (in [`Surface::ALL`] order).
#[derive(Resource, Debug, Clone)]
pub struct LevelMaterial(pub [Handle<StandardMaterial>; 3]);

impl LevelMaterial {
    /// The material of `surface`.
    pub fn of(&self, surface: Surface) -> &Handle<StandardMaterial> {
        let [solid, sky, liquid] = &self.0;
        match surface {
            Surface::Solid => solid,
            Surface::Sky => sky,
            Surface::Liquid => liquid,
        }
    }

    /// The three materials, added to `materials`.
    fn new(images: &mut Assets<Image>, materials: &mut Assets<StandardMaterial>) -> Self {
        let solid = StandardMaterial {
            base_color_texture: Some(images.add(checker())),
            perceptual_roughness: 0.9,
            ..Default::default()
        };
        let sky = StandardMaterial { unlit: true, ..Default::default() };
        let liquid =
            StandardMaterial { unlit: true, double_sided: true, cull_mode: None, ..Default::default() };
        Self([materials.add(solid), materials.add(sky), materials.add(liquid)])
    }
}

impl Plugin for LevelMaterialPlugin {
    fn build(&self, app: &mut App) {
        app.add_systems(PostUpdate, add_material.after(SightlineSystems::Spawn));
    }
}

fn checker() -> Image {
    let mut data = Vec::with_capacity((CHECKER * CHECKER * 4) as usize);
    for y in 0..CHECKER {
        for x in 0..CHECKER {
            let v = TONES[((x + y) % 2) as usize];
            data.extend([v, v, v, 255]);
        }
    }
    let mut image = Image::new(
        Extent3d { width: CHECKER, height: CHECKER, depth_or_array_layers: 1 },
        TextureDimension::D2,
        data,
        TextureFormat::Rgba8UnormSrgb,
        RenderAssetUsages::default(),
    );
    image.sampler = ImageSampler::Descriptor(ImageSamplerDescriptor {
        address_mode_u: ImageAddressMode::Repeat,
        address_mode_v: ImageAddressMode::Repeat,
        ..ImageSamplerDescriptor::nearest()
    });
    image
}

/// Level meshes spawned this frame without a material.
type NewLevelMeshes =
    (Or<(Added<ClusterMesh>, Added<BrushModelMesh>)>, Without<MeshMaterial3d<StandardMaterial>>);

fn add_material(
    mut commands: Commands,
    meshes: Query<(Entity, Option<&Surface>), NewLevelMeshes>,
    shared: Option<Res<LevelMaterial>>,
    mut images: ResMut<Assets<Image>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    if meshes.is_empty() {
        return;
    }
    let shared = match shared {
        Some(m) => m.clone(),
        None => {
            let m = LevelMaterial::new(&mut images, &mut materials);
            commands.insert_resource(m.clone());
            m
        }
    };
    for (e, surface) in &meshes {
        let handle = shared.of(surface.copied().unwrap_or_default()).clone();
        commands.entity(e).insert(MeshMaterial3d(handle));
    }
}
