//! How long-running library work (compiling, validating, GVS baking) reports progress: a phase
//! with a number of steps, steps done (possibly from several worker threads), the phase's end.
//! Libraries call it; the `sightline` binary draws progress bars with it; [`NoProgress`] shows
//! nothing.

/// Receives progress; implementations must accept [`Progress::advance`] from any thread.
pub trait Progress: Sync {
    /// A phase starts with `total` steps.
    fn begin(&self, phase: &str, total: u64);
    /// `n` steps of the current phase are done.
    fn advance(&self, n: u64);
    /// The current phase is over.
    fn end(&self);
}

/// A [`Progress`] that shows nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoProgress;

impl Progress for NoProgress {
    fn begin(&self, _: &str, _: u64) {}
    fn advance(&self, _: u64) {}
    fn end(&self) {}
}
