//! Status codes, the calling thread's last error message, the panic guard every entry point runs
//! in, and the version string.

use std::cell::RefCell;
use std::ffi::{CString, c_char};
use std::panic::{AssertUnwindSafe, catch_unwind};

use crate::handles::c_string;

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

/// Backend selectors for [`sl_visible_leaves`](crate::sl_visible_leaves).
pub const SL_BACKEND_PVS: i32 = 0;
/// The portal backend.
pub const SL_BACKEND_PORTAL: i32 = 1;

/// An index (leaf, cluster, face, texture, model) was out of range.
pub const SL_ERR_RANGE: SlStatus = 6;

/// Leaf contents codes of [`sl_leaf_contents`](crate::sl_leaf_contents) (Quake's, as `Contents::code`):
/// empty.
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

thread_local! {
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

/// `err` and its sources joined by ": " (how the CLI prints errors too).
pub(crate) fn error_chain(err: &dyn std::error::Error) -> String {
    let mut text = err.to_string();
    let mut source = err.source();
    while let Some(e) = source {
        text.push_str(": ");
        text.push_str(&e.to_string());
        source = e.source();
    }
    text
}

pub(crate) fn set_error(message: String) {
    LAST_ERROR.with(|e| *e.borrow_mut() = c_string(&message));
}

pub(crate) fn null_argument() -> SlStatus {
    set_error("null argument".to_string());
    SL_ERR_NULL
}

pub(crate) fn out_of_range(what: &str, index: u32, count: usize) -> SlStatus {
    set_error(format!("{what} {index} out of range (the world has {count})"));
    SL_ERR_RANGE
}

pub(crate) fn guard(f: impl FnOnce() -> SlStatus) -> SlStatus {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(status) => status,
        Err(_) => {
            set_error("internal panic".to_string());
            SL_ERR_PANIC
        }
    }
}

/// The message of the last error on this thread (empty when none). Valid until the next failing
/// call on the same thread.
#[unsafe(no_mangle)]
pub extern "C" fn sl_last_error() -> *const c_char {
    LAST_ERROR.with(|e| e.borrow().as_ptr())
}

/// The crate version (`"MAJOR.MINOR.PATCH"`), a static NUL-terminated string.
#[unsafe(no_mangle)]
pub extern "C" fn sl_version() -> *const c_char {
    concat!(env!("CARGO_PKG_VERSION"), "\0").as_ptr().cast()
}
