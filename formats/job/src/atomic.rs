//! Crash-safe file writing: the one way every writer in the project (levels, portal files,
//! pointfiles, BSPs written by vis, vis checkpoints, images) puts a file on disk.
//!
//! # Conventions
//! - The bytes go to a new temporary file in the target's own folder (so the rename cannot cross
//!   file systems), named `.<file name>.<process id>.<counter>.tmp`: unique within the process
//!   and across processes, and created exclusively, so a concurrent writer is never clobbered.
//! - The temporary file gets the permissions of the file it replaces, when there is one.
//! - It is renamed over the target, so a crash of the writing process leaves the old content or
//!   the new, never a mix. With [`Durability::Flushed`] (the default, and what checkpoints use)
//!   it is first flushed to disk (`fsync`) and on Unix the folder is synced after the rename, so
//!   the new content also survives a power failure once the call returns. Outputs that took less
//!   than [`Durability::FLUSH_AFTER`] to compute skip the flushes ([`Durability::for_work`]).
//! - On any error the temporary file is removed: a failed write leaves neither a partial target
//!   nor a stray temporary file. A writer killed between write and rename leaves its temporary
//!   file; the next process to write that name in that folder removes it (on Linux).
//! - Files that belong together are written with [`write_files_with`]: all or none replaced.

use std::fs::{self, File, OpenOptions};
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

/// What a write survives besides a crash of the writing process (which it always survives: the
/// rename is atomic either way).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Durability {
    /// The file is flushed (`fsync`) before the rename and its folder after: once the write
    /// returns, its content survives a power failure or a kernel crash.
    Flushed,
    /// The rename alone. After a power failure within the system's write-back delay (seconds),
    /// the file holds its old or its new content on file systems that write a renamed file's data
    /// before the rename (ext4's default `auto_da_alloc`, btrfs), and may be empty on others.
    Renamed,
}

impl Durability {
    /// Work behind an output from which it is flushed. The two flushes cost about a millisecond of
    /// waiting on a virtual disk (0.5–0.8 ms measured on this project's build hosts, ext4), a
    /// fifth to a third of a whole `sightline vis` of a small map, and next to nothing beside a
    /// second of work. Below it an output takes the risk every Quake tool's output takes (they
    /// rewrite the file in place without a flush): after a power cut in the seconds before the
    /// system writes it back, it may be empty on a file system that does not order the rename.
    pub const FLUSH_AFTER: Duration = Duration::from_secs(1);

    /// The durability of an output that took `work` to compute: [`Durability::Flushed`] from
    /// [`Durability::FLUSH_AFTER`] on, [`Durability::Renamed`] below it.
    pub fn for_work(work: Duration) -> Self {
        if work >= Self::FLUSH_AFTER { Self::Flushed } else { Self::Renamed }
    }
}

/// The folder `path` is in (`.` for a bare file name) and its file name.
fn dir_and_name(path: &Path) -> io::Result<(&Path, &std::ffi::OsStr)> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let name = path.file_name().ok_or_else(|| {
        io::Error::new(io::ErrorKind::InvalidInput, format!("{} names no file", path.display()))
    })?;
    Ok((dir, name))
}

/// Writes `bytes` to `path` so that `path` holds either its old content or all of `bytes`, never
/// a partial file, flushed to disk ([`Durability::Flushed`]; see the module docs).
pub fn write_file_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    write_file_with(path, bytes, Durability::Flushed)
}

/// [`write_file_atomic`] with the given [`Durability`]. What `path` points at is what gets
/// written ([`Target::of`]): a symlink's file is replaced and the link kept; a character device
/// (`/dev/null`, a terminal) is written directly; any other special file (a FIFO, a socket, a
/// block device) is refused.
pub fn write_file_with(path: &Path, bytes: &[u8], durability: Durability) -> io::Result<()> {
    write_files_with(&[(path, bytes)], durability).map_err(|e| e.source)
}

/// A write of [`write_files_with`] that failed, with the file it failed on.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {}: {source}", path.display())]
pub struct WriteError {
    /// The file (as the caller named it) whose write failed.
    pub path: PathBuf,
    /// What failed.
    #[source]
    pub source: io::Error,
}

