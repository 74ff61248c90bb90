//! Why a level could not be loaded.

use sightline_formats::rle::RleError;
use thiserror::Error;

/// A level failed validation (or its file failed to parse). After a successful load no query can
/// fail or panic, so this is the runtime's only error type.
#[derive(Debug, Error)]
pub enum LoadError {
    /// The level has no model 0 (the world).
    #[error("level has no world model")]
    NoWorldModel,
    /// A plane's normal is not unit length or a value is not finite.
    #[error("plane {index} is not a finite unit-normal plane")]
    BadPlane {
        /// Plane index.
        index: usize,
    },
    /// An index points outside its table.
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
    /// A non-solid leaf has non-finite or inverted bounds.
    #[error("{owner} {index} has non-finite or inverted bounds")]
    BadBounds {
        /// What has the bounds.
        owner: &'static str,
        /// Its index.
        index: usize,
    },
    /// A node is reached twice from the world root (a cycle or a shared subtree).
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
    /// A portal has fewer than 3 corners or a non-finite one.
    #[error("portal {index} has fewer than 3 corners or a non-finite corner")]
    BadPortal {
        /// Portal index.
        index: usize,
    },
    /// More clusters than leaves.
    #[error("{clusters} clusters for {leaves} leaves")]
    TooManyClusters {
        /// Cluster count.
        clusters: u32,
        /// Leaf count.
        leaves: usize,
    },
    /// PVS offsets do not match the cluster count.
    #[error("{rows} PVS rows for {clusters} clusters")]
    PvsRows {
        /// Rows present.
        rows: usize,
        /// Clusters.
        clusters: u32,
    },
    /// A PVS row does not decode.
    #[error("PVS row of cluster {cluster}: {source}")]
    PvsRow {
        /// Cluster.
        cluster: usize,
        /// Decoder error.
        #[source]
        source: RleError,
    },
    /// The level's GVS cells do not fit its faces.
    #[error("GVS data: {0}")]
    Gvs(#[from] crate::backend::gvs::GvsError),
    /// The `.slvl` file could not be read.
    #[error(transparent)]
    Slvl(#[from] sightline_formats::slvl::SlvlError),
    /// The `.bsp` file could not be read.
    #[error(transparent)]
    Bsp(#[from] sightline_formats::bsp::BspError),
    /// The `.prt` file could not be read.
    #[error(transparent)]
    PrtSyntax(#[from] sightline_formats::prt::PrtError),
    /// The `.prt` file does not fit the level.
    #[error("portal file: {0}")]
    Prt(String),
    /// Reading the file failed.
    #[error("{path}: {source}")]
    Io {
        /// The path.
        path: String,
        /// The IO error.
        #[source]
        source: std::io::Error,
    },
}
