//! Where the shared real maps (id's GPL release, LibreQuake, the reference compiler's outputs) live
//! for tests and benchmarks: `$SIGHTLINE_MAPS`, else `../shared/maps` beside the workspace. They
//! are never copied into the project.

use std::path::PathBuf;

/// The folder of shared maps, or `None` when it does not exist (callers say what they skip).
pub fn dir() -> Option<PathBuf> {
    let dir = std::env::var_os("SIGHTLINE_MAPS")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/maps"));
    dir.is_dir().then_some(dir)
}
