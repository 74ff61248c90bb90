//! The C ABI (feature `ffi`); the header is `runtime/include/sightline.h`.
//!
//! Conventions: every function returns an [`SlStatus`] code (0 = success) unless it only frees or
//! counts; on failure [`sl_last_error`] gives a message for the calling thread. Handles are opaque
//! pointers created by `sl_*_new`/`sl_world_load_*` and released by the matching `*_free`. A
//! world may be shared by threads; a scratch belongs to one thread at a time. No function
//! unwinds into C: a Rust panic (none is expected after a successful load) becomes
//! `SL_ERR_PANIC`.

use std::cell::RefCell;
use std::ffi::{CStr, CString, c_char};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use glam::{Vec3, Vec3A};

use crate::backend::{Backend, portal::Portal, pvs::Pvs};
use crate::camera::Camera;
use crate::load;
use crate::scratch::{Scratch, Visible};
use crate::world::World;

/// Status codes.
pub type SlStatus = i32;
/// Success.
pub const SL_OK: SlStatus = 0;
/// A required pointer was null.
pub const SL_ERR_NULL: SlStatus = 1;
/// The file could not be read.
pub const SL_ERR_IO: SlStatus = 2;
/// The level is invalid (parse or validation error).
pub const SL_ERR_INVALID: SlStatus = 3;
/// Unknown backend, or the backend cannot run on this world.
pub const SL_ERR_BACKEND: SlStatus = 4;
/// An internal panic was caught.
pub const SL_ERR_PANIC: SlStatus = 5;

/// Backend selectors for [`sl_visible_leaves`].
pub const SL_BACKEND_PVS: i32 = 0;
/// The portal backend.
pub const SL_BACKEND_PORTAL: i32 = 1;

/// Opaque world handle.
#[derive(Debug)]
pub struct SlWorld(World);

/// Opaque per-thread culling state.
#[derive(Debug)]
pub struct SlScratch {
    scratch: Scratch,
    visible: Visible,
}

/// A camera, as [`Camera`] (degrees, Quake axes).
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

/// Result of [`sl_trace`].
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

thread_local! {
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

/// `err` and its sources joined by ": " (how the CLI prints errors too).
fn error_chain(err: &dyn std::error::Error) -> String {
    let mut text = err.to_string();
    let mut source = err.source();
    while let Some(e) = source {
        text.push_str(": ");
        text.push_str(&e.to_string());
        source = e.source();
    }
    text
}

fn set_error(message: String) {
    let c = CString::new(message.replace('\0', " ")).unwrap_or_default();
    LAST_ERROR.with(|e| *e.borrow_mut() = c);
}

fn guard(f: impl FnOnce() -> SlStatus) -> SlStatus {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(status) => status,
        Err(_) => {
            set_error("internal panic".to_string());
            SL_ERR_PANIC
        }
    }
}

fn store_world(result: Result<World, crate::LoadError>, out: *mut *mut SlWorld) -> SlStatus {
    match result {
        Ok(world) => {
            let ptr = Box::into_raw(Box::new(SlWorld(world)));
            // SAFETY: callers checked `out` is non-null; C guarantees it points to writable storage.
            unsafe { *out = ptr };
            SL_OK
        }
        Err(err) => {
            let code = if matches!(err, crate::LoadError::Io { .. }) { SL_ERR_IO } else { SL_ERR_INVALID };
            set_error(error_chain(&err));
            code
        }
    }
}

/// The message of the last error on this thread (empty when none). Valid until the next failing
/// call on the same thread.
#[unsafe(no_mangle)]
pub extern "C" fn sl_last_error() -> *const c_char {
    LAST_ERROR.with(|e| e.borrow().as_ptr())
}

/// Load a `.slvl` or `.bsp` file (a PRT1 `NAME.prt` beside a `.bsp` adds portals).
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
    unsafe { world.as_ref() }.map_or(0, |w| w.0.num_leaves() as u32)
}

/// The leaf holding `position[0..3]`.
///
/// # Safety
/// `world` must be a live world, `position` 3 readable floats, `out_leaf` writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_leaf_at(
    world: *const SlWorld,
    position: *const f32,
    out_leaf: *mut u32,
) -> SlStatus {
    guard(|| {
        // SAFETY: null or live/readable/writable per the contract.
        let (Some(w), Some(p), Some(out)) =
            (unsafe { world.as_ref() }, unsafe { read3(position) }, unsafe { out_leaf.as_mut() })
        else {
            set_error("null argument".to_string());
            return SL_ERR_NULL;
        };
        *out = w.0.leaf_at(p);
        SL_OK
    })
}

