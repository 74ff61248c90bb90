//! Give the shared library the SONAME `libsightline.so.0` on Linux (the ABI major version; bump it
//! with an incompatible change to `runtime/capi/include/sightline.h`).

fn main() {
    if std::env::var("CARGO_CFG_TARGET_OS").is_ok_and(|os| os == "linux") {
        println!("cargo:rustc-cdylib-link-arg=-Wl,-soname,libsightline.so.0");
    }
    println!("cargo:rerun-if-changed=build.rs");
}
