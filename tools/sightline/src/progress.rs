//! Progress on stderr, and nothing under `--json` or `--no-progress`. [`Bars`] shows the
//! libraries' [`Progress`] reports: on a terminal as bars, elsewhere (an editor's compile console
//! such as TrenchBroom's, a log file) as plain lines ([`Plain`]), as ericw-tools prints them.

use std::io::IsTerminal;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};
use sightline_job::progress::Progress;
use sightline_job::progress::format_seconds as seconds;

/// A bar of `len` steps labelled `phase`; hidden when `quiet` or when stderr is not a terminal.
pub fn bar(phase: &str, len: u64, quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new(len);
    let style = ProgressStyle::with_template("{prefix:>10} [{bar:40}] {pos}/{len} {elapsed} eta {eta}")
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> ");
    pb.set_style(style);
    pb.set_prefix(phase.to_string());
    pb
}

/// A phase shown as plain lines: a line each time another tenth of it is done, once the phase
/// has run for [`Plain::QUIET_FOR`] (short phases print nothing), and a last line when it ends.
/// A line reads `vis flow: 40% (1225/3062), 12 s elapsed, about 18 s left`; the time left is
/// the elapsed time scaled by the steps left over the steps done.
#[derive(Debug)]
struct Plain {
    phase: String,
    total: u64,
    done: u64,
    start: Instant,
    /// Tenths already printed.
    shown: u64,
}

impl Plain {
    /// Phases shorter than this print nothing.
    const QUIET_FOR: Duration = Duration::from_secs(2);

    fn new(phase: &str, total: u64) -> Self {
        Self { phase: phase.to_string(), total, done: 0, start: Instant::now(), shown: 0 }
    }

    /// Count `n` more steps; the line to print, if a new tenth was reached.
    fn advance(&mut self, n: u64) -> Option<String> {
        self.done = self.done.saturating_add(n).min(self.total);
        let tenth = (self.done.saturating_mul(10)).checked_div(self.total)?;
        let elapsed = self.start.elapsed();
        if tenth <= self.shown || tenth >= 10 || elapsed < Self::QUIET_FOR {
            return None;
        }
        self.shown = tenth;
        let left = elapsed.as_secs_f64() * (self.total - self.done) as f64 / self.done.max(1) as f64;
        Some(format!(
            "{}: {}% ({}/{}), {} elapsed, about {} left",
            self.phase,
            tenth * 10,
            self.done,
            self.total,
            seconds(elapsed.as_secs_f64()),
            seconds(left)
        ))
    }

    /// The last line, when the phase was long enough to show.
    fn end(&self) -> Option<String> {
        let elapsed = self.start.elapsed();
        (elapsed >= Self::QUIET_FOR).then(|| {
            format!("{}: done ({} steps) in {}", self.phase, self.done, seconds(elapsed.as_secs_f64()))
        })
    }
}

/// How a phase is shown.
#[derive(Debug)]
enum Shown {
    Bar(ProgressBar),
    Lines(Plain),
}

/// A [`Progress`] that draws one [`bar`] per phase on a terminal, and plain lines elsewhere.
#[derive(Debug)]
pub struct Bars {
    quiet: bool,
    /// Plain lines instead of bars (stderr is not a terminal).
    plain: bool,
    /// Steps gathered before the bar is updated (1: every step).
    batch: u64,
    bar: Mutex<Option<Shown>>,
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
        let plain = !std::io::stderr().is_terminal();
        Self { quiet, plain, batch: batch.max(1), bar: Mutex::new(None), pending: AtomicU64::new(0) }
    }

    /// Run `f` (which prints) with the current bar, if any, hidden.
    pub fn suspend<R>(&self, f: impl FnOnce() -> R) -> R {
        match self.bar.lock() {
            Ok(b) => match b.as_ref() {
                Some(Shown::Bar(b)) => b.suspend(f),
                _ => f(),
            },
            Err(_) => f(),
        }
    }
}

impl Progress for Bars {
    fn begin(&self, phase: &str, total: u64) {
        self.pending.store(0, Ordering::Relaxed);
        if let Ok(mut b) = self.bar.lock() {
            *b = Some(match (self.quiet, self.plain) {
                (false, true) => Shown::Lines(Plain::new(phase, total)),
                _ => Shown::Bar(bar(phase, total, self.quiet)),
            });
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
        if let Ok(mut b) = self.bar.lock() {
            match b.as_mut() {
                Some(Shown::Bar(b)) => b.inc(n),
                Some(Shown::Lines(p)) => {
                    if let Some(line) = p.advance(n) {
                        eprintln!("{line}");
                    }
                }
                None => {}
            }
        }
    }

    fn note(&self, message: &str) {
        self.suspend(|| eprintln!("note: {message}"));
    }

    fn warn(&self, message: &str) {
        self.suspend(|| eprintln!("warning: {message}"));
    }

    fn end(&self) {
        if let Ok(mut b) = self.bar.lock() {
            let n = self.pending.swap(0, Ordering::Relaxed);
            match b.take() {
                Some(Shown::Bar(b)) => {
                    b.inc(n);
                    b.finish_and_clear();
                }
                Some(Shown::Lines(mut p)) => {
                    p.done = p.done.saturating_add(n).min(p.total);
                    if let Some(line) = p.end() {
                        eprintln!("{line}");
                    }
                }
                None => {}
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A phase already running for `secs`.
    fn running(total: u64, secs: u64) -> Plain {
        let mut p = Plain::new("vis flow", total);
        p.start = Instant::now().checked_sub(Duration::from_secs(secs)).unwrap_or(p.start);
        p
    }

    #[test]
    fn a_long_phase_prints_each_tenth_once_then_done() {
        let mut p = running(200, 30);
        let lines: Vec<String> = (0..200).filter_map(|_| p.advance(1)).collect();
        assert_eq!(lines.len(), 9, "{lines:?}");
        assert!(
            lines[0].starts_with("vis flow: 10% (20/200), 30 s elapsed, about 4 min 30 s left"),
            "{}",
            lines[0]
        );
        assert!(lines[8].starts_with("vis flow: 90% (180/200)"), "{}", lines[8]);
        assert_eq!(p.end().as_deref(), Some("vis flow: done (200 steps) in 30 s"));
    }

    #[test]
    fn a_short_phase_prints_nothing_and_an_empty_one_never_divides_by_zero() {
        let mut p = Plain::new("bsp", 10);
        assert!((0..10).all(|_| p.advance(1).is_none()));
        assert_eq!(p.end(), None);
        let mut empty = running(0, 30);
        assert_eq!(empty.advance(5), None);
    }

    #[test]
    fn big_steps_print_the_tenth_they_reach() {
        let mut p = running(100, 5);
        assert_eq!(p.advance(55).as_deref(), Some("vis flow: 50% (55/100), 5 s elapsed, about 4 s left"));
        assert_eq!(p.advance(1), None);
        assert_eq!(seconds(61.4), "1 min 01 s");
    }
}