/// Writes files that belong together (a level and its portal file) so that none is replaced
/// unless all could be written: every file is first written in full to its temporary file (and
/// flushed, with [`Durability::Flushed`]), and only then are they renamed over their targets, in
/// the order given. A failure while writing (no space, a folder in the way, a refused target)
/// removes every temporary file and replaces nothing. The renames follow one another at once, so
/// only a crash in those microseconds leaves an earlier file new and a later one old: put last the
/// file that records which others belong to it. Targets follow [`Target::of`] as
/// [`write_file_with`] does; a character device is written when its turn to be renamed comes.
pub fn write_files_with(files: &[(&Path, &[u8])], durability: Durability) -> Result<(), WriteError> {
    let mut staged: Vec<Staged> = Vec::with_capacity(files.len());
    let mut failure = None;
    for &(path, bytes) in files {
        match stage(path, bytes, durability) {
            Ok(s) => staged.push(s),
            Err(source) => {
                failure = Some(WriteError { path: path.to_path_buf(), source });
                break;
            }
        }
    }
    if let Some(e) = failure {
        discard(&staged);
        return Err(e);
    }
    for (i, s) in staged.iter().enumerate() {
        let done = match s {
            Staged::File { tmp, real, .. } => fs::rename(tmp, real),
            Staged::Device { path, bytes } => {
                OpenOptions::new().write(true).open(path).and_then(|mut f| f.write_all(bytes))
            }
        };
        if let Err(source) = done {
            discard(&staged[i..]);
            return Err(WriteError { path: files[i].0.to_path_buf(), source });
        }
    }
    if durability == Durability::Flushed {
        for s in &staged {
            if let Staged::File { real, .. } = s {
                sync_dir(dir_and_name(real).map_or(Path::new("."), |(d, _)| d));
            }
        }
    }
    Ok(())
}

/// A file of [`write_files_with`] ready to take its place.
enum Staged<'a> {
    /// Written in full to `tmp`, beside `real` (the file the target path leads to).
    File { tmp: PathBuf, real: PathBuf },
    /// A character device, written directly when its turn comes.
    Device { path: &'a Path, bytes: &'a [u8] },
}

/// Writes `bytes` to a temporary file beside the file `path` leads to.
fn stage<'a>(path: &'a Path, bytes: &'a [u8], durability: Durability) -> io::Result<Staged<'a>> {
    let real = match Target::of(path)? {
        Target::File(real) => real,
        Target::Device => return Ok(Staged::Device { path, bytes }),
    };
    if fs::metadata(&real).is_ok_and(|m| m.is_dir()) {
        // The rename would fail; find out before any file of the group is replaced.
        let msg = format!("{} is a folder", real.display());
        return Err(io::Error::new(io::ErrorKind::IsADirectory, msg));
    }
    let (dir, name) = dir_and_name(&real)?;
    let (tmp, mut file) = create_temporary(dir, name)?;
    let result = (|| {
        file.write_all(bytes)?;
        if let Ok(meta) = fs::metadata(&real) {
            file.set_permissions(meta.permissions())?;
        }
        if durability == Durability::Flushed {
            file.sync_all()?;
        }
        Ok(())
    })();
    match result {
        Ok(()) => Ok(Staged::File { tmp, real }),
        Err(e) => {
            // Best effort: the temporary file is garbage whatever went wrong.
            let _ = fs::remove_file(&tmp);
            Err(e)
        }
    }
}

/// Removes the temporary files of writes that will not happen (best effort).
fn discard(staged: &[Staged]) {
    for s in staged {
        if let Staged::File { tmp, .. } = s {
            let _ = fs::remove_file(tmp);
        }
    }
}

/// Checks, without writing `path`, that [`write_file_atomic`] could write it: `path` names a file
/// (not an existing folder) in a folder that exists and takes new files. It creates the temporary
/// file a write would and removes it at once. Commands that work long before writing call it first,
/// so a bad output path fails at once instead of after the work.
pub fn check_writable(path: &Path) -> io::Result<()> {
    let real = match Target::of(path)? {
        Target::Device => return Ok(()),
        Target::File(real) => real,
    };
    let path = real.as_path();
    let (dir, name) = dir_and_name(path)?;
    match fs::metadata(dir) {
        Ok(meta) if meta.is_dir() => {}
        Ok(_) => {
            let msg = format!("{} is not a folder", dir.display());
            return Err(io::Error::new(io::ErrorKind::NotADirectory, msg));
        }
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            let msg = format!("the folder {} does not exist", dir.display());
            return Err(io::Error::new(io::ErrorKind::NotFound, msg));
        }
        Err(e) => return Err(e),
    }
    if fs::metadata(path).is_ok_and(|m| m.is_dir()) {
        let msg = format!("{} is a folder", path.display());
        return Err(io::Error::new(io::ErrorKind::IsADirectory, msg));
    }
    let (tmp, file) = create_temporary(dir, name)?;
    drop(file);
    fs::remove_file(&tmp)
}

