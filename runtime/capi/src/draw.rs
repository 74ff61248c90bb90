//! What an engine draws: faces, their vertices, textures, brush models, the faces of a cluster.

use std::ffi::c_char;

use crate::handles::*;
use crate::lists::*;
use crate::status::*;

/// A face, as [`sl_face`] gives it.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct SlFace {
    /// Unit normal of the face's plane, pointing to the side the face is seen from.
    pub normal: [f32; 3],
    /// `normal · p` for points on the face (world units).
    pub dist: f32,
    /// Texture index (`0..sl_world_num_textures`).
    pub texture: u32,
    /// Number of vertices ([`sl_face_vertices`]).
    pub num_vertices: u32,
    /// Index of its first vertex in the level's vertex array ([`sl_world_vertices`]): its
    /// vertices are the `num_vertices` entries from there.
    pub first_vertex: u32,
    /// 1 when the level has texture projections (`s`, `t`, `flags`, `styles`, `light_offset`
    /// below); 0 when it has none and those fields are zero, styles 255 and `light_offset` -1.
    pub has_draw: i32,
    /// S axis (texels per world unit along x, y, z) and offset: `s = s[0..3] · p + s[3]` texels.
    pub s: [f32; 4],
    /// T axis and offset, as `s`.
    pub t: [f32; 4],
    /// Quake texinfo flags (bit 0: sky or liquid, warped and not light-mapped).
    pub flags: u32,
    /// Light styles of the light maps; 255 ends the list.
    pub styles: [u8; 4],
    /// Byte offset of the first light map in the source BSP's lighting lump; -1 for none.
    pub light_offset: i32,
}

/// Face `face` into `out`: plane, texture, vertex count and draw data. `SL_ERR_RANGE` when
/// `face >= sl_world_num_faces`.
///
/// # Safety
/// `world` must be a live world and `out` writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_face(world: *const SlWorld, face: u32, out: *mut SlFace) -> SlStatus {
    guard(|| {
        // SAFETY: null or live/writable per the contract.
        let (Some(w), Some(out)) = (unsafe { world.as_ref() }, unsafe { out.as_mut() }) else {
            return null_argument();
        };
        let draw = w.world.draw();
        let Some(f) = draw.face(face) else { return out_of_range("face", face, draw.num_faces()) };
        let d = f.draw.copied();
        let fd = d.unwrap_or(sightline_formats::level::FaceDraw::NONE);
        *out = SlFace {
            normal: f.normal.to_array(),
            dist: f.dist,
            texture: f.texture,
            num_vertices: f.vertices.len() as u32,
            first_vertex: f.first_vertex,
            has_draw: i32::from(d.is_some()),
            s: fd.s,
            t: fd.t,
            flags: fd.flags,
            styles: fd.styles,
            light_offset: fd.light_offset,
        };
        SL_OK
    })
}

/// The vertices of face `face`, clockwise seen from the front of its plane (Quake's order),
/// world units, as `x, y, z` float triples: writes at most `capacity` vertices (`3 * capacity`
/// floats) to `out_xyz` and the full vertex count to `out_count` (call with NULL/0 first).
/// `SL_ERR_RANGE` when `face >= sl_world_num_faces`.
///
/// # Safety
/// `world` must be a live world, `out_xyz` writable for `3 * capacity` floats (may be null when
/// `capacity` is 0), `out_count` writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_face_vertices(
    world: *const SlWorld,
    face: u32,
    out_xyz: *mut f32,
    capacity: usize,
    out_count: *mut usize,
) -> SlStatus {
    guard(|| {
        // SAFETY: null or live per the contract.
        let Some(w) = (unsafe { world.as_ref() }) else { return null_argument() };
        let draw = w.world.draw();
        let Some(f) = draw.face(face) else { return out_of_range("face", face, draw.num_faces()) };
        // SAFETY: forwarded contract; `[f32; 3]` has the alignment of `f32`.
        unsafe { write_list(f.vertices, out_xyz.cast::<[f32; 3]>(), capacity, out_count) }
    })
}

/// Every face's vertices in one array, world units, as `x, y, z` float triples (face `f`'s are
/// the `num_vertices` from its `first_vertex`, see [`SlFace`]): writes at most `capacity`
/// vertices (`3 * capacity` floats) to `out_xyz` and the full vertex count to `out_count` (call
/// with NULL/0 first), so C can fill one vertex buffer.
///
/// # Safety
/// `world` must be a live world, `out_xyz` writable for `3 * capacity` floats (may be null when
/// `capacity` is 0), `out_count` writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_world_vertices(
    world: *const SlWorld,
    out_xyz: *mut f32,
    capacity: usize,
    out_count: *mut usize,
) -> SlStatus {
    guard(|| {
        // SAFETY: null or live per the contract.
        let Some(w) = (unsafe { world.as_ref() }) else { return null_argument() };
        // SAFETY: forwarded contract; `[f32; 3]` has the alignment of `f32`.
        unsafe { write_list(w.world.draw().vertices(), out_xyz.cast::<[f32; 3]>(), capacity, out_count) }
    })
}

