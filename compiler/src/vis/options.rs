//! What a run is asked to do ([`VisOptions`]). A run reports as it goes through
//! [`sightline_job::progress::Progress`]: phases `vis base` (a step per portal) and `vis flow`
//! (as many steps as one-way portals, each flow bringing its share by expected cost,
//! [`estimate::progress_steps`](super::estimate::progress_steps)), and a note when clusters are
//! merged to fit the limits.

use std::path::PathBuf;
use std::time::Duration;

use sightline_job::cancel::Cancel;

/// Options of [`run`](super::run).
#[derive(Debug, Clone)]
pub struct VisOptions {
    /// Stop after base vis (`mightsee`), like the reference `-fast`.
    pub fast: bool,
    /// Separator tests, 0..=4 as the reference `vis -level` defines them (4 is the tightest).
    pub level: u8,
    /// Seed flows with clusters known visible through their portal by certified sight lines
    /// (`certify`) and with those earlier flows from the same cluster saw (on by default). Off, every flow finds
    /// everything itself: more work, and about the PVS the seeds would leave (the beam cull
    /// depends on the order clusters are found in, and a seeded flow's row also holds portals
    /// into clusters only its cluster's other portals see).
    pub seeds: bool,
    /// Worker threads; 0 uses every core, or one for a run estimated below [`SERIAL_WORK`](super::SERIAL_WORK).
    /// The result is the same for any count.
    pub threads: usize,
    /// Checkpoint file: loaded when present (resume), written every `checkpoint_interval`.
    pub state: Option<PathBuf>,
    /// Time between checkpoints.
    pub checkpoint_interval: Duration,
    /// Stop (with [`VisError::Interrupted`](super::VisError::Interrupted), after a checkpoint) once at least this many flow
    /// portals are finished: for tests of resuming.
    pub stop_after: Option<usize>,
    /// Stop the same way at the next batch boundary once this token is cancelled (for example
    /// by a Ctrl-C handler): with [`VisOptions::state`] the finished portals are saved first.
    pub cancel: Cancel,
    /// Refuse (with [`VisError::Memory`](super::VisError::Memory)) a run whose [`memory_estimate`](super::memory_estimate) is above this many
    /// bytes; the memory the process may still take ([`crate::memory::limit`]) is always a
    /// limit too.
    pub max_memory: Option<u64>,
    /// Refuse (with [`VisError::Work`](super::VisError::Work)) a run whose [`work_estimate`](super::work_estimate) is above this many portal
    /// tests. With [`VisOptions::coarsen`] and no limit given, [`COARSEN_MAX_WORK`](super::COARSEN_MAX_WORK) applies.
    pub max_work: Option<u64>,
    /// Over either limit, merge clusters until both estimates fit ([`coarsen`](super::coarsen)) instead of
    /// refusing.
    pub coarsen: bool,
    /// Flow in this many waves of equal size instead of the default batches: a portal reads the
    /// rows of earlier waves only, as the shards of a plan of that many waves do
    /// ([`shard`](super::shard)), so this one-process run gives their merge, byte for byte.
    pub waves: Option<u32>,
    /// Take the flow rows from the shard files of a plan instead of flowing ([`shard`](super::shard)).
    pub merge: Option<super::plan::MergeSpec>,
    /// Tests only: panic in the flow at this position of the processing order.
    #[cfg(test)]
    pub(crate) panic_at: Option<usize>,
    /// Tests only: the chain cap of flows on merged clusters, instead of `budget::chain_cap`'s.
    #[cfg(test)]
    pub(crate) chain_cap: Option<u64>,
}

impl Default for VisOptions {
    fn default() -> Self {
        Self {
            fast: false,
            level: 4,
            seeds: true,
            threads: 0,
            state: None,
            checkpoint_interval: Duration::from_secs(180),
            stop_after: None,
            cancel: Cancel::new(),
            max_memory: None,
            max_work: None,
            coarsen: false,
            waves: None,
            merge: None,
            #[cfg(test)]
            panic_at: None,
            #[cfg(test)]
            chain_cap: None,
        }
    }
}
