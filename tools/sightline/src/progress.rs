//! Progress bars on a terminal, silent otherwise (`indicatif` hides itself when stderr is not a
//! TTY) and always silent under `--json`.

use indicatif::{ProgressBar, ProgressStyle};

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
