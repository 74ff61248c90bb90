//! `libsightline`: the C ABI of `sightline-runtime` as a shared and a static library, declared by
//! `runtime/capi/include/sightline.h` (written by hand; `tests/tests/e2e/ffi_header.rs` fails when
//! it and the exported functions of this crate drift apart).
//!
//! Conventions: every function returns an [`SlStatus`] code (0 = success) unless it only frees or
//! counts; on failure [`sl_last_error`] gives a message for the calling thread. Handles are opaque
//! pointers created by `sl_*_new`/`sl_world_load_*` and released by the matching `*_free`. A
//! world may be shared by threads; a scratch belongs to one thread at a time. No function
//! unwinds into C: a Rust panic (none is expected after a successful load) becomes
//! `SL_ERR_PANIC`. The crate uses only the runtime's public API.
//!
//! # Build and install (Linux)
//! `tools/install-capi.sh PREFIX` builds this crate in release and installs the header, the
//! shared library as `libsightline.so.VERSION` with the links `libsightline.so.0` (the SONAME) and
//! `libsightline.so`, the static library as `libsightline.a`, and `sightline.pc` (from
//! `sightline.pc.in`); `docs/engine.md` shows the `cc` lines, shared and static.

// Modules, one concern each; `status` and `handles` first, the entry points above them.
// The modules with entry points allow `unsafe_code`: a C ABI takes raw pointers from C (read and
// written in `unsafe` blocks, each with its SAFETY contract) and exports unmangled
// functions. `handles` needs none.

#[allow(unsafe_code)] // C ABI: raw pointers from C, read and written by `draw`'s entry points.
mod draw;
mod handles;
#[allow(unsafe_code)] // C ABI: raw pointers from C (the buffer protocol's reads and writes).
mod lists;
#[allow(unsafe_code)] // C ABI: raw pointers from C, read and written by the query entry points.
mod queries;
#[allow(unsafe_code)] // C ABI: unmangled exports returning C strings.
mod status;
#[allow(unsafe_code)] // C ABI: raw pointers from C, read and written by the culling entry points.
mod walk;
#[allow(unsafe_code)] // C ABI: raw pointers from C, handles boxed into and freed from C.
mod world;

pub use draw::*;
pub use handles::*;
pub use queries::*;
pub use status::*;
pub use walk::*;
pub use world::*;
