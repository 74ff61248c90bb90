//! Reading an input file whole, within a bound: the one way every reader in the project (maps,
//! meshes, portal files, compiled maps, levels, vis checkpoints, side files, pointfiles) takes a
//! file's bytes ([`read_input`]).
//!
//! # Conventions
//! - Only a regular file is read, reached by following symlinks (a link to a regular file is read
//!   as that file). A folder, FIFO, character or block device or socket is refused before it is
//!   opened, with an error saying which it is: a FIFO would block until some writer comes, a
//!   device such as `/dev/zero` never ends.
//! - On Unix the file is opened without blocking (`O_NONBLOCK`, and `O_NOCTTY`) and checked again
//!   once open, so a file swapped for a FIFO or a device between the check and the open is
//!   refused too, never waited on.
//! - At most the size the open file reports, plus one byte, is read: a file that grows while it
//!   is read is refused (something is still writing it), never read without end. A file that
//!   shrinks is returned as read; its format's reader reports what is missing.
//! - The buffer for the whole file is reserved before reading: a file larger than the memory the
//!   process can take is refused, naming its size, instead of aborting the process.

use std::fs::{File, Metadata, OpenOptions};
use std::io::{self, Read};
use std::path::{Path, PathBuf};

/// Why an input file was not read. Every variant names the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum InputError {
    /// The file could not be found, opened or read (the cause says why).
    #[error("cannot read {}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: io::Error,
    },
    /// The path leads to something that is not a regular file.
    #[error("cannot read {}: it is {kind}, not a regular file", path.display())]
    NotAFile {
        /// The file.
        path: PathBuf,
        /// What it is: `"a folder"`, `"a FIFO (named pipe)"`, `"a character device"`,
        /// `"a block device"`, `"a socket"`.
        kind: &'static str,
    },
    /// The file held more bytes than its size said when it was opened.
    #[error("cannot read {}: it grew past the {len} bytes it had when opened (is it still being written?)", path.display())]
    Grew {
        /// The file.
        path: PathBuf,
        /// Its size when opened.
        len: u64,
    },
    /// The file is larger than the memory the process can take.
    #[error("cannot read {}: its {len} bytes do not fit in memory", path.display())]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// Its size.
        len: u64,
    },
}

impl InputError {
    /// The file the error is about.
    pub fn path(&self) -> &Path {
        match self {
            Self::Io { path, .. }
            | Self::NotAFile { path, .. }
            | Self::Grew { path, .. }
            | Self::TooLarge { path, .. } => path,
        }
    }

    /// True when nothing exists at the path (for optional files such as side files).
    pub fn is_not_found(&self) -> bool {
        matches!(self, Self::Io { source, .. } if source.kind() == io::ErrorKind::NotFound)
    }
}

/// The bytes of the regular file at `path` (see the module docs for what is refused).
pub fn read_input(path: &Path) -> Result<Vec<u8>, InputError> {
    let io = |source| InputError::Io { path: path.to_path_buf(), source };
    // Checked before opening: opening a FIFO or a device can block or act on the device.
    regular(path, &std::fs::metadata(path).map_err(io)?)?;
    let mut file = open(path).map_err(io)?;
    let len = regular(path, &file.metadata().map_err(io)?)?.len();
    let too_large = || InputError::TooLarge { path: path.to_path_buf(), len };
    let cap = usize::try_from(len).ok().and_then(|l| l.checked_add(1)).ok_or_else(too_large)?;
    let mut bytes = Vec::new();
    bytes.try_reserve_exact(cap).map_err(|_| too_large())?;
    (&mut file).take(len.saturating_add(1)).read_to_end(&mut bytes).map_err(io)?;
    if bytes.len() as u64 > len {
        return Err(InputError::Grew { path: path.to_path_buf(), len });
    }
    Ok(bytes)
}

/// At most the first `max` bytes of the regular file at `path`, refused as [`read_input`]
/// refuses (fewer when the file is shorter): a header read without the file's body.
pub fn read_input_head(path: &Path, max: usize) -> Result<Vec<u8>, InputError> {
    let io = |source| InputError::Io { path: path.to_path_buf(), source };
    regular(path, &std::fs::metadata(path).map_err(io)?)?;
    let file = open(path).map_err(io)?;
    regular(path, &file.metadata().map_err(io)?)?;
    let mut bytes = Vec::with_capacity(max);
    file.take(max as u64).read_to_end(&mut bytes).map_err(io)?;
    Ok(bytes)
}