/// What writing to a path writes to.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Target {
    /// A regular file (existing or not) at this path: the given one, or the file its symlinks
    /// lead to, so the link is kept and its file replaced.
    File(PathBuf),
    /// A character device (`/dev/null`, a terminal): written directly, never replaced.
    Device,
}

impl Target {
    /// Where writing `path` goes. Refused (`InvalidInput`): a FIFO, a socket, a block device, and
    /// a symlink whose file cannot be found (a dangling or looping link).
    pub fn of(path: &Path) -> io::Result<Self> {
        // Nothing there (or no folder to hold it): a new file, whose write reports the folder.
        let Ok(first) = fs::symlink_metadata(path) else { return Ok(Self::File(path.to_path_buf())) };
        let link = first.file_type().is_symlink();
        let meta = match fs::metadata(path) {
            Ok(m) => m,
            Err(e) if link => {
                let msg = format!("{} is a symlink to a file that cannot be reached ({e})", path.display());
                return Err(io::Error::new(io::ErrorKind::InvalidInput, msg));
            }
            Err(e) => return Err(e),
        };
        let kind = meta.file_type();
        if kind.is_file() || kind.is_dir() {
            // A folder is refused by the rename (and by `check_writable`) with its own message.
            return Ok(Self::File(if link { fs::canonicalize(path)? } else { path.to_path_buf() }));
        }
        #[cfg(unix)]
        {
            use std::os::unix::fs::FileTypeExt;
            if kind.is_char_device() {
                return Ok(Self::Device);
            }
        }
        let msg = format!(
            "{} is {}, not a regular file: refusing to write to it",
            path.display(),
            crate::input::kind(&meta)
        );
        Err(io::Error::new(io::ErrorKind::InvalidInput, msg))
    }
}

/// Creates a fresh temporary file for `name` in `dir`; never opens an existing file. The first
/// time a process writes `name` in `dir`, it removes the temporary files of that name left by
/// writers that died ([`sweep_stale`]).
fn create_temporary(dir: &Path, name: &std::ffi::OsStr) -> io::Result<(PathBuf, File)> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    static SWEPT: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
    let key = dir.join(name);
    let first = SWEPT.lock().map(|mut swept| {
        let first = !swept.contains(&key);
        if first {
            swept.push(key);
        }
        first
    });
    if first.unwrap_or(false) {
        sweep_stale(dir, name);
    }
    loop {
        let mut tmp_name = std::ffi::OsString::from(".");
        tmp_name.push(name);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        tmp_name.push(format!(".{}.{n}.tmp", std::process::id()));
        let tmp = dir.join(tmp_name);
        match OpenOptions::new().write(true).create_new(true).open(&tmp) {
            Ok(file) => return Ok((tmp, file)),
            // Left behind by a crashed process that had the same id: take the next name.
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(e),
        }
    }
}

/// Removes from `dir` the temporary files of `name` (`.<name>.<process id>.<counter>.tmp`, regular
/// files only) whose process is no longer running: what a writer killed between its write and its
/// rename left behind. Only on Linux, where `/proc` tells whether a process runs; a process id
/// reused since counts as running and its file is left alone. Failures are ignored.
fn sweep_stale(dir: &Path, name: &std::ffi::OsStr) {
    if !cfg!(target_os = "linux") || !Path::new("/proc/self").exists() {
        return;
    }
    let Some(name) = name.to_str() else { return };
    let Ok(entries) = fs::read_dir(dir) else { return };
    let prefix = format!(".{name}.");
    for entry in entries.flatten() {
        let file_name = entry.file_name();
        let Some(rest) = file_name.to_str().and_then(|f| f.strip_prefix(&prefix)) else { continue };
        let Some(rest) = rest.strip_suffix(".tmp") else { continue };
        let Some((pid, counter)) = rest.split_once('.') else { continue };
        let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
        if !digits(pid) || !digits(counter) || pid == std::process::id().to_string() {
            continue;
        }
        let regular = entry.file_type().is_ok_and(|t| t.is_file());
        if regular && !Path::new("/proc").join(pid).exists() {
            let _ = fs::remove_file(entry.path());
        }
    }
}

