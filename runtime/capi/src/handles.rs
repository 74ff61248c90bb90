//! The types C sees: the opaque handles [`SlWorld`] and [`SlScratch`], and the camera and trace
//! result, laid out as C structs.

use std::ffi::CString;

use sightline_runtime::{Scratch, Visible, World};

/// Opaque world handle: the world, and the C strings it hands out (owned here so their pointers
/// live as long as the world).
#[derive(Debug)]
pub struct SlWorld {
    pub(crate) world: World,
    /// NUL-terminated texture names, by texture index (an interior NUL becomes a space).
    pub(crate) texture_names: Vec<CString>,
    /// The entity text, NUL-terminated.
    pub(crate) entities: CString,
}

impl SlWorld {
    pub(crate) fn new(world: World) -> Self {
        let draw = world.draw();
        let texture_names =
            (0..draw.num_textures() as u32).map(|t| c_string(draw.texture_name(t).unwrap_or(""))).collect();
        let entities = c_string(draw.entities());
        Self { world, texture_names, entities }
    }
}

/// `text` as a C string, interior NULs replaced by spaces.
pub(crate) fn c_string(text: &str) -> CString {
    CString::new(text.replace('\0', " ")).unwrap_or_default()
}

/// Opaque per-thread culling state.
#[derive(Debug)]
pub struct SlScratch {
    pub(crate) scratch: Scratch,
    pub(crate) visible: Visible,
}

/// A camera, as [`sightline_runtime::Camera`] (degrees, Quake axes).
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct SlCamera {
    /// Eye position.
    pub position: [f32; 3],
    /// Heading in degrees.
    pub yaw: f32,
    /// Degrees above the horizon.
    pub pitch: f32,
    /// Roll in degrees.
    pub roll: f32,
    /// Vertical field of view in degrees.
    pub fov_y: f32,
    /// Width / height.
    pub aspect: f32,
    /// Near plane distance.
    pub near_dist: f32,
    /// Far plane distance.
    pub far_dist: f32,
}

/// Result of [`sl_trace`](crate::sl_trace).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct SlTrace {
    /// 1 when the segment hit solid, 0 when it is open all the way.
    pub hit: i32,
    /// 1 when the start point is in solid.
    pub start_solid: i32,
    /// Fraction travelled (1 when nothing was hit).
    pub fraction: f32,
    /// End point (the hit point, backed off into open space).
    pub point: [f32; 3],
    /// Normal of the surface hit (zero when none).
    pub normal: [f32; 3],
    /// Solid leaf hit (0 when none).
    pub leaf: u32,
}
