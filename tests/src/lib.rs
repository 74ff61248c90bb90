//! Helpers shared by the integration tests in `tests/tests/`.

use std::path::PathBuf;

/// The workspace root.
pub fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The bundled small maps (`maps/` in the workspace).
pub fn bundled_maps() -> PathBuf {
    workspace_root().join("maps")
}

/// The shared real maps: `$SIGHTLINE_MAPS`, or `../shared/maps` beside the workspace. Returns
/// `None`, after printing why, when the folder is absent, so a test can skip its real-map part
/// visibly rather than silently.
pub fn shared_maps() -> Option<PathBuf> {
    let dir = sightline_formats::shared_maps::dir();
    if dir.is_none() {
        eprintln!("note: real maps not found (set SIGHTLINE_MAPS); real-map checks are not run");
    }
    dir
}

/// The file `rel` (for example `ericw/e1m1.prt`) under [`shared_maps`], or `None`, after printing
/// why, when the maps or that file are absent.
pub fn shared_map(rel: &str) -> Option<PathBuf> {
    let p = shared_maps()?.join(rel);
    if p.is_file() {
        Some(p)
    } else {
        eprintln!("note: {} missing; its checks are not run", p.display());
        None
    }
}
