//! Writing the files a command makes from its work (levels, portal files, pointfiles, BSPs and
//! `.vis` files written by vis): atomically, and flushed to disk when the work behind them took
//! long enough for that to matter ([`Durability::for_work`]; a small map's whole vis lasts a few
//! milliseconds, a fifth to a third of which the flushes would be). Checkpoints are always
//! flushed, by the library that writes them.

use std::path::Path;
use std::time::Instant;

use anyhow::Context;
use sightline_job::atomic::{Durability, write_file_with, write_files_with};

/// Refuses, before any work, outputs that would replace one of the command's `inputs` or one
/// another (by file identity, so `./a.map`, symlinks and hard links count as the same file), or
/// that cannot be written where they point (a missing folder, a FIFO):
/// [`sightline_job::apart::check_outputs`].
pub fn check(inputs: &[&Path], outputs: &[&Path]) -> anyhow::Result<()> {
    Ok(sightline_job::apart::check_outputs(inputs, outputs)?)
}

/// Writes files that belong together ([`write_files_with`]: all or none replaced, renamed in the
/// order given), with the durability of work started at `started`.
pub fn write_together(files: &[(&Path, &[u8])], started: Instant) -> anyhow::Result<()> {
    Ok(write_files_with(files, Durability::for_work(started.elapsed()))?)
}

/// Removes `path`, an output of an earlier run that no longer describes this run's result (`what`
/// it is, for the note), when it is a regular file; says so on stderr.
pub fn remove_stale(path: &Path, what: &str) {
    let regular = std::fs::symlink_metadata(path).is_ok_and(|m| m.is_file());
    if regular && std::fs::remove_file(path).is_ok() {
        eprintln!("removed {} ({what})", path.display());
    }
}

/// Writes `bytes` to `path` atomically, with the durability of work started at `started`.
pub fn write(path: &Path, bytes: &[u8], started: Instant) -> anyhow::Result<()> {
    write_file_with(path, bytes, Durability::for_work(started.elapsed()))
        .with_context(|| format!("cannot write {}", path.display()))
}
