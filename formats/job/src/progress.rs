//! How long-running library work (compiling, vis, validating, GVS baking) reports progress: a
//! phase with a number of steps ([`phase`] begins one and ends it when its guard drops), steps
//! done (possibly from several worker threads), and what the user should hear at once (a note, a
//! warning). Libraries call it; the `sightline` binary draws progress bars and prints with it;
//! [`NoProgress`] shows nothing. Stopping is the other half of the protocol
//! ([`crate::cancel::Cancel`]).

/// Receives progress; implementations must accept [`Progress::advance`] from any thread.
pub trait Progress: Sync {
    /// A phase starts with `total` steps.
    fn begin(&self, phase: &str, total: u64);
    /// `n` steps of the current phase are done.
    fn advance(&self, n: u64);
    /// The current phase is over.
    fn end(&self);
    /// Something the user should know now, which changes nothing (for example that vis merges
    /// clusters to fit its limits). Shown nowhere by default.
    fn note(&self, message: &str) {
        let _ = message;
    }
    /// Something wrong with the input that the work goes on past (for example a side file that
    /// belongs to another compile). Shown nowhere by default.
    fn warn(&self, message: &str) {
        let _ = message;
    }
}

/// Seconds as progress lines say them: whole seconds (`12 s`), or minutes and seconds from a
/// minute on (`4 min 05 s`).
pub fn format_seconds(s: f64) -> String {
    let s = s.max(0.0).round() as u64;
    if s < 60 { format!("{s} s") } else { format!("{} min {:02} s", s / 60, s % 60) }
}

/// A [`Progress`] that shows nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoProgress;

impl Progress for NoProgress {
    fn begin(&self, _: &str, _: u64) {}
    fn advance(&self, _: u64) {}
    fn end(&self) {}
}

/// A phase in progress: begun by [`phase`], ended when dropped (also on an early `?` return), so
/// no caller can forget to close a progress bar.
#[must_use = "the phase ends when this guard is dropped"]
pub struct Phase<'a> {
    progress: &'a dyn Progress,
}

impl std::fmt::Debug for Phase<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Phase")
    }
}

impl Phase<'_> {
    /// `n` more steps of this phase are done.
    pub fn advance(&self, n: u64) {
        self.progress.advance(n);
    }
}

impl Drop for Phase<'_> {
    fn drop(&mut self) {
        self.progress.end();
    }
}

/// Begins phase `name` of `total` steps on `progress`; the phase ends when the guard drops.
pub fn phase<'a>(progress: &'a dyn Progress, name: &str, total: u64) -> Phase<'a> {
    progress.begin(name, total);
    Phase { progress }
}
