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
use crate::pvs::Bitset;
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

/// An index (leaf, cluster, face, texture, model) was out of range.
pub const SL_ERR_RANGE: SlStatus = 6;

/// Leaf contents codes of [`sl_leaf_contents`] (Quake's, as `Contents::code`): empty.
pub const SL_CONTENTS_EMPTY: i32 = -1;
/// Solid, and every point outside the world.
pub const SL_CONTENTS_SOLID: i32 = -2;
/// Water.
pub const SL_CONTENTS_WATER: i32 = -3;
/// Slime.
pub const SL_CONTENTS_SLIME: i32 = -4;
/// Lava.
pub const SL_CONTENTS_LAVA: i32 = -5;
/// Sky.
pub const SL_CONTENTS_SKY: i32 = -6;

/// Opaque world handle: the world, and the C strings it hands out (owned here so their pointers
/// live as long as the world).
#[derive(Debug)]
pub struct SlWorld {
    world: World,
    /// NUL-terminated texture names, by texture index (an interior NUL becomes a space).
    texture_names: Vec<CString>,
    /// The entity text, NUL-terminated.
    entities: CString,
}

impl SlWorld {
    fn new(world: World) -> Self {
        let draw = world.draw();
        let texture_names =
            (0..draw.num_textures() as u32).map(|t| c_string(draw.texture_name(t).unwrap_or(""))).collect();
        let entities = c_string(draw.entities());
        Self { world, texture_names, entities }
    }
}

/// `text` as a C string, interior NULs replaced by spaces.
fn c_string(text: &str) -> CString {
    CString::new(text.replace('\0', " ")).unwrap_or_default()
}

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
    LAST_ERROR.with(|e| *e.borrow_mut() = c_string(&message));
}

fn null_argument() -> SlStatus {
    set_error("null argument".to_string());
    SL_ERR_NULL
}

fn out_of_range(what: &str, index: u32, count: usize) -> SlStatus {
    set_error(format!("{what} {index} out of range (the world has {count})"));
    SL_ERR_RANGE
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
            let ptr = Box::into_raw(Box::new(SlWorld::new(world)));
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
    unsafe { world.as_ref() }.map_or(0, |w| w.world.num_leaves() as u32)
}

