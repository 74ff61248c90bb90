//! Why a run failed ([`VisError`]).

use std::any::Any;

/// What went wrong.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum VisError {
    /// The portal file is inconsistent.
    #[error("invalid portal file: {0}")]
    Invalid(String),
    /// An option is out of range.
    #[error("invalid option: {0}")]
    Option(String),
    /// A checkpoint could not be read or written, or belongs to another input.
    #[error("vis state: {0}")]
    State(String),
    /// A shard file of a plan ([`shard`](super::shard)) could not be read or written, belongs
    /// to another input, plan or version, or is missing from a merge.
    #[error("vis shard: {0}")]
    Shard(String),
    /// Stopped on request after `done` flow portals; the state file holds them.
    #[error("stopped after {done} of {total} portals (state saved)")]
    Interrupted {
        /// Flow portals finished.
        done: usize,
        /// Flow portals in all.
        total: usize,
    },
    /// The run would need more memory than is available or allowed; nothing was allocated.
    #[error("{what} would need {need_text} for {reason}: more than the {limit_text} {source_of_limit}; {hint}", need_text = crate::memory::format_size(*need), limit_text = crate::memory::format_size(*limit))]
    Memory {
        /// Estimated bytes ([`memory_estimate`](super::memory_estimate)).
        need: u64,
        /// The limit in bytes.
        limit: u64,
        /// What needs it (`vis`, `vis --fast`).
        what: String,
        /// What the memory is for (the matrices and the counts that size them).
        reason: String,
        /// Where the limit comes from.
        source_of_limit: crate::memory::LimitSource,
        /// What to do about it (rerun with `--coarsen`, or that coarsening did not help).
        hint: String,
    },
    /// The run's [`work_estimate`](super::work_estimate) is over [`VisOptions::max_work`](super::VisOptions::max_work); nothing was computed.
    #[error(
        "vis would take an estimated {need} portal tests ({reason}): more than the {limit} {source_of_limit}; {hint}"
    )]
    Work {
        /// Estimated portal tests ([`work_estimate`](super::work_estimate)).
        need: u64,
        /// The limit.
        limit: u64,
        /// The counts the estimate comes from.
        reason: String,
        /// Where the limit comes from (`--max-work`, or coarsening's default).
        source_of_limit: String,
        /// What to do about it.
        hint: String,
    },
    /// A bug: vis panicked (in a flow worker or elsewhere); every worker was stopped.
    #[error("vis panicked (a bug; every worker was stopped): {0}")]
    Panicked(String),
}

/// The error for a caught panic, with its message when it has one.
pub(super) fn panic_error(payload: Box<dyn Any + Send>) -> VisError {
    let message = payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "(no message)".to_string());
    VisError::Panicked(message)
}
