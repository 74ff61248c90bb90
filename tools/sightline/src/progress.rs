//! Progress bars on a terminal, silent otherwise (`indicatif` hides itself when stderr is not a
//! TTY) and always silent under `--json`. [`Bars`] draws the libraries' [`Progress`] reports.

use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

use indicatif::{ProgressBar, ProgressStyle};
use sightline_job::progress::Progress;

/// A bar of `len` steps labelled `phase`; hidden when `quiet` or when stderr is not a terminal.
pub fn bar(phase: &str, len: u64, quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new(len);
    let style = ProgressStyle::with_template("{prefix:>10} [{bar:40}] {pos}/{len} {per_sec} eta {eta}")
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> ");
    pb.set_style(style);
    pb.set_prefix(phase.to_string());
    pb
}

/// A [`Progress`] that draws one [`bar`] per phase.
#[derive(Debug)]
pub struct Bars {
    quiet: bool,
    /// Steps gathered before the bar is updated (1: every step).
    batch: u64,
    bar: Mutex<Option<ProgressBar>>,
    pending: AtomicU64,
}

impl Bars {
    /// Bars updated on every step, hidden when `quiet`.
    pub fn new(quiet: bool) -> Self {
        Self::batched(quiet, 1)
    }

    /// Bars updated once `batch` steps have gathered (and at the end of a phase): for phases of
    /// many small steps reported from several threads, where locking the bar per step costs.
    pub fn batched(quiet: bool, batch: u64) -> Self {
        Self { quiet, batch: batch.max(1), bar: Mutex::new(None), pending: AtomicU64::new(0) }
    }

    /// Run `f` (which prints) with the current bar, if any, hidden.
    pub fn suspend<R>(&self, f: impl FnOnce() -> R) -> R {
        match self.bar.lock() {
            Ok(b) => match b.as_ref() {
                Some(b) => b.suspend(f),
                None => f(),
            },
            Err(_) => f(),
        }
    }
}

impl Progress for Bars {
    fn begin(&self, phase: &str, total: u64) {
        self.pending.store(0, Ordering::Relaxed);
        if let Ok(mut b) = self.bar.lock() {
            *b = Some(bar(phase, total, self.quiet));
        }
    }

    fn advance(&self, n: u64) {
        crate::interrupt::announce_stop();
        if self.quiet {
            return;
        }
        let pending = self.pending.fetch_add(n, Ordering::Relaxed) + n;
        if pending < self.batch {
            return;
        }
        let n = self.pending.swap(0, Ordering::Relaxed);
        if let Ok(b) = self.bar.lock()
            && let Some(b) = b.as_ref()
        {
            b.inc(n);
        }
    }

    fn note(&self, message: &str) {
        self.suspend(|| eprintln!("note: {message}"));
    }

    fn warn(&self, message: &str) {
        self.suspend(|| eprintln!("warning: {message}"));
    }

    fn end(&self) {
        if let Ok(mut b) = self.bar.lock()
            && let Some(b) = b.take()
        {
            b.inc(self.pending.swap(0, Ordering::Relaxed));
            b.finish_and_clear();
        }
    }
}
