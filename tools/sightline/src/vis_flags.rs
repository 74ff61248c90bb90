//! The vis flags that `sightline vis` and `sightline compile` share.

use std::path::PathBuf;

use sightline_compiler::vis::VisOptions;

/// The vis flags that `sightline vis` and `sightline compile` share.
#[derive(Debug, Clone, clap::Args)]
pub struct VisFlags {
    /// Base vis only (like the reference `-fast`): fast and loose.
    #[arg(long)]
    pub fast: bool,
    /// Separator tests, 0..=4 as the reference `vis -level` defines them (4 is the tightest).
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u8).range(0..=4))]
    pub level: u8,
    /// Checkpoint file: resumed from when present, written every `--checkpoint-secs` and on
    /// Ctrl-C. The same command run again resumes from it. A damaged or stale file (other input
    /// or options) is refused; one crafted to pass the checks is trusted and can hide leaves:
    /// resume only files a run of this program wrote.
    #[arg(long)]
    pub state: Option<PathBuf>,
    /// Seconds between checkpoints, 1 to 31536000 (a year).
    #[arg(long, default_value_t = 180, value_parser = clap::value_parser!(u64).range(1..=31_536_000))]
    pub checkpoint_secs: u64,
    /// Stop after this many flow portals (after writing the state): for testing resumes.
    #[arg(long, hide = true)]
    pub stop_after: Option<usize>,
    /// Refuse a vis (and each compile phase) whose estimated memory is above this size (bytes, or
    /// with K, M, G, T: 512M, 8G); what the process may still take (available memory, cgroup and
    /// `ulimit -v` limits) is always a limit too.
    #[arg(long, value_name = "SIZE", value_parser = sightline_compiler::memory::parse_size)]
    pub max_memory: Option<u64>,
    /// Refuse a vis whose estimated work is above this many portal tests (a number: 2e11,
    /// 500000000000). The estimate (`work_estimate` in `--json`; a base-vis test counts as ten)
    /// grows with the square of the portals; about 10^8 tests take a second of one core.
    #[arg(long, value_name = "TESTS", value_parser = parse_count)]
    pub max_work: Option<u64>,
    /// A work limit given as time (`90s`, `15m`, `1h30m`, `2h`; a bare number is seconds): the
    /// limit `--max-work` sets to 10^8 portal tests per second, a fixed rate, so the same
    /// budget merges alike on every machine (deterministic output) but is not a promise of wall
    /// time: on a 2-core test machine a vis inside it took a half to a fifth of the time given.
    #[arg(long, value_name = "DURATION", value_parser = parse_duration, conflicts_with = "max_work")]
    pub max_time: Option<f64>,
    /// Over the memory or work limit, merge clusters into coarser ones until the vis fits instead
    /// of refusing: a looser PVS (never hiding a visible leaf), reported with a warning. Without
    /// `--max-work` it merges down to 2e11 portal tests (under an hour of one core).
    #[arg(long)]
    pub coarsen: bool,
}

/// A count for `--max-work`: a whole number, or a decimal one with an exponent (`2e11`).
fn parse_count(s: &str) -> Result<u64, String> {
    let t = s.trim();
    if let Ok(n) = t.parse::<u64>() {
        return Ok(n);
    }
    match t.parse::<f64>() {
        Ok(v) if v.is_finite() && (0.0..u64::MAX as f64).contains(&v) => Ok(v as u64),
        _ => Err(format!("`{s}` is not a count of portal tests (a number: 2e11, 500000000000)")),
    }
}

/// Seconds for `--max-time`: numbers with units `h`, `m`, `s` in that order (`1h30m`, `15m`,
/// `90s`, `1.5h`), or a bare number of seconds; more than zero, at most a year.
fn parse_duration(s: &str) -> Result<f64, String> {
    let bad = || format!("`{s}` is not a duration (90s, 15m, 1h30m, 2h, or seconds)");
    let t = s.trim();
    if let Ok(v) = t.parse::<f64>() {
        return (v.is_finite() && v > 0.0 && v <= YEAR).then_some(v).ok_or_else(bad);
    }
    let (mut total, mut rest, mut last_unit) = (0.0, t, 0usize);
    while !rest.is_empty() {
        let end = rest.find(|c: char| !(c.is_ascii_digit() || c == '.')).ok_or_else(bad)?;
        let value: f64 = rest[..end].parse().map_err(|_| bad())?;
        let unit = rest[end..].chars().next().ok_or_else(bad)?;
        let (rank, scale) = match unit {
            'h' => (1, 3600.0),
            'm' => (2, 60.0),
            's' => (3, 1.0),
            _ => return Err(bad()),
        };
        if rank <= last_unit {
            return Err(bad());
        }
        last_unit = rank;
        total += value * scale;
        rest = &rest[end + 1..];
    }
    (last_unit > 0 && total.is_finite() && total > 0.0 && total <= YEAR).then_some(total).ok_or_else(bad)
}

/// The longest `--max-time`, in seconds.
const YEAR: f64 = 31_536_000.0;

impl Default for VisFlags {
    /// The command-line defaults: full vis at level 4, no state file.
    fn default() -> Self {
        Self {
            fast: false,
            level: 4,
            state: None,
            checkpoint_secs: 180,
            stop_after: None,
            max_memory: None,
            max_work: None,
            max_time: None,
            coarsen: false,
        }
    }
}

impl VisFlags {
    /// The vis options these flags ask for (every core; Ctrl-C stops at the next batch).
    pub fn options(&self) -> VisOptions {
        VisOptions {
            fast: self.fast,
            level: self.level,
            state: self.state.clone(),
            checkpoint_interval: std::time::Duration::from_secs(self.checkpoint_secs),
            stop_after: self.stop_after,
            cancel: crate::interrupt::cancel(),
            max_memory: self.max_memory,
            max_work: self
                .max_work
                .or(self.max_time.map(|t| (t * sightline_compiler::vis::WORK_PER_SECOND as f64) as u64)),
            coarsen: self.coarsen,
            ..VisOptions::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn durations_parse_with_units_in_order_and_nothing_else() {
        for (text, want) in [
            ("90", 90.0),
            ("90s", 90.0),
            ("15m", 900.0),
            ("1h30m", 5400.0),
            ("1.5h", 5400.0),
            ("2h5s", 7205.0),
        ] {
            assert_eq!(parse_duration(text), Ok(want), "{text}");
        }
        for text in ["", "0", "-5m", "15x", "m", "5m1h", "1m1m", "nan", "inf", "1e9", "h", "1h 5m"] {
            assert!(parse_duration(text).is_err(), "{text:?} parsed");
        }
    }
}
