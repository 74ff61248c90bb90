//! Reading and writing C memory: the buffer protocol and three-float vectors.

use glam::Vec3A;

use crate::status::*;

/// The buffer protocol: copy `min(src.len(), capacity)` items to `out` and store `src.len()` in
/// `out_count`.
///
/// # Safety
/// `out` must be writable for `capacity` items (it may be null when `capacity` is 0) and
/// `out_count` null or writable.
pub(crate) unsafe fn write_list<T: Copy>(
    src: &[T],
    out: *mut T,
    capacity: usize,
    out_count: *mut usize,
) -> SlStatus {
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
pub(crate) unsafe fn write3(p: *mut f32, v: Vec3A) {
    // SAFETY: per the contract.
    unsafe { std::slice::from_raw_parts_mut(p, 3) }.copy_from_slice(&v.to_array());
}

/// Three floats from a C pointer.
///
/// # Safety
/// `p` must be null or point to 3 readable floats.
pub(crate) unsafe fn read3(p: *const f32) -> Option<Vec3A> {
    if p.is_null() {
        return None;
    }
    // SAFETY: non-null and 3 readable floats per the contract.
    let a = unsafe { std::slice::from_raw_parts(p, 3) };
    Some(Vec3A::new(a[0], a[1], a[2]))
}
