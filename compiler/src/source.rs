//! What to compile: a parsed `.map` or a triangle mesh ([`Source`]), read from a file.

use sightline_formats::map::MapFile;

use crate::mesh;

/// What to compile.
#[derive(Debug, Clone)]
pub enum Source {
    /// A parsed `.map`.
    Map {
        /// The map.
        map: MapFile,
        /// File name for messages.
        file: String,
    },
    /// A triangle mesh (from `.obj`): its triangles build a polygon BSP.
    Mesh {
        /// The mesh.
        mesh: mesh::Mesh,
        /// File name for messages.
        file: String,
    },
}

/// Why [`Source::read`] failed; every variant names the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SourceError {
    /// The file could not be read ([`sightline_job::input::read_input`]: a regular file only).
    #[error(transparent)]
    Read(#[from] sightline_job::input::InputError),
    /// The `.map` does not parse.
    #[error(transparent)]
    Map(#[from] sightline_formats::map::MapError),
    /// The `.obj` could not be loaded.
    #[error(transparent)]
    Obj(#[from] sightline_formats::obj::ObjError),
    /// The file is a compiled map ([`sightline_formats::bsp::Game::sniff`]), not a source: the
    /// message suggests `sightline vis`, which is what a compiled map is given to.
    #[error("{file} is a compiled map ({game}), not a .map; did you mean `sightline vis {file}`?")]
    CompiledMap {
        /// The file.
        file: String,
        /// Its game and format, e.g. `Quake BSP29`.
        game: String,
    },
}

impl Source {
    /// Reads `path`: an `.obj` ([`sightline_formats::FileKind::from_extension`]) as a mesh, any
    /// other file as a `.map`. The file name kept for messages is `path` as given.
    ///
    /// A `.map` is read as bytes ([`sightline_formats::map::parse_bytes`]): UTF-8 text as it is,
    /// any other file as Latin-1, so Quake's high-bit characters in strings are accepted and kept
    /// (as the characters `U+0080..=U+00FF` in the level's entity text). An `.obj`'s faces of one
    /// or two vertices are skipped; [`compile`](fn@crate::compile) reports their count as a warning.
    pub fn read(path: &std::path::Path) -> Result<Self, SourceError> {
        let file = path.display().to_string();
        let bytes = sightline_job::input::read_input(path)?;
        if sightline_formats::FileKind::from_extension(path) == Some(sightline_formats::FileKind::Obj) {
            let mesh = mesh::Mesh::from(&sightline_formats::obj::load_from_bytes(&bytes, &file)?);
            return Ok(Source::Mesh { mesh, file });
        }
        if let Some(game) = sightline_formats::bsp::Game::sniff(&bytes) {
            let game = match game {
                sightline_formats::bsp::Game::Quake(version) => format!("{} {}", game.name(), version.name()),
                _ => game.name().to_string(),
            };
            return Err(SourceError::CompiledMap { file, game });
        }
        let map = sightline_formats::map::parse_bytes(&bytes, &file)?;
        Ok(Source::Map { map, file })
    }

    /// The file name kept for messages.
    pub fn file(&self) -> &str {
        match self {
            Source::Map { file, .. } | Source::Mesh { file, .. } => file,
        }
    }
}