/// Persists a rename in `dir`. The data is already safe in the file, so failures are ignored.
#[cfg(unix)]
fn sync_dir(dir: &Path) {
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
}

/// Directories cannot be opened as files on this platform; the rename is left to the system.
#[cfg(not(unix))]
fn sync_dir(_dir: &Path) {}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_dir(tag: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("sightline-atomic-{tag}-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn names(dir: &Path) -> Vec<std::ffi::OsString> {
        let mut names: Vec<_> = fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name()).collect();
        names.sort();
        names
    }

    #[test]
    fn replaces_content_and_leaves_no_temporary() {
        let dir = temp_dir("replace");
        let path = dir.join("level.slvl");
        write_file_atomic(&path, b"first").unwrap();
        write_file_atomic(&path, b"second").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"second");
        assert_eq!(names(&dir), [std::ffi::OsString::from("level.slvl")]);
        assert!(write_file_atomic(&dir.join("missing/x"), b"x").is_err());
        assert!(write_file_atomic(&dir, b"x").is_err(), "a folder is not replaced by a file");
        assert_eq!(names(&dir), [std::ffi::OsString::from("level.slvl")], "no temporary left");
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn files_that_belong_together_are_replaced_all_or_none() {
        let dir = temp_dir("group");
        let (level, prt) = (dir.join("k.slvl"), dir.join("k.prt"));
        write_files_with(&[(&prt, b"old prt"), (&level, b"old level")], Durability::Renamed).unwrap();
        // A folder in the way of the second file: neither is replaced, no temporary is left.
        fs::create_dir(dir.join("k.pts")).unwrap();
        let e = write_files_with(
            &[(&prt, b"new prt"), (&level, b"new level"), (&dir.join("k.pts"), b"pts")],
            Durability::Flushed,
        )
        .unwrap_err();
        assert_eq!(e.path, dir.join("k.pts"), "{e}");
        assert!(e.to_string().contains("k.pts"), "{e}");
        assert_eq!(fs::read(&prt).unwrap(), b"old prt");
        assert_eq!(fs::read(&level).unwrap(), b"old level");
        let expected: Vec<std::ffi::OsString> = ["k.prt", "k.pts", "k.slvl"].map(Into::into).to_vec();
        assert_eq!(names(&dir), expected);
        write_files_with(&[(&prt, b"new prt"), (&level, b"new level")], Durability::Flushed).unwrap();
        assert_eq!(fs::read(&prt).unwrap(), b"new prt");
        assert_eq!(fs::read(&level).unwrap(), b"new level");
        fs::remove_dir_all(&dir).unwrap();
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn temporaries_of_dead_writers_are_swept_and_live_ones_kept() {
        let dir = temp_dir("sweep");
        // No process has an id this large (Linux ids stop at 2^22); the parent runs.
        let dead = dir.join(".map.bsp.999999999.3.tmp");
        let live = dir.join(format!(".map.bsp.{}.0.tmp", std::os::unix::process::parent_id()));
        let other = dir.join(".other.bsp.999999999.0.tmp");
        let not_ours = dir.join(".map.bsp.999999999.tmp");
        for p in [&dead, &live, &other, &not_ours] {
            fs::write(p, b"partial").unwrap();
        }
        write_file_atomic(&dir.join("map.bsp"), b"whole").unwrap();
        assert!(!dead.exists(), "a dead writer's temporary of this name is removed");
        assert!(live.exists() && other.exists() && not_ours.exists(), "{:?}", names(&dir));
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn writability_is_checked_without_writing() {
        let dir = temp_dir("check");
        check_writable(&dir.join("level.slvl")).unwrap();
        assert!(names(&dir).is_empty(), "the probe leaves nothing behind");
        let e = check_writable(&dir.join("missing/level.slvl")).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::NotFound);
        assert!(e.to_string().contains("missing"), "{e}");
        assert_eq!(check_writable(&dir).unwrap_err().kind(), io::ErrorKind::IsADirectory);
        write_file_atomic(&dir.join("file"), b"x").unwrap();
        assert_eq!(
            check_writable(&dir.join("file/level.slvl")).unwrap_err().kind(),
            io::ErrorKind::NotADirectory
        );
        assert_eq!(names(&dir), [std::ffi::OsString::from("file")]);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn concurrent_writers_never_mix() {
        let dir = temp_dir("threads");
        let path = dir.join("out.bin");
        std::thread::scope(|s| {
            for t in 0..4u8 {
                let path = &path;
                // Half the writers skip the flushes: the rename alone keeps them from mixing.
                let durability = if t % 2 == 0 { Durability::Flushed } else { Durability::Renamed };
                s.spawn(move || {
                    for _ in 0..20 {
                        write_file_with(path, &[t; 4096], durability).unwrap();
                    }
                });
            }
        });
        let bytes = fs::read(&path).unwrap();
        assert!(bytes.len() == 4096 && bytes.iter().all(|&b| b == bytes[0]));
        assert_eq!(names(&dir), [std::ffi::OsString::from("out.bin")]);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn only_quick_work_skips_the_flushes() {
        let flush = Durability::FLUSH_AFTER;
        assert_eq!(Durability::for_work(Duration::ZERO), Durability::Renamed);
        assert_eq!(Durability::for_work(flush - Duration::from_nanos(1)), Durability::Renamed);
        assert_eq!(Durability::for_work(flush), Durability::Flushed);
        assert_eq!(Durability::for_work(Duration::from_secs(20 * 3600)), Durability::Flushed);
    }

    #[cfg(unix)]
    #[test]
    fn keeps_the_permissions_of_the_file_it_replaces() {
        use std::os::unix::fs::PermissionsExt;
        let dir = temp_dir("perms");
        let path = dir.join("map.bsp");
        write_file_atomic(&path, b"old").unwrap();
        fs::set_permissions(&path, fs::Permissions::from_mode(0o640)).unwrap();
        write_file_atomic(&path, b"new").unwrap();
        assert_eq!(fs::metadata(&path).unwrap().permissions().mode() & 0o777, 0o640);
        write_file_with(&path, b"newer", Durability::Renamed).unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"newer");
        assert_eq!(fs::metadata(&path).unwrap().permissions().mode() & 0o777, 0o640);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[cfg(unix)]
    #[test]
    fn a_symlink_keeps_pointing_at_its_file_which_gets_the_bytes() {
        let dir = temp_dir("symlink");
        let real = dir.join("real.bsp");
        fs::write(&real, b"old").unwrap();
        let link = dir.join("link.bsp");
        let _ = fs::remove_file(&link);
        std::os::unix::fs::symlink(&real, &link).unwrap();
        write_file_atomic(&link, b"new").unwrap();
        assert!(fs::symlink_metadata(&link).unwrap().file_type().is_symlink(), "the link is kept");
        assert_eq!(fs::read(&real).unwrap(), b"new", "its file got the bytes");
        let dangling = dir.join("dangling.bsp");
        let _ = fs::remove_file(&dangling);
        std::os::unix::fs::symlink(dir.join("nowhere"), &dangling).unwrap();
        assert_eq!(write_file_atomic(&dangling, b"x").unwrap_err().kind(), io::ErrorKind::InvalidInput);
        let _ = fs::remove_dir_all(&dir);
    }

    #[cfg(unix)]
    #[test]
    fn a_device_is_written_directly_and_a_fifo_refused() {
        use std::os::unix::fs::FileTypeExt;
        let null = Path::new("/dev/null");
        if fs::metadata(null).is_ok_and(|m| m.file_type().is_char_device()) {
            write_file_atomic(null, b"discarded").unwrap();
            check_writable(null).unwrap();
            assert!(fs::metadata(null).unwrap().file_type().is_char_device(), "/dev/null stays a device");
        }
        let dir = temp_dir("fifo");
        let fifo = dir.join("pipe");
        let _ = fs::remove_file(&fifo);
        if std::process::Command::new("mkfifo").arg(&fifo).status().is_ok_and(|s| s.success()) {
            let e = write_file_atomic(&fifo, b"x").unwrap_err();
            assert_eq!(e.kind(), io::ErrorKind::InvalidInput, "{e}");
            assert!(fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo(), "the FIFO is left alone");
        }
        let _ = fs::remove_dir_all(&dir);
    }
}