/// Name of texture `texture`, NUL-terminated, owned by the world (valid until
/// [`sl_world_free`](crate::sl_world_free); empty for a texture missing from a BSP). Null, with
/// [`sl_last_error`](crate::sl_last_error) set, for a null world or `texture >= sl_world_num_textures`.
///
/// # Safety
/// `world` must be null or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_texture_name(world: *const SlWorld, texture: u32) -> *const c_char {
    // SAFETY: null or live per the contract.
    let Some(w) = (unsafe { world.as_ref() }) else {
        null_argument();
        return std::ptr::null();
    };
    match w.texture_names.get(texture as usize) {
        Some(name) => name.as_ptr(),
        None => {
            out_of_range("texture", texture, w.texture_names.len());
            std::ptr::null()
        }
    }
}

/// Size of texture `texture` in texels into `out_width`/`out_height`; both 0 when the level does
/// not size its textures (a level compiled from a `.map`). `SL_ERR_RANGE` when
/// `texture >= sl_world_num_textures`.
///
/// # Safety
/// `world` must be a live world, `out_width` and `out_height` writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_texture_size(
    world: *const SlWorld,
    texture: u32,
    out_width: *mut u32,
    out_height: *mut u32,
) -> SlStatus {
    guard(|| {
        // SAFETY: null or live/writable per the contract.
        let (Some(w), Some(width), Some(height)) =
            (unsafe { world.as_ref() }, unsafe { out_width.as_mut() }, unsafe { out_height.as_mut() })
        else {
            return null_argument();
        };
        let draw = w.world.draw();
        if texture as usize >= draw.num_textures() {
            return out_of_range("texture", texture, draw.num_textures());
        }
        [*width, *height] = draw.texture_size(texture).unwrap_or([0, 0]);
        SL_OK
    })
}

/// A brush model, as [`sl_model`] gives it.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct SlModel {
    /// Smallest corner of its bounds, world units (where the model sits as compiled).
    pub mins: [f32; 3],
    /// Largest corner of its bounds.
    pub maxs: [f32; 3],
    /// Its faces are `first_face..first_face + num_faces` in the face index space.
    pub first_face: u32,
    /// Number of faces.
    pub num_faces: u32,
    /// Where the engine places the model: the `origin` of the entity whose `"model"` is `"*N"`,
    /// zero when none (see `BrushModel::origin`).
    pub origin: [f32; 3],
}

/// Brush model `model` into `out` (model 0 is the world; a brush entity is placed at `origin`,
/// from its `"model" "*N"` entity). `SL_ERR_RANGE` when `model >= sl_world_num_models`.
///
/// # Safety
/// `world` must be a live world and `out` writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_model(world: *const SlWorld, model: u32, out: *mut SlModel) -> SlStatus {
    guard(|| {
        // SAFETY: null or live/writable per the contract.
        let (Some(w), Some(out)) = (unsafe { world.as_ref() }, unsafe { out.as_mut() }) else {
            return null_argument();
        };
        let models = w.world.draw().models();
        let Some(m) = models.get(model as usize) else { return out_of_range("model", model, models.len()) };
        *out = SlModel {
            mins: m.mins.to_array(),
            maxs: m.maxs.to_array(),
            first_face: m.faces.start,
            num_faces: m.faces.end - m.faces.start,
            origin: m.origin.to_array(),
        };
        SL_OK
    })
}

/// The faces of the world leaves of cluster `cluster`, each once, ascending. Buffer protocol as
/// [`sl_visible_leaves`](crate::sl_visible_leaves). `SL_ERR_RANGE` when `cluster >= sl_world_num_clusters`.
///
/// # Safety
/// `world` must be a live world, `out_faces` writable for `capacity` entries (may be null when
/// `capacity` is 0), `out_count` writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_cluster_faces(
    world: *const SlWorld,
    cluster: u32,
    out_faces: *mut u32,
    capacity: usize,
    out_count: *mut usize,
) -> SlStatus {
    guard(|| {
        // SAFETY: null or live per the contract.
        let Some(w) = (unsafe { world.as_ref() }) else { return null_argument() };
        let n = w.world.num_clusters();
        if cluster >= n {
            return out_of_range("cluster", cluster, n as usize);
        }
        // SAFETY: forwarded contract.
        unsafe { write_list(w.world.draw().cluster_faces(cluster), out_faces, capacity, out_count) }
    })
}
