//! Outputs that would destroy an input, or each other: found before any work, by file identity.
//!
//! Two spellings name the same file when they reach the same file on disk: `a.map` and `./a.map`,
//! a symlink and its target, two hard links. An output that exists is compared by identity
//! (device and inode on Unix, following symlinks) with every input and every other output; an
//! output that does not exist yet is compared by its absolute path (its folder resolved, symlinks
//! included) with the other outputs, since two of them may be about to be created at the same
//! place. [`check_apart`] refuses a run whose outputs would replace one of its inputs or one
//! another; [`check_outputs`] also checks that each output can be written where it points
//! ([`crate::atomic::check_writable`]: its folder exists and takes files, it is no folder, FIFO,
//! socket or block device), so a command refuses a bad output before its work, not after.

use std::io;
use std::path::{Path, PathBuf};

/// An output that would replace an input or another output of the same run.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{} is also {role} {}: writing it would replace that file; choose another output", output.display(), other.display())]
pub struct NotApart {
    /// The output as the caller named it.
    pub output: PathBuf,
    /// `"the input"` or `"another output of this run"`.
    pub role: &'static str,
    /// The input or output it would replace, as the caller named it.
    pub other: PathBuf,
}

/// Where a path leads: the file's identity when it exists, else its absolute path.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Place {
    File(u64, u64),
    Path(PathBuf),
}

fn place(path: &Path) -> io::Result<Place> {
    match std::fs::metadata(path) {
        Ok(meta) => Ok(identity(&meta, path)),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(Place::Path(absolute(path))),
        Err(e) => Err(e),
    }
}

#[cfg(unix)]
fn identity(meta: &std::fs::Metadata, _: &Path) -> Place {
    use std::os::unix::fs::MetadataExt;
    Place::File(meta.dev(), meta.ino())
}

#[cfg(not(unix))]
fn identity(_: &std::fs::Metadata, path: &Path) -> Place {
    Place::Path(absolute(path))
}

/// `path` made absolute with its folder resolved (symlinks followed where the folder exists).
fn absolute(path: &Path) -> PathBuf {
    let name = path.file_name().map(PathBuf::from).unwrap_or_default();
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    match std::fs::canonicalize(&dir) {
        Ok(d) => d.join(name),
        Err(_) => std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf()),
    }
}

/// Refuses `outputs` that would replace one of `inputs` or one another (see the module docs).
/// Inputs that cannot be found are skipped (their readers report them); an output whose place
/// cannot be told is reported as an I/O error naming it.
pub fn check_apart(inputs: &[&Path], outputs: &[&Path]) -> Result<(), CheckError> {
    let where_ = |p: &Path| {
        place(p).map_err(|source| CheckError::Io { path: p.to_path_buf(), message: source.to_string() })
    };
    let inputs: Vec<(&Path, Place)> = inputs
        .iter()
        .filter_map(|p| place(p).ok().filter(|pl| matches!(pl, Place::File(..))).map(|pl| (*p, pl)))
        .collect();
    let mut seen: Vec<(&Path, Place)> = Vec::with_capacity(outputs.len());
    for &out in outputs {
        let at = where_(out)?;
        if let Some((input, _)) = inputs.iter().find(|(_, p)| *p == at) {
            return Err(NotApart { output: out.into(), role: "the input", other: input.to_path_buf() }.into());
        }
        if let Some((other, _)) = seen.iter().find(|(_, p)| *p == at) {
            return Err(NotApart {
                output: out.into(),
                role: "another output of this run",
                other: other.to_path_buf(),
            }
            .into());
        }
        seen.push((out, at));
    }
    Ok(())
}

/// [`crate::atomic::check_writable`] for every output (a missing folder is said as such), then
/// [`check_apart`]: all that can be told about a run's outputs before its work.
pub fn check_outputs(inputs: &[&Path], outputs: &[&Path]) -> Result<(), CheckError> {
    for &out in outputs {
        crate::atomic::check_writable(out)
            .map_err(|e| CheckError::Unwritable { path: out.to_path_buf(), message: e.to_string() })?;
    }
    check_apart(inputs, outputs)
}

/// Why [`check_apart`] or [`check_outputs`] refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CheckError {
    /// An output would replace an input or another output.
    #[error(transparent)]
    NotApart(#[from] NotApart),
    /// Where an output leads could not be told.
    #[error("cannot check the output {}: {message}", path.display())]
    Io {
        /// The output.
        path: PathBuf,
        /// Why.
        message: String,
    },
    /// An output cannot be written where it points ([`check_outputs`]).
    #[error("cannot write the output {}: {message}", path.display())]
    Unwritable {
        /// The output.
        path: PathBuf,
        /// Why.
        message: String,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("sightline-apart-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).expect("temp dir");
        d
    }

    #[test]
    fn the_same_file_by_any_spelling_is_refused() {
        let d = dir("same");
        let a = d.join("a.map");
        std::fs::write(&a, b"x").expect("write");
        let dotted = d.join(".").join("a.map");
        assert!(matches!(check_apart(&[&a], &[&dotted]), Err(CheckError::NotApart(_))));
        #[cfg(unix)]
        {
            let link = d.join("link.map");
            std::os::unix::fs::symlink(&a, &link).expect("symlink");
            assert!(
                matches!(check_apart(&[&a], &[&link]), Err(CheckError::NotApart(_))),
                "a symlink to the input"
            );
            let hard = d.join("hard.map");
            std::fs::hard_link(&a, &hard).expect("hard link");
            assert!(matches!(check_apart(&[&hard], &[&a]), Err(CheckError::NotApart(_))), "a hard link");
        }
        let fresh = d.join("b.slvl");
        assert_eq!(check_apart(&[&a], &[&fresh]), Ok(()));
        let also_fresh = d.join(".").join("b.slvl");
        let e = check_apart(&[&a], &[&fresh, &also_fresh]).expect_err("two outputs at one new place");
        assert!(e.to_string().contains("another output"), "{e}");
        assert_eq!(
            check_apart(&[&d.join("missing.map")], &[&fresh]),
            Ok(()),
            "a missing input is its reader's to report"
        );
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn outputs_that_cannot_be_written_are_refused_naming_them() {
        let d = dir("writable");
        let a = d.join("a.map");
        std::fs::write(&a, b"x").expect("write");
        let fresh = d.join("a.slvl");
        assert_eq!(check_outputs(&[&a], &[&fresh]), Ok(()));
        let nowhere = d.join("no-such-folder").join("a.slvl");
        let e = check_outputs(&[&a], &[&fresh, &nowhere]).expect_err("no folder");
        assert!(matches!(&e, CheckError::Unwritable { path, .. } if *path == nowhere), "{e:?}");
        let e = check_outputs(&[&a], &[&d]).expect_err("a folder");
        assert!(e.to_string().contains(&d.display().to_string()), "{e}");
        assert!(matches!(check_outputs(&[&a], &[&a]), Err(CheckError::NotApart(_))), "writable, not apart");
        let _ = std::fs::remove_dir_all(&d);
    }
}
