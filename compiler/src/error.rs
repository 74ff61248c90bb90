//! Why a compile failed ([`CompileError`]).

use crate::report::LeakReport;
use crate::vis;

/// Why a compile failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CompileError {
    /// The map has no entities.
    #[error("{file}: the map has no entities (a map starts with a worldspawn entity)")]
    NoEntities {
        /// Source file.
        file: String,
    },
    /// The first entity is not worldspawn.
    #[error("{file}:{line}: the first entity is `{classname}`, expected `worldspawn`")]
    NoWorldspawn {
        /// Source file.
        file: String,
        /// Line of the entity.
        line: u32,
        /// Its class.
        classname: String,
    },
    /// A brush whose planes enclose nothing, or do not close.
    #[error("{file}:{line}: entity {entity} (`{classname}`) brush {brush}: {problem}")]
    BadBrush {
        /// Source file.
        file: String,
        /// Line of the brush.
        line: u32,
        /// Entity index.
        entity: usize,
        /// Entity class.
        classname: String,
        /// Brush index in the entity.
        brush: usize,
        /// What is wrong.
        problem: String,
    },
    /// A coordinate beyond the world limit.
    #[error("{file}:{line}: {what} lies beyond ±{limit} units", limit = sightline_formats::geom::WORLD_LIMIT)]
    HugeCoordinate {
        /// Source file.
        file: String,
        /// Line.
        line: u32,
        /// What it is.
        what: String,
    },
    /// An entity's `origin` is not three finite numbers.
    #[error("{file}:{line}: the origin of `{classname}` is \"{value}\", not three finite numbers")]
    BadOrigin {
        /// Source file.
        file: String,
        /// Line of the entity.
        line: u32,
        /// Its class.
        classname: String,
        /// The `origin` value as written.
        value: String,
    },
    /// Nothing to build a tree from.
    #[error("{file}: the world has no solid brushes to build a tree from")]
    EmptyWorld {
        /// Source file.
        file: String,
    },
    /// The mesh has no usable triangle.
    #[error("{file}: no triangle in the whole file has an area ({triangles} triangles read)")]
    EmptyMesh {
        /// Triangles the mesh has (all of them degenerate).
        triangles: usize,
        /// Source file.
        file: String,
    },
    /// The map leaks (and leaks were not allowed).
    #[error("{0}")]
    Leak(Box<LeakReport>),
    /// Vis failed, or stopped on request ([`vis::VisError::Interrupted`]: with a state file, the
    /// same compile resumes from it).
    #[error("vis")]
    Vis(#[from] vis::VisError),
    /// The compile was cancelled ([`crate::CompileOptions::cancel`]) during `phase`; nothing was
    /// returned.
    #[error("stopped during {phase}")]
    Cancelled {
        /// The phase that was running (`csg`, `bsp`, `portals`, `outside`, `emit`).
        phase: &'static str,
    },
    /// A phase's memory estimate does not fit what the process may still take
    /// ([`crate::phase_memory`]).
    #[error(
        "{file}: {phase} would need about {need_text} for {what}: more than the {limit_text} {source_of_limit}",
        need_text = crate::memory::format_size(*need),
        limit_text = crate::memory::format_size(*limit)
    )]
    Memory {
        /// Source file.
        file: String,
        /// The phase refused (`csg`, `bsp`, `portals`, `outside`, `emit`).
        phase: &'static str,
        /// Its estimate, in bytes.
        need: u64,
        /// The limit it exceeds, in bytes.
        limit: u64,
        /// Where the limit comes from.
        source_of_limit: crate::memory::LimitSource,
        /// What the estimate counts (`24,036 brush sides`).
        what: String,
    },
    /// Vis returned rows for another number of clusters than the level has.
    #[error("vis returned {got} clusters for {want}")]
    VisClusters {
        /// Clusters in the vis result.
        got: usize,
        /// Clusters in the level.
        want: usize,
    },
    /// The worker pool could not start.
    #[error("could not start {threads} worker threads: {message}")]
    Threads {
        /// Requested count.
        threads: usize,
        /// Why.
        message: String,
    },
}
