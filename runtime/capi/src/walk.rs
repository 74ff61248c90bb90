//! Culling: per-thread scratches, the visible leaves and faces of a camera, back-face culling.

use glam::Vec3;
use sightline_runtime::backend::{Backend, portal::Portal, pvs::Pvs};
use sightline_runtime::{Camera, Scratch, Visible};

use crate::handles::*;
use crate::lists::*;
use crate::status::*;

/// New culling state for `world` (null when `world` is null).
///
/// # Safety
/// `world` must be null or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_scratch_new(world: *const SlWorld) -> *mut SlScratch {
    // SAFETY: null or live per the contract.
    let Some(w) = (unsafe { world.as_ref() }) else { return std::ptr::null_mut() };
    let s = SlScratch { scratch: Scratch::new(&w.world), visible: Visible::for_world(&w.world) };
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

/// Run backend `backend` (`SL_BACKEND_*`) for `cam` into the scratch's output lists, with back
/// faces left out of the faces when `back_faces`.
pub(crate) fn cull_into(
    w: &SlWorld,
    s: &mut SlScratch,
    cam: &SlCamera,
    backend: i32,
    back_faces: bool,
) -> SlStatus {
    let b: &dyn Backend = match backend {
        SL_BACKEND_PVS => &Pvs,
        SL_BACKEND_PORTAL => &Portal,
        _ => {
            set_error(format!("unknown backend {backend}"));
            return SL_ERR_BACKEND;
        }
    };
    if !b.supports(&w.world) {
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
    b.cull(&w.world, &c.view().with_back_face_culling(back_faces), &mut s.scratch, &mut s.visible);
    SL_OK
}

/// Cull a camera's view and write one of the resulting lists ([`sl_visible_leaves`] and
/// [`sl_visible_faces`]).
///
/// # Safety
/// The contract of those two functions.
#[allow(clippy::too_many_arguments)]
pub(crate) unsafe fn visible_list(
    world: *const SlWorld,
    scratch: *mut SlScratch,
    camera: *const SlCamera,
    backend: i32,
    back_faces: bool,
    list: fn(&Visible) -> &[u32],
    out: *mut u32,
    capacity: usize,
    out_count: *mut usize,
) -> SlStatus {
    guard(|| {
        // SAFETY: null or live/readable per the contract.
        let (Some(w), Some(s), Some(cam)) =
            (unsafe { world.as_ref() }, unsafe { scratch.as_mut() }, unsafe { camera.as_ref() })
        else {
            return null_argument();
        };
        match cull_into(w, s, cam, backend, back_faces) {
            // SAFETY: forwarded contract.
            SL_OK => unsafe { write_list(list(&s.visible), out, capacity, out_count) },
            err => err,
        }
    })
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
    // SAFETY: forwarded contract.
    unsafe {
        visible_list(world, scratch, camera, backend, false, |v| &v.leaves, out_leaves, capacity, out_count)
    }
}

/// Visible faces of a camera: the faces of the visible leaves, each once, nearest leaf first
/// (what an engine draws), leaving out back faces (the eye more than 1/32 unit behind the plane)
/// when `cull_back_faces` is non-zero, as the walk outputs them. Buffer protocol as
/// [`sl_visible_leaves`].
///
/// # Safety
/// As [`sl_visible_leaves`], with `out_faces` writable for `capacity` entries.
#[unsafe(no_mangle)]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn sl_visible_faces(
    world: *const SlWorld,
    scratch: *mut SlScratch,
    camera: *const SlCamera,
    backend: i32,
    cull_back_faces: i32,
    out_faces: *mut u32,
    capacity: usize,
    out_count: *mut usize,
) -> SlStatus {
    let back_faces = cull_back_faces != 0;
    // SAFETY: forwarded contract.
    unsafe {
        visible_list(
            world,
            scratch,
            camera,
            backend,
            back_faces,
            |v| &v.faces,
            out_faces,
            capacity,
            out_count,
        )
    }
}

/// Remove from `faces[0..count]`, in place, every face whose plane faces away from `eye[0..3]` by
/// more than 1/32 unit, keeping the order (and faces out of range); writes the number kept to
/// `out_count`. Run it on the faces of the visible leaves.
///
/// # Safety
/// `world` must be a live world, `eye` 3 readable floats, `faces` readable and writable for
/// `count` entries (may be null when `count` is 0), `out_count` writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_cull_back_faces(
    world: *const SlWorld,
    eye: *const f32,
    faces: *mut u32,
    count: usize,
    out_count: *mut usize,
) -> SlStatus {
    guard(|| {
        // SAFETY: null or live/readable/writable per the contract.
        let (Some(w), Some(e), Some(kept)) =
            (unsafe { world.as_ref() }, unsafe { read3(eye) }, unsafe { out_count.as_mut() })
        else {
            return null_argument();
        };
        if faces.is_null() && count > 0 {
            return null_argument();
        }
        let mut list = if count == 0 {
            Vec::new()
        } else {
            // SAFETY: non-null and readable for `count` entries per the contract.
            unsafe { std::slice::from_raw_parts(faces, count) }.to_vec()
        };
        w.world.cull_back_faces(e, &mut list);
        if !list.is_empty() {
            // SAFETY: writable for `count >= list.len()` entries per the contract.
            unsafe { std::slice::from_raw_parts_mut(faces, list.len()) }.copy_from_slice(&list);
        }
        *kept = list.len();
        SL_OK
    })
}
