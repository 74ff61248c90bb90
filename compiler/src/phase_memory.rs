//! Memory checks of the compile's phases before vis: before each phase, what it will add is
//! estimated from the counts the previous phases produced, and the phase is refused
//! ([`CompileError::Memory`]) when that does not fit (vis checks its own matrices, see
//! [`crate::vis::memory_estimate`]).
//!
//! The estimates are upper bounds per element, measured on real and generated maps (2026-11-28:
//! LibreQuake's lq_e1m2, id's dm1, a room of 4,000 small brushes) with a margin of about two:
//! CSG holds its input and its fragments (at most [`CSG_PER_SIDE`] per brush side, or
//! [`MESH_PER_TRIANGLE`] per triangle of a mesh, whose tree is built in the same phase), the tree
//! adds at most [`BSP_PER_SIDE`] per side, portals [`PORTALS_PER_ENTRY`] per node or leaf, the
//! outside fill [`OUTSIDE_PER_ENTRY`], and emitting the level [`EMIT_PER_FACE`] per CSG face plus
//! [`EMIT_PER_PORTAL`] per portal.
//!
//! A phase's need is checked against every limit of [`crate::memory::limits`]: the memory
//! available, the cgroup's and the rlimits' headroom (all of which already exclude what the
//! process holds) take what the phase adds; `--max-memory` takes that plus what the process holds
//! now (its resident size).

use crate::error::CompileError;
use crate::memory::{self, LimitSource};

/// Bytes CSG may add per brush side of a map.
pub const CSG_PER_SIDE: u64 = 2 << 10;
/// Bytes the mesh's CSG-and-tree phase may add per triangle.
pub const MESH_PER_TRIANGLE: u64 = 3 << 10;
/// Bytes the world tree may add per brush side.
pub const BSP_PER_SIDE: u64 = 1 << 10;
/// Bytes portal building may add per entry of the tree (node or leaf).
pub const PORTALS_PER_ENTRY: u64 = 1 << 10;
/// Bytes the outside fill may add per entry of the tree.
pub const OUTSIDE_PER_ENTRY: u64 = 256;
/// Bytes emitting the level may add per CSG face.
pub const EMIT_PER_FACE: u64 = 1 << 10;
/// Bytes emitting the level may add per portal.
pub const EMIT_PER_PORTAL: u64 = 256;

/// The limits of one compile, found once, and the file they are reported against.
#[derive(Debug)]
pub struct PhaseMemory<'a> {
    file: &'a str,
    limits: Vec<(u64, LimitSource)>,
}

impl<'a> PhaseMemory<'a> {
    /// The limits for a compile of `file` on `threads` worker threads under `max`
    /// (`--max-memory`; see [`memory::limits`]).
    pub fn new(file: &'a str, max: Option<u64>, threads: usize) -> Self {
        Self { file, limits: memory::limits(max, threads) }
    }

    /// Refuses `phase` when `adds` bytes (its estimate, for `what`) do not fit.
    pub fn check(
        &self,
        phase: &'static str,
        adds: u64,
        what: impl FnOnce() -> String,
    ) -> Result<(), CompileError> {
        let held = memory::resident().unwrap_or(0);
        // The limit left least room for this phase, if any is exceeded.
        let over = self
            .limits
            .iter()
            .map(|&(limit, source)| {
                let need = if source == LimitSource::Explicit { held.saturating_add(adds) } else { adds };
                (need, limit, source)
            })
            .filter(|&(need, limit, _)| need > limit)
            .max_by_key(|&(need, limit, _)| need - limit);
        match over {
            None => Ok(()),
            Some((need, limit, source_of_limit)) => Err(CompileError::Memory {
                file: self.file.to_string(),
                phase,
                need,
                limit,
                source_of_limit,
                what: what(),
            }),
        }
    }
}

/// Bytes times a count, saturating.
pub fn per(bytes: u64, count: usize) -> u64 {
    bytes.saturating_mul(count as u64)
}
