//! Loading and freeing a world, and its counts and entity text.

use std::ffi::{CStr, c_char};
use std::path::Path;

use sightline_runtime::{LoadError, World, load};

use crate::handles::*;
use crate::status::*;

pub(crate) fn store_world(result: Result<World, LoadError>, out: *mut *mut SlWorld) -> SlStatus {
    match result {
        Ok(world) => {
            let ptr = Box::into_raw(Box::new(SlWorld::new(world)));
            // SAFETY: callers checked `out` is non-null; C guarantees it points to writable storage.
            unsafe { *out = ptr };
            SL_OK
        }
        Err(err) => {
            let code = if matches!(err, LoadError::Io(_)) { SL_ERR_IO } else { SL_ERR_INVALID };
            set_error(error_chain(&err));
            code
        }
    }
}

/// Load a `.slvl` or `.bsp` file (a PRT1 `NAME.prt` beside a `.bsp` adds portals). Only a regular
/// file is read (symlinks followed): a folder, FIFO or device is `SL_ERR_IO`, naming it.
///
/// # Safety
/// `path` must be a NUL-terminated string and `out` a valid pointer to writable storage.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_world_load_file(path: *const c_char, out: *mut *mut SlWorld) -> SlStatus {
    guard(|| {
        if path.is_null() || out.is_null() {
            set_error("null argument".to_string());
            return SL_ERR_NULL;
        }
        // SAFETY: `path` is non-null and, per the contract, NUL-terminated.
        let path = unsafe { CStr::from_ptr(path) };
        let Ok(path) = path.to_str() else {
            set_error("path is not UTF-8".to_string());
            return SL_ERR_IO;
        };
        store_world(load::load_path(Path::new(path)), out)
    })
}

/// Load `.slvl` or `.bsp` bytes (the bytes are copied; the caller keeps ownership).
///
/// # Safety
/// `data` must point to `len` readable bytes and `out` to writable storage.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_world_load_bytes(
    data: *const u8,
    len: usize,
    out: *mut *mut SlWorld,
) -> SlStatus {
    guard(|| {
        if data.is_null() || out.is_null() {
            set_error("null argument".to_string());
            return SL_ERR_NULL;
        }
        // SAFETY: non-null, and the caller promises `len` readable bytes that outlive this call.
        let bytes = unsafe { std::slice::from_raw_parts(data, len) };
        store_world(load::load_bytes(bytes), out)
    })
}

/// Free a world (null is ignored). Scratches made for it must not be used afterwards.
///
/// # Safety
/// `world` must come from `sl_world_load_*` and not have been freed.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_world_free(world: *mut SlWorld) {
    if !world.is_null() {
        // SAFETY: created by `Box::into_raw` in `store_world`, freed once per the contract.
        drop(unsafe { Box::from_raw(world) });
    }
}

/// Number of leaves (0 for null).
///
/// # Safety
/// `world` must be null or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_world_num_leaves(world: *const SlWorld) -> u32 {
    // SAFETY: null or live per the contract.
    unsafe { world.as_ref() }.map_or(0, |w| w.world.num_leaves() as u32)
}

/// Number of PVS clusters (0 for null); cluster indices are `0..count`.
///
/// # Safety
/// `world` must be null or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_world_num_clusters(world: *const SlWorld) -> u32 {
    // SAFETY: null or live per the contract.
    unsafe { world.as_ref() }.map_or(0, |w| w.world.num_clusters())
}

/// Number of faces (0 for null); face indices are `0..count`, the indices of
/// [`sl_cluster_faces`](crate::sl_cluster_faces) and, for a `.bsp`, the BSP's own face indices.
///
/// # Safety
/// `world` must be null or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_world_num_faces(world: *const SlWorld) -> u32 {
    // SAFETY: null or live per the contract.
    unsafe { world.as_ref() }.map_or(0, |w| w.world.draw().num_faces() as u32)
}

/// Number of textures (0 for null); texture indices are `0..count`.
///
/// # Safety
/// `world` must be null or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_world_num_textures(world: *const SlWorld) -> u32 {
    // SAFETY: null or live per the contract.
    unsafe { world.as_ref() }.map_or(0, |w| w.world.draw().num_textures() as u32)
}

/// Number of brush models (0 for null); model 0 is the world, models `1..` brush entities.
///
/// # Safety
/// `world` must be null or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_world_num_models(world: *const SlWorld) -> u32 {
    // SAFETY: null or live per the contract.
    unsafe { world.as_ref() }.map_or(0, |w| w.world.draw().models().len() as u32)
}

/// 1 when the level carries a PVS, 0 when it has none (an unvised map: every cluster then sees
/// every other, so PVS culling culls nothing) or for null. Check it after loading: the load itself
/// succeeds either way.
///
/// # Safety
/// `world` must be null or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_world_has_pvs(world: *const SlWorld) -> i32 {
    // SAFETY: null or live per the contract.
    unsafe { world.as_ref() }.map_or(0, |w| i32::from(w.world.has_vis()))
}

/// The level's entity text (Quake `.map` syntax without brushes), NUL-terminated, owned by the
/// world (valid until [`sl_world_free`]); null for a null world.
///
/// # Safety
/// `world` must be null or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_world_entities(world: *const SlWorld) -> *const c_char {
    // SAFETY: null or live per the contract.
    unsafe { world.as_ref() }.map_or(std::ptr::null(), |w| w.entities.as_ptr())
}
