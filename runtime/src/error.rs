//! Why a level could not be loaded, or its GVS cells not used.
//!
//! This is the bottom layer of the crate: it imports nothing from it, so every other module may
//! return these errors.

use sightline_formats::slvl::SlvlError;
use thiserror::Error;

/// A level failed validation (or its file failed to parse). After a successful load no query can
/// fail or panic, so this is the runtime's only error type for worlds.
///
/// A level is checked in two steps (see [`crate::world`]): first the rules every reader of a level
/// relies on, owned by [`sightline_formats::slvl::validate`] and reported as
/// [`LoadError::Invalid`]; then the runtime's own rules (the other variants).
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum LoadError {
    /// The level breaks a rule of [`sightline_formats::slvl::validate`] (an index out of range, a
    /// non-finite value, a cycle, a PVS row that does not decode, ...).
    #[error("invalid level")]
    Invalid(#[source] SlvlError),
    /// The level has no model 0 (the world). [`sightline_formats::slvl::validate`] refuses such a
    /// level first ([`LoadError::Invalid`]); this is the runtime's own guard, for a level that
    /// reached it unchecked.
    #[error("the models lump is empty: the level has no world model (model 0)")]
    NoWorldModel,
    /// A plane's normal is not unit length.
    #[error("plane {index} is not a finite unit-normal plane")]
    BadPlane {
        /// Plane index.
        index: usize,
    },
    /// A count or index the runtime cannot represent.
    #[error("{owner} {index}: {what} index {value} out of range")]
    Index {
        /// Which table the index points into.
        what: &'static str,
        /// What holds the index.
        owner: &'static str,
        /// Index of the holder.
        index: usize,
        /// The offending value (or end of range).
        value: u64,
    },
    /// A non-solid leaf has inverted bounds.
    #[error("{owner} {index} has non-finite or inverted bounds")]
    BadBounds {
        /// What has the bounds.
        owner: &'static str,
        /// Its index.
        index: usize,
    },
    /// A node is reached twice from the world root (a shared subtree).
    #[error("node {index} is reached twice from the world root: not a tree")]
    NotATree {
        /// Node index.
        index: usize,
    },
    /// A non-solid leaf is reached twice from the world root.
    #[error("non-solid leaf {index} is reached twice from the world root")]
    SharedLeaf {
        /// Leaf index.
        index: usize,
    },
    /// The world tree is deeper than [`crate::world::MAX_TREE_DEPTH`].
    #[error("world tree deeper than {max}")]
    TooDeep {
        /// The limit.
        max: usize,
    },
    /// The level's entity text is malformed, or a brush entity's origin is not three finite
    /// numbers (the source names the byte offset in the entity text).
    #[error("entity text")]
    Entities(#[source] sightline_formats::entities::EntityError),
    /// The level's GVS cells do not fit its faces.
    #[error("GVS data")]
    Gvs(#[from] GvsError),
    /// The `.slvl` file could not be read.
    #[error(transparent)]
    Slvl(#[from] SlvlError),
    /// The `.bsp` file could not be read.
    #[error(transparent)]
    Bsp(#[from] sightline_formats::bsp::BspError),
    /// The `.prt` file could not be read.
    #[error(transparent)]
    PrtSyntax(#[from] sightline_formats::prt::PrtError),
    /// The `.prt` file does not fit the level.
    #[error("portal file: {0}")]
    Prt(String),
    /// The file `path` holds what failed to load (the cause is the source); from
    /// [`crate::load::load_path`], which names the file of every error this way (but for `Io`).
    #[error("{path}")]
    File {
        /// The file.
        path: String,
        /// What is wrong with it.
        #[source]
        source: Box<LoadError>,
    },
    /// Reading the file failed, or it is not a regular file (the error names it).
    #[error(transparent)]
    Io(#[from] sightline_job::input::InputError),
}

/// Why a level's GVS lumps cannot be used ([`crate::gvs_cells::GvsCells::from_level`]).
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[non_exhaustive]
pub enum GvsError {
    /// A cell's face range lies outside `gvs_faces`.
    #[error("gvs cell {cell}: faces {first}..+{count} outside the {len} gvs_faces")]
    CellRange {
        /// Cell index.
        cell: usize,
        /// First face entry.
        first: u32,
        /// Entry count.
        count: u32,
        /// Length of `gvs_faces`.
        len: usize,
    },
    /// A face index or its corners are out of range, or a bound is not finite.
    #[error("gvs face entry {entry}: {detail}")]
    Face {
        /// Entry in `gvs_faces`.
        entry: usize,
        /// What is wrong.
        detail: String,
    },
}