/// `meta` when it describes a regular file, else the error saying what `path` is.
fn regular<'m>(path: &Path, meta: &'m Metadata) -> Result<&'m Metadata, InputError> {
    if meta.is_file() {
        return Ok(meta);
    }
    Err(InputError::NotAFile { path: path.to_path_buf(), kind: kind(meta) })
}

/// What a file that is not regular is, for messages (readers' and writers' alike).
pub(crate) fn kind(meta: &Metadata) -> &'static str {
    let t = meta.file_type();
    if t.is_dir() {
        return "a folder";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    "a special file"
}

/// Opens `path` for reading without waiting for a writer (a FIFO) or taking a terminal.
fn open(path: &Path) -> io::Result<File> {
    let mut options = OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK | libc::O_NOCTTY);
    }
    options.open(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("sightline-input-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).expect("temp dir");
        d
    }

    #[test]
    fn a_regular_file_and_a_link_to_one_are_read_whole() {
        let d = dir("regular");
        let a = d.join("a.map");
        std::fs::write(&a, b"{ }\n").expect("write");
        assert_eq!(read_input(&a).expect("read"), b"{ }\n");
        let empty = d.join("empty.map");
        std::fs::write(&empty, b"").expect("write");
        assert_eq!(read_input(&empty).expect("read"), b"");
        #[cfg(unix)]
        {
            let link = d.join("link.map");
            std::os::unix::fs::symlink(&a, &link).expect("symlink");
            assert_eq!(read_input(&link).expect("read through the link"), b"{ }\n");
        }
        let missing = read_input(&d.join("missing.map")).expect_err("missing");
        assert!(missing.is_not_found(), "{missing:?}");
        assert!(missing.to_string().contains("missing.map"), "{missing}");
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn a_head_is_at_most_its_bytes() {
        let d = dir("head");
        let a = d.join("a.state");
        std::fs::write(&a, b"0123456789").expect("write");
        assert_eq!(read_input_head(&a, 4).expect("head"), b"0123");
        assert_eq!(read_input_head(&a, 16).expect("short file"), b"0123456789");
        assert!(read_input_head(&d.join("missing"), 4).expect_err("missing").is_not_found());
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn what_is_not_a_regular_file_is_refused_naming_it_and_what_it_is() {
        let d = dir("special");
        let mut cases: Vec<(PathBuf, &str)> = vec![(d.clone(), "folder")];
        #[cfg(unix)]
        {
            cases.push((PathBuf::from("/dev/zero"), "character device"));
            cases.push((PathBuf::from("/dev/null"), "character device"));
            let fifo = d.join("pipe.prt");
            let made = std::process::Command::new("mkfifo").arg(&fifo).status();
            if made.is_ok_and(|s| s.success()) {
                // Nothing ever writes it: reading it would block forever.
                cases.push((fifo.clone(), "FIFO"));
                let link = d.join("to-pipe.prt");
                std::os::unix::fs::symlink(&fifo, &link).expect("symlink");
                cases.push((link, "FIFO"));
            }
            let socket = d.join("s.sock");
            if let Ok(_listener) = std::os::unix::net::UnixListener::bind(&socket) {
                let e = read_input(&socket).expect_err("a socket");
                assert!(e.to_string().contains("socket"), "{e}");
            }
        }
        for (path, what) in cases {
            let e = read_input(&path).expect_err("refused");
            assert!(matches!(e, InputError::NotAFile { .. }), "{}: {e:?}", path.display());
            let msg = e.to_string();
            assert!(msg.contains(&path.display().to_string()) && msg.contains(what), "{msg}");
            assert_eq!(e.path(), path);
            let head = read_input_head(&path, 16).expect_err("its head refused too");
            assert!(matches!(head, InputError::NotAFile { .. }), "{}: {head:?}", path.display());
        }
        let _ = std::fs::remove_dir_all(&d);
    }

    /// A file holding more than its size says (as one still being written) is refused, not read
    /// to its end: `/proc` files report a size of 0.
    #[cfg(target_os = "linux")]
    #[test]
    fn a_file_longer_than_its_size_is_refused() {
        let e = read_input(Path::new("/proc/self/status")).expect_err("more than 0 bytes");
        assert!(matches!(e, InputError::Grew { len: 0, .. }), "{e:?}");
    }
}