/// The leaf holding `position[0..3]` (world units). Every point has a leaf: a point in solid or
/// outside the world gets a solid leaf, which [`sl_leaf_contents`] tells apart
/// (`SL_CONTENTS_SOLID`).
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
        *out = w.world.leaf_at(p);
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
        *out = match w.world.trace(a, b) {
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
fn cull_into(w: &SlWorld, s: &mut SlScratch, cam: &SlCamera, backend: i32, back_faces: bool) -> SlStatus {
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
unsafe fn visible_list(
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

/// The crate version (`"MAJOR.MINOR.PATCH"`), a static NUL-terminated string.
#[unsafe(no_mangle)]
pub extern "C" fn sl_version() -> *const c_char {
    concat!(env!("CARGO_PKG_VERSION"), "\0").as_ptr().cast()
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
/// [`sl_cluster_faces`] and, for a `.bsp`, the BSP's own face indices.
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

/// What fills leaf `leaf`, as Quake's contents code into `out_contents`: `SL_CONTENTS_EMPTY`
/// (-1), `SL_CONTENTS_SOLID` (-2), water (-3), slime (-4), lava (-5), sky (-6).
/// `SL_ERR_RANGE` when `leaf >= sl_world_num_leaves`.
///
/// # Safety
/// `world` must be a live world and `out_contents` writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_leaf_contents(
    world: *const SlWorld,
    leaf: u32,
    out_contents: *mut i32,
) -> SlStatus {
    guard(|| {
        // SAFETY: null or live/writable per the contract.
        let (Some(w), Some(out)) = (unsafe { world.as_ref() }, unsafe { out_contents.as_mut() }) else {
            return null_argument();
        };
        match w.world.leaf_contents(leaf) {
            Some(c) => {
                *out = c.code();
                SL_OK
            }
            None => out_of_range("leaf", leaf, w.world.num_leaves()),
        }
    })
}

/// The PVS cluster of leaf `leaf` into `out_cluster`: `0..sl_world_num_clusters`, or -1 for a
/// leaf without a cluster (solid leaves, leaves outside the world tree). `SL_ERR_RANGE` when
/// `leaf >= sl_world_num_leaves`.
///
/// # Safety
/// `world` must be a live world and `out_cluster` writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_leaf_cluster(
    world: *const SlWorld,
    leaf: u32,
    out_cluster: *mut i32,
) -> SlStatus {
    guard(|| {
        // SAFETY: null or live/writable per the contract.
        let (Some(w), Some(out)) = (unsafe { world.as_ref() }, unsafe { out_cluster.as_mut() }) else {
            return null_argument();
        };
        if leaf as usize >= w.world.num_leaves() {
            return out_of_range("leaf", leaf, w.world.num_leaves());
        }
        *out = w.world.leaf_cluster(leaf).and_then(|c| i32::try_from(c).ok()).unwrap_or(-1);
        SL_OK
    })
}

/// The bounds of leaf `leaf` (world units, as the level stores them) into `out_mins[0..3]` and
/// `out_maxs[0..3]`. `SL_ERR_RANGE` when `leaf >= sl_world_num_leaves`.
///
/// # Safety
/// `world` must be a live world, `out_mins` and `out_maxs` writable for 3 floats each.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_leaf_bounds(
    world: *const SlWorld,
    leaf: u32,
    out_mins: *mut f32,
    out_maxs: *mut f32,
) -> SlStatus {
    guard(|| {
        // SAFETY: null or live per the contract.
        let Some(w) = (unsafe { world.as_ref() }) else { return null_argument() };
        if out_mins.is_null() || out_maxs.is_null() {
            return null_argument();
        }
        let Some(b) = w.world.leaf_bounds(leaf) else {
            return out_of_range("leaf", leaf, w.world.num_leaves());
        };
        // SAFETY: non-null and writable for 3 floats each per the contract.
        unsafe {
            write3(out_mins, b.mins());
            write3(out_maxs, b.maxs());
        }
        SL_OK
    })
}

/// Which of the two rows [`row`] decodes.
#[derive(Clone, Copy)]
enum Row {
    Pvs,
    Phs,
}

/// The PVS or PHS row of `cluster` through the buffer protocol of [`sl_pvs_row`].
///
/// # Safety
/// As [`sl_pvs_row`].
unsafe fn row(
    world: *const SlWorld,
    cluster: u32,
    which: Row,
    out_words: *mut u64,
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
        let mut bits = Bitset::new(n as usize);
        match which {
            Row::Pvs => w.world.decode_pvs(cluster, &mut bits),
            Row::Phs => w.world.decode_phs(cluster, &mut bits),
        }
        // SAFETY: forwarded contract.
        unsafe { write_list(bits.words(), out_words, capacity, out_count) }
    })
}

/// The PVS row of `cluster` as 64-bit words: cluster `j` is potentially visible from `cluster`
/// when bit `j % 64` (least significant first) of word `j / 64` is set; bits past the last
/// cluster are clear. There are `(sl_world_num_clusters + 63) / 64` words; a level without vis
/// data has every cluster's bit set. Buffer protocol: writes at most `capacity` words to
/// `out_words` and the full word count to `out_count` (call with NULL/0 first to get the count).
/// `SL_ERR_RANGE` when `cluster >= sl_world_num_clusters` (a leaf without a cluster sees
/// everything, as in Quake). Allocates a row per call.
///
/// # Safety
/// `world` must be a live world, `out_words` writable for `capacity` words (may be null when
/// `capacity` is 0), `out_count` writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_pvs_row(
    world: *const SlWorld,
    cluster: u32,
    out_words: *mut u64,
    capacity: usize,
    out_count: *mut usize,
) -> SlStatus {
    // SAFETY: forwarded contract.
    unsafe { row(world, cluster, Row::Pvs, out_words, capacity, out_count) }
}

/// The PHS row of `cluster` (bit `j` set: a sound in cluster `j` may be heard from `cluster`), in
/// the layout and buffer protocol of [`sl_pvs_row`]. A Quake 2 file's own PHS is used; otherwise
/// the first call on a world computes every row (tens of milliseconds on a large map).
///
/// # Safety
/// As [`sl_pvs_row`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_phs_row(
    world: *const SlWorld,
    cluster: u32,
    out_words: *mut u64,
    capacity: usize,
    out_count: *mut usize,
) -> SlStatus {
    // SAFETY: forwarded contract.
    unsafe { row(world, cluster, Row::Phs, out_words, capacity, out_count) }
}

