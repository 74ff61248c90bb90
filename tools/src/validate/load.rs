//! Loading a level from any file `validate` and `render` accept.

use std::path::Path;

use anyhow::{Context, bail};
use sightline_formats::{Level, bsp, slvl};

/// Read a Sightline `.slvl`, or a Quake `.bsp` (through [`bsp::to_level`]: one cluster per vis
/// leaf), as a [`Level`].
pub fn load_level(path: &Path) -> anyhow::Result<Level> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    match ext.as_str() {
        "bsp" => {
            let b = bsp::read(&bytes).with_context(|| format!("{}", path.display()))?;
            Ok(bsp::to_level(&b))
        }
        "slvl" => slvl::read(&bytes).with_context(|| format!("{}", path.display())),
        _ => bail!("{}: expected a .bsp or .slvl file", path.display()),
    }
}
