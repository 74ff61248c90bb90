//! Which of Sightline's formats a file holds, from its name and first bytes only: nothing is
//! parsed, so this works without the `map` and `obj` features that the parsers of those formats
//! need.
//!
//! # Conventions
//! - The extension decides when it is one of `.map`, `.obj`, `.prt`, `.bsp`, `.slvl` (ASCII
//!   case-insensitive), whatever the bytes are.
//! - Otherwise the first bytes do: the `.slvl` magic `SLVL`; a BSP version (`29` little-endian,
//!   `BSP2`, `2PSB`, Half-Life's `30`, Quake 2's `IBSP`); `PRT1` or `PRT2` (which also starts `PRT1-AM`). Failing those, the first line
//!   of the first 4096 bytes (read lossily as UTF-8) that is neither blank nor a `//` comment: a `{`
//!   starts a `.map`, an `.obj` keyword (`v`, `vt`, `vn`, `f`, `o`, `g`, `s`, `mtllib`, `usemtl`,
//!   or a `#` comment) an `.obj`.

use std::path::Path;

use crate::bsp::BspVersion;

/// A kind of file Sightline reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FileKind {
    /// A Quake `.map` (Standard or Valve 220).
    Map,
    /// A Wavefront `.obj` mesh.
    Obj,
    /// A `.prt` portal file.
    Prt,
    /// A Quake-family BSP (Quake 1's BSP29, BSP2, BSP2-RMQ, Half-Life's BSP30, or Quake 2's
    /// `IBSP`).
    Bsp,
    /// A Sightline level (`.slvl`).
    Slvl,
}

/// Bytes of text looked at by [`FileKind::from_bytes`].
const TEXT_PREFIX: usize = 4096;

/// First words of `.obj` lines.
const OBJ_WORDS: [&str; 10] = ["v", "vt", "vn", "f", "o", "g", "#", "mtllib", "usemtl", "s"];

impl FileKind {
    /// The kind of the file at `path` whose content starts with `bytes`: by extension, then by
    /// content (see the module docs); `None` when neither tells.
    pub fn detect(path: &Path, bytes: &[u8]) -> Option<Self> {
        Self::from_extension(path).or_else(|| Self::from_bytes(bytes))
    }

    /// The kind named by the extension of `path`.
    pub fn from_extension(path: &Path) -> Option<Self> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Some(match ext.as_str() {
            "map" => Self::Map,
            "obj" => Self::Obj,
            "prt" => Self::Prt,
            "bsp" => Self::Bsp,
            "slvl" => Self::Slvl,
            _ => return None,
        })
    }

    /// The kind the first bytes of a file show.
    pub fn from_bytes(bytes: &[u8]) -> Option<Self> {
        let magic = bytes.get(..4)?;
        if magic == crate::slvl::MAGIC {
            return Some(Self::Slvl);
        }
        if BspVersion::ALL.iter().any(|v| magic == v.magic()) || magic == crate::bsp::q2::MAGIC {
            return Some(Self::Bsp);
        }
        if bytes.starts_with(b"PRT1") || bytes.starts_with(b"PRT2") {
            return Some(Self::Prt);
        }
        // Lossily: a prefix may end inside a character, and a `.map` may hold bytes that are not
        // UTF-8 (see `map::decode`); only the first line that says something is looked at.
        let text = String::from_utf8_lossy(bytes.get(..bytes.len().min(TEXT_PREFIX))?);
        let first = text.lines().map(str::trim).find(|l| !l.is_empty() && !l.starts_with("//"))?;
        if first.starts_with('{') {
            return Some(Self::Map);
        }
        OBJ_WORDS.contains(&first.split_whitespace().next()?).then_some(Self::Obj)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kind_from_extension_then_magic() {
        let none = Path::new("file");
        let kind_of = FileKind::detect;
        assert_eq!(kind_of(Path::new("a.MAP"), b""), Some(FileKind::Map));
        assert_eq!(kind_of(Path::new("a.bsp"), b"SLVL"), Some(FileKind::Bsp));
        assert_eq!(kind_of(Path::new("a.txt"), b"SLVL"), Some(FileKind::Slvl));
        assert_eq!(kind_of(none, b"SLVL\x01\0\0\0"), Some(FileKind::Slvl));
        assert_eq!(kind_of(none, &[29, 0, 0, 0, 1]), Some(FileKind::Bsp));
        assert_eq!(kind_of(none, &[30, 0, 0, 0, 1]), Some(FileKind::Bsp));
        assert_eq!(kind_of(none, b"BSP2...."), Some(FileKind::Bsp));
        assert_eq!(kind_of(none, b"2PSB...."), Some(FileKind::Bsp));
        assert_eq!(kind_of(none, b"IBSP\x26\0\0\0"), Some(FileKind::Bsp));
        assert_eq!(kind_of(none, b"PRT1\n3\n2\n"), Some(FileKind::Prt));
        assert_eq!(kind_of(none, b"PRT1-AM\n"), Some(FileKind::Prt));
        assert_eq!(
            kind_of(none, b"// Game: Quake\n\n{\n\"classname\" \"worldspawn\"\n}\n"),
            Some(FileKind::Map)
        );
        assert_eq!(kind_of(none, b"# exported\nv 0 0 0\n"), Some(FileKind::Obj));
        assert_eq!(kind_of(none, b"hello world\n"), None);
        assert_eq!(kind_of(none, b"ab"), None);
        assert_eq!(kind_of(none, b"\xff\xfe\xfd\xfc{"), None);
        // Text that is not UTF-8 (a `.map` with Quake's high-bit characters) is still looked at.
        assert_eq!(kind_of(none, b"{\n\"message\" \"\xe9\x80\"\n}\n"), Some(FileKind::Map));
    }
}