/// The open (non-solid) world leaves that the axis-aligned box from `mins[0..3]` to `maxs[0..3]`
/// (world units; swapped corners span the same box) touches, each once, in tree order (Quake's
/// efrags). Conservative: a box within 1/32 unit of a leaf counts as touching it. Buffer
/// protocol as [`sl_visible_leaves`]: writes at most `capacity` leaves, and the full count.
///
/// # Safety
/// `world` must be a live world, `mins`/`maxs` 3 readable floats each, `out_leaves` writable for
/// `capacity` entries (may be null when `capacity` is 0), `out_count` writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_leaves_touching(
    world: *const SlWorld,
    mins: *const f32,
    maxs: *const f32,
    out_leaves: *mut u32,
    capacity: usize,
    out_count: *mut usize,
) -> SlStatus {
    guard(|| {
        // SAFETY: null or live/readable per the contract.
        let (Some(w), Some(a), Some(b)) =
            (unsafe { world.as_ref() }, unsafe { read3(mins) }, unsafe { read3(maxs) })
        else {
            return null_argument();
        };
        let mut leaves = Vec::new();
        w.world.leaves_touching(a, b, &mut leaves);
        // SAFETY: forwarded contract.
        unsafe { write_list(&leaves, out_leaves, capacity, out_count) }
    })
}

/// Whether the box from `mins[0..3]` to `maxs[0..3]` (world units) is potentially visible from
/// `eye[0..3]`: `out_visible` is 1 when the box touches an open leaf whose cluster is in the PVS
/// of the eye's cluster, else 0. Conservative; an eye in solid or outside the world sees
/// everything, as in Quake.
///
/// # Safety
/// `world` must be a live world, `eye`/`mins`/`maxs` 3 readable floats each, `out_visible`
/// writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sl_box_potentially_visible(
    world: *const SlWorld,
    eye: *const f32,
    mins: *const f32,
    maxs: *const f32,
    out_visible: *mut i32,
) -> SlStatus {
    guard(|| {
        // SAFETY: null or live/readable/writable per the contract.
        let (Some(w), Some(e), Some(a), Some(b), Some(out)) = (
            unsafe { world.as_ref() },
            unsafe { read3(eye) },
            unsafe { read3(mins) },
            unsafe { read3(maxs) },
            unsafe { out_visible.as_mut() },
        ) else {
            return null_argument();
        };
        let mut bits = Bitset::default();
        *out = i32::from(w.world.box_potentially_visible(e, a, b, &mut bits));
        SL_OK
    })
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
/// [`sl_world_free`]; empty for a texture missing from a BSP). Null, with [`sl_last_error`] set,
/// for a null world or `texture >= sl_world_num_textures`.
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
/// [`sl_visible_leaves`]. `SL_ERR_RANGE` when `cluster >= sl_world_num_clusters`.
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

/// The buffer protocol: copy `min(src.len(), capacity)` items to `out` and store `src.len()` in
/// `out_count`.
///
/// # Safety
/// `out` must be writable for `capacity` items (it may be null when `capacity` is 0) and
/// `out_count` null or writable.
unsafe fn write_list<T: Copy>(src: &[T], out: *mut T, capacity: usize, out_count: *mut usize) -> SlStatus {
    // SAFETY: null or writable per the contract.
    let Some(count) = (unsafe { out_count.as_mut() }) else { return null_argument() };
    if out.is_null() && capacity > 0 {
        set_error("null buffer with non-zero capacity".to_string());
        return SL_ERR_NULL;
    }
    let n = src.len().min(capacity);
    if n > 0 {
        // SAFETY: non-null and writable for `capacity >= n` items per the contract.
        unsafe { std::slice::from_raw_parts_mut(out, n) }.copy_from_slice(&src[..n]);
    }
    *count = src.len();
    SL_OK
}

/// Write three floats to a C pointer.
///
/// # Safety
/// `p` must be non-null and point to 3 writable floats.
unsafe fn write3(p: *mut f32, v: Vec3A) {
    // SAFETY: per the contract.
    unsafe { std::slice::from_raw_parts_mut(p, 3) }.copy_from_slice(&v.to_array());
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