/// Trace the segment `from → to`.
///
/// # Safety
/// `world` must be a live world, `from`/`to` 3 readable floats each, `out` writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_trace(
    world: *const SlWorld,
    from: *const f32,
    to: *const f32,
    out: *mut SlTrace,
) -> SlStatus {
    guard(|| {
        // SAFETY: null or live/readable/writable per the contract.
        let (Some(w), Some(a), Some(b), Some(out)) =
            (unsafe { world.as_ref() }, unsafe { read3(from) }, unsafe { read3(to) }, unsafe {
                out.as_mut()
            })
        else {
            set_error("null argument".to_string());
            return SL_ERR_NULL;
        };
        *out = match w.0.trace(a, b) {
            Some(h) => SlTrace {
                hit: 1,
                start_solid: i32::from(h.start_solid),
                fraction: h.fraction,
                point: h.point.to_array(),
                normal: h.normal.to_array(),
                leaf: h.leaf,
            },
            None => SlTrace {
                hit: 0,
                start_solid: 0,
                fraction: 1.0,
                point: b.to_array(),
                normal: [0.0; 3],
                leaf: 0,
            },
        };
        SL_OK
    })
}

/// New culling state for `world` (null when `world` is null).
///
/// # Safety
/// `world` must be null or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_scratch_new(world: *const SlWorld) -> *mut SlScratch {
    // SAFETY: null or live per the contract.
    let Some(w) = (unsafe { world.as_ref() }) else { return std::ptr::null_mut() };
    let s = SlScratch { scratch: Scratch::new(&w.0), visible: Visible::for_world(&w.0) };
    Box::into_raw(Box::new(s))
}

/// Free culling state (null is ignored).
///
/// # Safety
/// `scratch` must come from `sl_scratch_new` and not have been freed.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_scratch_free(scratch: *mut SlScratch) {
    if !scratch.is_null() {
        // SAFETY: created by `Box::into_raw` in `sl_scratch_new`, freed once per the contract.
        drop(unsafe { Box::from_raw(scratch) });
    }
}

/// Visible leaves of a camera, front to back. Writes at most `capacity` leaves to `out_leaves` and
/// the full count to `out_count` (call again with a larger buffer when it exceeds `capacity`).
///
/// # Safety
/// `world` and `scratch` must be live (the scratch used by one thread at a time), `camera`
/// readable, `out_leaves` writable for `capacity` entries (may be null when `capacity` is 0),
/// `out_count` writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_visible_leaves(
    world: *const SlWorld,
    scratch: *mut SlScratch,
    camera: *const SlCamera,
    backend: i32,
    out_leaves: *mut u32,
    capacity: usize,
    out_count: *mut usize,
) -> SlStatus {
    guard(|| {
        // SAFETY: null or live/readable/writable per the contract.
        let (Some(w), Some(s), Some(cam), Some(count)) =
            (unsafe { world.as_ref() }, unsafe { scratch.as_mut() }, unsafe { camera.as_ref() }, unsafe {
                out_count.as_mut()
            })
        else {
            set_error("null argument".to_string());
            return SL_ERR_NULL;
        };
        if out_leaves.is_null() && capacity > 0 {
            set_error("null leaf buffer with non-zero capacity".to_string());
            return SL_ERR_NULL;
        }
        let b: &dyn Backend = match backend {
            SL_BACKEND_PVS => &Pvs,
            SL_BACKEND_PORTAL => &Portal,
            _ => {
                set_error(format!("unknown backend {backend}"));
                return SL_ERR_BACKEND;
            }
        };
        if !b.supports(&w.0) {
            set_error(format!("backend `{}` cannot run on this world", b.name()));
            return SL_ERR_BACKEND;
        }
        let c = Camera {
            position: Vec3::from_array(cam.position),
            yaw: cam.yaw,
            pitch: cam.pitch,
            roll: cam.roll,
            fov_y: cam.fov_y,
            aspect: cam.aspect,
            near: cam.near_dist,
            far: cam.far_dist,
        };
        b.cull(&w.0, &c.view(), &mut s.scratch, &mut s.visible);
        let n = s.visible.leaves.len().min(capacity);
        if n > 0 {
            // SAFETY: non-null and writable for `capacity >= n` entries per the contract.
            let dst = unsafe { std::slice::from_raw_parts_mut(out_leaves, n) };
            dst.copy_from_slice(&s.visible.leaves[..n]);
        }
        *count = s.visible.leaves.len();
        SL_OK
    })
}

/// Three floats from a C pointer.
///
/// # Safety
/// `p` must be null or point to 3 readable floats.
unsafe fn read3(p: *const f32) -> Option<Vec3A> {
    if p.is_null() {
        return None;
    }
    // SAFETY: non-null and 3 readable floats per the contract.
    let a = unsafe { std::slice::from_raw_parts(p, 3) };
    Some(Vec3A::new(a[0], a[1], a[2]))
}
