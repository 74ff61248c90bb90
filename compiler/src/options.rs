//! How to compile ([`CompileOptions`]).

use sightline_job::cancel::Cancel;

use crate::vis;

/// Options of [`compile`](fn@crate::compile).
#[derive(Debug, Clone, Default)]
pub struct CompileOptions {
    /// Worker threads (`None`: rayon's default).
    pub threads: Option<usize>,
    /// Return a level even when the map leaks (without filling the outside, and without vis).
    pub allow_leak: bool,
    /// Run vis on the portals and store the PVS in the level (`None`: stop after portals).
    pub vis: Option<vis::VisOptions>,
    /// Refuse (with [`CompileError::Vis`](crate::CompileError::Vis) holding [`vis::VisError::Memory`]) a vis whose
    /// [`vis::memory_estimate`] is above this many bytes, before allocating it (the smaller of
    /// this and [`vis::VisOptions::max_memory`] applies; the memory the machine has available is
    /// always a limit too).
    pub max_memory: Option<u64>,
    /// Stops the compile at its next safe point once cancelled (between brushes, tree nodes and
    /// phases, and at vis's next batch boundary) with [`CompileError::Cancelled`](crate::CompileError::Cancelled);
    /// vis uses this token too, whatever [`vis::VisOptions::cancel`] holds.
    pub cancel: Cancel,
}
