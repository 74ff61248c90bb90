//! `libsightline`: the C ABI of `sightline-runtime` (its module `ffi`, feature `ffi`) as a shared
//! and a static library, declared by `runtime/include/sightline.h`.
//!
//! # Build and install (Linux)
//! ```sh
//! cargo build --release -p sightline-capi
//! PREFIX=/usr/local VERSION=0.1.0
//! install -Dm644 runtime/include/sightline.h "$PREFIX/include/sightline.h"
//! install -Dm755 target/release/libsightline_capi.so "$PREFIX/lib/libsightline.so.$VERSION"
//! ln -sf "libsightline.so.$VERSION" "$PREFIX/lib/libsightline.so.0"   # the SONAME
//! ln -sf libsightline.so.0 "$PREFIX/lib/libsightline.so"             # for -lsightline
//! install -Dm644 target/release/libsightline_capi.a "$PREFIX/lib/libsightline.a"
//! sed -e "s|@PREFIX@|$PREFIX|" -e "s|@VERSION@|$VERSION|" runtime/capi/sightline.pc.in \
//!     > "$PREFIX/lib/pkgconfig/sightline.pc"
//! cc app.c $(pkg-config --cflags --libs sightline)
//! ```
//! Static linking: `pkg-config --static --libs sightline` adds the system libraries Rust's
//! standard library needs.

pub use sightline_runtime::ffi::*;
