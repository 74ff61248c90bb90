//! Loading a level from any file `validate` and `render` accept.

use std::path::{Path, PathBuf};

use sightline_formats::bsp::BspError;
use sightline_formats::slvl::SlvlError;
use sightline_formats::{Level, bsp, slvl};
use sightline_job::input::{InputError, read_input};
use sightline_job::progress::Progress;

/// Why a level file could not be loaded. Each variant names the file; the cause, when there is
/// one, is the error's [`source`](std::error::Error::source).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LoadError {
    /// The file could not be read, or is not a regular file (the error names it).
    #[error(transparent)]
    Io(#[from] InputError),
    /// A `.bsp` file that is not a valid Quake-family BSP.
    #[error("{}", .path.display())]
    Bsp {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        #[source]
        source: BspError,
    },
    /// A `.slvl` file that is not a valid Sightline level.
    #[error("{}", .path.display())]
    Slvl {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        #[source]
        source: SlvlError,
    },
    /// Neither `.bsp` nor `.slvl`.
    #[error("{}: expected a .bsp or .slvl file", .path.display())]
    UnknownExtension {
        /// The file.
        path: PathBuf,
    },
}

/// Read a Sightline `.slvl`, or a compiled map of any Quake-family game as a [`Level`] through
/// the one view every reader shares ([`bsp::CompiledMap::to_level_with_repairs`]: Quake 1 and
/// Half-Life one cluster per vis leaf, Quake 2 and 3 the file's clusters). Each repair of stored
/// bounds that sampling or drawing uses (an open leaf's, a model's) is a warning to `progress`
/// naming the file.
pub fn load_level(path: &Path, progress: &dyn Progress) -> Result<Level, LoadError> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let bytes = read_input(path)?;
    match ext.as_str() {
        "bsp" => {
            let err = |source| LoadError::Bsp { path: path.to_path_buf(), source };
            let (level, repairs) = bsp::CompiledMap::read(bytes).map_err(err)?.to_level_with_repairs();
            for r in repairs {
                progress.warn(&format!("{}: {r}", path.display()));
            }
            Ok(level)
        }
        "slvl" => slvl::read(&bytes).map_err(|source| LoadError::Slvl { path: path.to_path_buf(), source }),
        _ => Err(LoadError::UnknownExtension { path: path.to_path_buf() }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::error::Error as _;

    /// The CLI prints an error and its sources joined by ": " (anyhow's `{:#}`).
    fn chain(e: &dyn std::error::Error) -> String {
        let mut s = e.to_string();
        let mut cur = e.source();
        while let Some(c) = cur {
            s += &format!(": {c}");
            cur = c.source();
        }
        s
    }

    #[test]
    fn errors_name_the_file_once() {
        let e = load_level(Path::new("/nonexistent/x.bsp"), &crate::NoProgress).unwrap_err();
        let io = std::fs::read("/nonexistent/x.bsp").unwrap_err();
        assert_eq!(chain(&e), format!("cannot read /nonexistent/x.bsp: {io}"));
        let dir = std::env::temp_dir().join(format!("sightline-validate-load-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (bad_bsp, other) = (dir.join("bad.bsp"), dir.join("level.txt"));
        std::fs::write(&bad_bsp, b"nope").unwrap();
        std::fs::write(&other, b"nope").unwrap();
        let e = load_level(&bad_bsp, &crate::NoProgress).unwrap_err();
        let cause = e.source().unwrap().to_string();
        assert_eq!(chain(&e), format!("{}: {cause}", bad_bsp.display()));
        let e = load_level(&other, &crate::NoProgress).unwrap_err();
        assert_eq!(chain(&e), format!("{}: expected a .bsp or .slvl file", other.display()));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
