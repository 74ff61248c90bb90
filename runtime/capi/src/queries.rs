//! Point, box and row queries: the leaf at a point, traces, leaf contents, clusters and bounds,
//! PVS and PHS rows, the leaves a box touches and whether a box is potentially visible.

use sightline_runtime::Bitset;

use crate::handles::*;
use crate::lists::*;
use crate::status::*;

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
/// protocol as [`sl_visible_leaves`](crate::sl_visible_leaves): writes at most `capacity` leaves, and the
/// full count.
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
