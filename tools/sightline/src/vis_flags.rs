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
    /// 500000000000). The estimate (`work_estimate` in `--json`) grows with the square of the
    /// portals; about 10^8 tests take a second of one core.
    #[arg(long, value_name = "TESTS", value_parser = parse_count)]
    pub max_work: Option<u64>,
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
            max_work: self.max_work,
            coarsen: self.coarsen,
            ..VisOptions::default()
        }
    }
}
