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
//!   nor a stray temporary file.

use std::fs::{self, File, OpenOptions};
use std::io::{self, Write};
use std::path::{Path, PathBuf};
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
    let real = match Target::of(path)? {
        Target::File(real) => real,
        Target::Device => return OpenOptions::new().write(true).open(path)?.write_all(bytes),
    };
    let path = real.as_path();
    let (dir, name) = dir_and_name(path)?;
    let (tmp, mut file) = create_temporary(dir, name)?;
    let result = (|| {
        file.write_all(bytes)?;
        if let Ok(meta) = fs::metadata(path) {
            file.set_permissions(meta.permissions())?;
        }
        if durability == Durability::Flushed {
            file.sync_all()?;
        }
        drop(file);
        fs::rename(&tmp, path)
    })();
    if result.is_err() {
        // Best effort: the temporary file is garbage whatever went wrong.
        let _ = fs::remove_file(&tmp);
        return result;
    }
    if durability == Durability::Flushed {
        sync_dir(dir);
    }
    Ok(())
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
            "{} is not a regular file (a FIFO, socket or block device): refusing to write to it",
            path.display()
        );
        Err(io::Error::new(io::ErrorKind::InvalidInput, msg))
    }
}

/// Creates a fresh temporary file for `name` in `dir`; never opens an existing file.
fn create_temporary(dir: &Path, name: &std::ffi::OsStr) -> io::Result<(PathBuf, File)> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
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
