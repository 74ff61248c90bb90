//! Quake portal files: PRT1, PRT2, PRT1-AM, q3map2's dialect of PRT1 (see
//! `../shared/reference/formats.md` and `family.md`), and the VHLT/SDHLT dialect Half-Life's
//! `hlbsp` writes (module `vhlt`).
//!
//! Convention: the plane of a portal's winding (computed as for `.map` sides, see
//! [`crate::geom`]) faces **into** `leaves[0]`.
//!
//! Layouts (whitespace, including line breaks, separates tokens; `(` and `)` may touch numbers):
//! - `PRT1 <leaves> <portals>` then `<n> <leafA> <leafB> (x y z)…` per portal.
//! - `PRT2 <leaves> <clusters> <portals>`, portal lines naming clusters, then per cluster its leaf
//!   numbers terminated by `-1`.
//! - `PRT1-AM <clusters> <portals> <leaves>`, portal lines naming clusters, then one cluster
//!   number per leaf.
//! - q3map2 (Quake 3): `PRT1 <clusters> <portals> <solid faces>`, then
//!   `<n> <clusterA> <clusterB> <flags> (x y z)…` per portal (flags: bit 0 hint, bit 1 sky), then
//!   `<n> <cluster> (x y z)…` per solid face. Portals join clusters, with the same winding
//!   orientation as PRT1 (q3map2 writes the cluster the winding faces first, and its vis builds
//!   the two one-way portals exactly as Quake 1's does), so vis reads it as PRT1 over clusters.
//!   The flags only steer q3map2's `-hint` merging and `-farplane` sky exemption, and the solid
//!   faces (cluster walls, pointing out of their cluster) only feed its `-merge`: both are checked
//!   like the rest of the file and then dropped ([`write()`] writes flags 0 and no solid face).
//!   The dialect is told from PRT1 by the token after the first portal's two clusters: a number
//!   (the flags) rather than `(`; with no portals, by a fourth header count ([`PrtFormat::of_text`]).
//! - VHLT (no header word): `<portal leaves> <portals>`, one line per portal leaf with the number
//!   of BSP vis leaves it holds, then portal lines naming portal leaves (read as clusters); or,
//!   once `hlvis` has deleted the count lines ("FixPrt"), the portal lines right after the counts.
//!
//! The reader rejects leaf/cluster numbers out of range, windings of fewer than 3 or more than
//! [`MAX_POINTS`] points, non-finite coordinates, leaves missing from (or listed twice in) the
//! PRT2 cluster lists, and trailing tokens. It never allocates from a header count before checking
//! the count against the text that remains. The writer prints floats in Rust's shortest
//! round-trip form, so `read(write(f)) == f`. Line breaks may be `\n` or `\r\n` (any whitespace
//! separates tokens), so a portal file written on Windows reads the same.
//!
//! # The portal file of a `.bsp`
//! A BSP compiler writes `NAME.prt` beside `NAME.bsp`; tools that vis a copy often name it
//! `NAME.vis.bsp` and leave the portal file as it was. [`beside_bsp`] owns the rule every reader
//! follows (vis, the runtime loader): strip `.bsp` (any case) from the file name, try `STEM.prt`,
//! then, when the stem ends in `.vis` (any case), `STEM-without-.vis.prt`. [`find_beside_bsp`]
//! returns the first of those that is a file.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use glam::DVec3;

use crate::geom::Winding;

mod vhlt;

/// Largest number of points a portal winding may have (as readers in the wild cap it).
pub const MAX_POINTS: usize = 64;

/// Largest vis-leaf count accepted for PRT1, whose leaves need not appear in the text.
pub const MAX_LEAVES: u32 = 1 << 22;

/// Which variant a portal file is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PrtFormat {
    /// One vis leaf per cluster; portal lines name leaves.
    Prt1,
    /// Quake 1 detail clusters; portal lines name clusters, then a leaf list per cluster.
    Prt2,
    /// Older clusters variant; portal lines name clusters, then one cluster number per leaf.
    Prt1Am,
    /// q3map2's PRT1: clusters, portals with flags, then solid faces (see the module docs).
    Q3map2,
    /// Half-Life's VHLT/SDHLT `hlbsp`: no header word; a leaf count per portal leaf (cluster),
    /// whose leaves are consecutive vis leaves; portal lines name portal leaves.
    Vhlt,
    /// [`PrtFormat::Vhlt`] after `hlvis`'s FixPrt deleted the count lines: which vis leaves a
    /// portal leaf holds is not in the file, so each portal leaf is read as one vis leaf.
    VhltFixed,
}

impl PrtFormat {
    /// The variant's name: the first token of a file of it (`PRT1`, also q3map2's, `PRT2`,
    /// `PRT1-AM`), or `VHLT` and `VHLT-fixed` for the dialects without a header word.
    pub fn header(self) -> &'static str {
        match self {
            Self::Prt1 | Self::Q3map2 => "PRT1",
            Self::Prt2 => "PRT2",
            Self::Prt1Am => "PRT1-AM",
            Self::Vhlt => "VHLT",
            Self::VhltFixed => "VHLT-fixed",
        }
    }

    /// The variant of `text` from its first token (leading whitespace skipped): for the VHLT
    /// dialects (a number first) from the shape of the third line; for `PRT1`, q3map2's dialect
    /// when the first portal line has a number where PRT1 has `(` (or, without portals, when a
    /// fourth header count follows). `None` when the header is none of them.
    pub fn of_text(text: &str) -> Option<Self> {
        let mut lx = Lexer::new(text);
        let head = lx.next_token()?.text;
        if head.parse::<i64>().is_ok() {
            return Some(vhlt::sniff(text));
        }
        let format = [Self::Prt1, Self::Prt2, Self::Prt1Am].into_iter().find(|f| f.header() == head)?;
        if format != Self::Prt1 {
            return Some(format);
        }
        let t: Vec<&str> = std::iter::from_fn(|| lx.next_token()).take(6).map(|t| t.text).collect();
        let q3 = match t.as_slice() {
            [_, portals, faces, ..] if *portals == "0" => faces.parse::<u32>().is_ok(),
            [_, _, _, _, _, flags] => flags.parse::<i64>().is_ok(),
            _ => false,
        };
        Some(if q3 { Self::Q3map2 } else { Self::Prt1 })
    }
}

/// The portal files that may belong to the BSP at `bsp`, in the order to try them (see the module
/// docs): `NAME.prt` for `NAME.bsp`; `NAME.vis.prt`, then `NAME.prt`, for `NAME.vis.bsp`. Empty
/// when the file name does not end in `.bsp` (any case).
pub fn beside_bsp(bsp: &Path) -> Vec<PathBuf> {
    // Path and OsStr throughout: a name that is not UTF-8 is a name like any other.
    let named = |p: &Path, ext: &str| p.extension().is_some_and(|e| e.eq_ignore_ascii_case(ext));
    let Some(stem) = bsp.file_stem().map(Path::new).filter(|_| named(bsp, "bsp")) else {
        return Vec::new();
    };
    let mut out = vec![bsp.with_extension("prt")];
    if named(stem, "vis") {
        out.push(bsp.with_file_name(stem).with_extension("prt"));
    }
    out
}

/// The first of [`beside_bsp`]'s candidates that is a file.
pub fn find_beside_bsp(bsp: &Path) -> Option<PathBuf> {
    beside_bsp(bsp).into_iter().find(|p| p.is_file())
}

/// One portal line.
#[derive(Debug, Clone, PartialEq)]
pub struct PrtPortal {
    /// The two clusters (leaves in PRT1) it joins; the winding faces into `leaves[0]`.
    pub leaves: [u32; 2],
    /// The convex winding.
    pub winding: Winding,
}

/// A whole portal file.
#[derive(Debug, Clone, PartialEq)]
pub struct PortalFile {
    /// The variant.
    pub format: PrtFormat,
    /// Number of vis leaves (real leaves, numbered from 0).
    pub num_leaves: u32,
    /// Number of clusters (equal to `num_leaves` for PRT1).
    pub num_clusters: u32,
    /// Portals between clusters.
    pub portals: Vec<PrtPortal>,
    /// Cluster of each vis leaf (`0..num_leaves`); the identity for PRT1.
    pub leaf_clusters: Vec<u32>,
}

impl PortalFile {
    /// A PRT1 file of `num_leaves` leaves, each its own cluster, with `portals` between them.
    pub fn prt1(num_leaves: u32, portals: Vec<PrtPortal>) -> Self {
        Self {
            format: PrtFormat::Prt1,
            num_leaves,
            num_clusters: num_leaves,
            portals,
            leaf_clusters: (0..num_leaves).collect(),
        }
    }
}

/// What went wrong while reading a `.prt`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PrtErrorKind {
    /// The first token is not `PRT1`, `PRT2`, `PRT1-AM` or a number (VHLT).
    #[error("unknown portal file header `{0}`, expected PRT1, PRT2, PRT1-AM or a portal leaf count (VHLT)")]
    BadHeader(String),
    /// End of text where more was needed.
    #[error("unexpected end of file, expected {0}")]
    UnexpectedEof(&'static str),
    /// A token that does not belong here.
    #[error("unexpected `{found}`, expected {expected}")]
    Stray {
        /// The token found (truncated).
        found: String,
        /// What the grammar needed.
        expected: &'static str,
    },
    /// A word that should be a number.
    #[error("expected {expected}, found `{found}`")]
    NotANumber {
        /// The token found (truncated).
        found: String,
        /// What kind of number.
        expected: &'static str,
    },
    /// A coordinate that is infinite or NaN.
    #[error("non-finite coordinate `{0}`")]
    NonFinite(String),
    /// A header count the rest of the text cannot possibly hold.
    #[error("{what} count {count} is more than the file can hold")]
    CountTooLarge {
        /// Which count.
        what: &'static str,
        /// The count read.
        count: u64,
    },
    /// A leaf or cluster number out of range.
    #[error("{what} {value} out of range (there are {limit})")]
    OutOfRange {
        /// "leaf" or "cluster".
        what: &'static str,
        /// The number read.
        value: i64,
        /// The exclusive upper bound.
        limit: u32,
    },
    /// A winding with too few or too many points.
    #[error("winding has {0} points, expected 3 to {MAX_POINTS}")]
    BadPointCount(i64),
    /// A leaf listed in two PRT2 clusters.
    #[error("leaf {0} is listed in two clusters")]
    LeafTwice(u32),
    /// A leaf listed in no PRT2 cluster.
    #[error("leaf {0} belongs to no cluster")]
    LeafMissing(u32),
    /// Tokens after the end of the data.
    #[error("trailing data `{0}` after the last record")]
    Trailing(String),
    /// A negative VHLT leaf count.
    #[error("portal leaf holds {0} leaves, expected a count >= 0")]
    BadLeafCount(i64),
}

/// A `.prt` read error with its location; displays as `file:line:col: message`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}:{line}:{col}: {kind}")]
pub struct PrtError {
    /// The file name given to [`read`].
    pub file: String,
    /// 1-based line.
    pub line: u32,
    /// 1-based column (characters).
    pub col: u32,
    /// What went wrong.
    pub kind: PrtErrorKind,
}

/// Smallest text one portal line takes: `3 0 0 (0 0 0) (0 0 0) (0 0 0)` without spaces between
/// parentheses is 3 + 3 × 7 characters.
const MIN_PORTAL_CHARS: usize = 24;

/// Read a portal file. `file` is only used in error messages.
pub fn read(text: &str, file: &str) -> Result<PortalFile, PrtError> {
    let mut r = Reader { lx: Lexer::new(text), file };
    if r.lx.clone().next_token().is_some_and(|t| t.text.parse::<i64>().is_ok()) {
        return vhlt::read(r);
    }
    let head = r.next("a header")?;
    let Some(format) = PrtFormat::of_text(text) else {
        return Err(r.at(&head, PrtErrorKind::BadHeader(shown(head.text))));
    };
    let (num_leaves, num_clusters, num_portals);
    let mut num_faces = 0;
    match format {
        PrtFormat::Prt1 | PrtFormat::Q3map2 | PrtFormat::Vhlt | PrtFormat::VhltFixed => {
            num_leaves = r.count("leaf")?;
            num_clusters = num_leaves;
            num_portals = r.count("portal")?;
            if format == PrtFormat::Q3map2 {
                num_faces = r.count("solid face")?.1;
            }
        }
        PrtFormat::Prt2 => {
            num_leaves = r.count("leaf")?;
            num_clusters = r.count("cluster")?;
            num_portals = r.count("portal")?;
        }
        PrtFormat::Prt1Am => {
            num_clusters = r.count("cluster")?;
            num_portals = r.count("portal")?;
            num_leaves = r.count("leaf")?;
        }
    }
    let remaining = r.check_portal_count(num_portals.1)?;
    if (num_faces as usize).saturating_mul(MIN_PORTAL_CHARS - 2) > remaining {
        let pos = r.lx.position();
        return Err(r.err(pos, PrtErrorKind::CountTooLarge { what: "solid face", count: num_faces.into() }));
    }
    // PRT2 and PRT1-AM list every leaf (at least two characters each); PRT1 leaves need no text.
    let leaf_limit = match format {
        PrtFormat::Prt1 | PrtFormat::Q3map2 => MAX_LEAVES as usize,
        _ => remaining / 2,
    };
    if num_leaves.1 as usize > leaf_limit {
        return Err(
            r.err(num_leaves.0, PrtErrorKind::CountTooLarge { what: "leaf", count: num_leaves.1.into() })
        );
    }
    if format == PrtFormat::Prt2 && num_clusters.1 as usize > remaining / 3 {
        return Err(r.err(
            num_clusters.0,
            PrtErrorKind::CountTooLarge { what: "cluster", count: num_clusters.1.into() },
        ));
    }
    if format == PrtFormat::Prt1Am && num_clusters.1 > num_leaves.1 {
        return Err(r.err(
            num_clusters.0,
            PrtErrorKind::CountTooLarge { what: "cluster", count: num_clusters.1.into() },
        ));
    }
    let (num_leaves, num_clusters, num_portals) = (num_leaves.1, num_clusters.1, num_portals.1);
    let what = if format == PrtFormat::Prt1 { "leaf" } else { "cluster" };
    let portals = r.portals(num_portals, num_clusters, what, format == PrtFormat::Q3map2)?;
    for _ in 0..num_faces {
        r.solid_face(num_clusters)?;
    }
    let leaf_clusters = match format {
        // The VHLT dialects never get here (they have no header word): see `vhlt::read`.
        PrtFormat::Prt1 | PrtFormat::Q3map2 | PrtFormat::Vhlt | PrtFormat::VhltFixed => {
            (0..num_leaves).collect()
        }
        PrtFormat::Prt2 => r.cluster_lists(num_leaves, num_clusters)?,
        PrtFormat::Prt1Am => {
            let mut v = Vec::with_capacity(num_leaves as usize);
            for _ in 0..num_leaves {
                v.push(r.index("cluster", num_clusters)?);
            }
            v
        }
    };
    r.end()?;
    Ok(PortalFile { format, num_leaves, num_clusters, portals, leaf_clusters })
}

/// Read the bytes of a portal file: [`read`] of the bytes taken as UTF-8, lossily. Every token of a
/// valid portal file is ASCII, so a byte that is not UTF-8 is never accepted: it shows as `U+FFFD`
/// in the error that names its line and column. `file` is only used in error messages.
pub fn read_bytes(bytes: &[u8], file: &str) -> Result<PortalFile, PrtError> {
    read(&String::from_utf8_lossy(bytes), file)
}

/// What identifies a portal file's bytes (FNV-1a 64, [`crate::hash`]): a level records the
/// fingerprint of the portal file written with it ([`crate::level::Level::portal_file`]).
pub fn fingerprint(bytes: &[u8]) -> u64 {
    crate::hash::fnv1a(bytes, crate::hash::FNV_OFFSET)
}

/// Write a portal file in its own variant; floats in shortest round-trip form.
pub fn write(prt: &PortalFile) -> String {
    let mut s = String::with_capacity(64 + prt.portals.len() * 80);
    // `write!` to a String cannot fail.
    let head = prt.format.header();
    let _ = match prt.format {
        PrtFormat::Prt1 => write!(s, "{head}\n{}\n{}\n", prt.num_leaves, prt.portals.len()),
        PrtFormat::Q3map2 => write!(s, "{head}\n{}\n{}\n0\n", prt.num_leaves, prt.portals.len()),
        PrtFormat::Prt2 => {
            write!(s, "{head}\n{}\n{}\n{}\n", prt.num_leaves, prt.num_clusters, prt.portals.len())
        }
        PrtFormat::Prt1Am => {
            write!(s, "{head}\n{}\n{}\n{}\n", prt.num_clusters, prt.portals.len(), prt.num_leaves)
        }
        PrtFormat::Vhlt | PrtFormat::VhltFixed => vhlt::write_head(prt, &mut s),
    };
    for p in &prt.portals {
        let _ = write!(s, "{} {} {}", p.winding.points.len(), p.leaves[0], p.leaves[1]);
        if prt.format == PrtFormat::Q3map2 {
            s.push_str(" 0");
        }
        for q in &p.winding.points {
            let _ = write!(s, " ({} {} {})", q.x, q.y, q.z);
        }
        s.push('\n');
    }
    match prt.format {
        PrtFormat::Prt1 | PrtFormat::Q3map2 | PrtFormat::Vhlt | PrtFormat::VhltFixed => {}
        PrtFormat::Prt2 => {
            let mut lists: Vec<Vec<u32>> = vec![Vec::new(); prt.num_clusters as usize];
            for (leaf, &c) in prt.leaf_clusters.iter().enumerate() {
                if let Some(list) = lists.get_mut(c as usize) {
                    list.push(leaf as u32);
                }
            }
            for list in lists {
                for leaf in list {
                    let _ = write!(s, "{leaf} ");
                }
                s.push_str("-1\n");
            }
        }
        PrtFormat::Prt1Am => {
            for c in &prt.leaf_clusters {
                let _ = writeln!(s, "{c}");
            }
        }
    }
    s
}

/// Truncate a token for an error message.
fn shown(text: &str) -> String {
    const MAX: usize = 40;
    match text.char_indices().nth(MAX) {
        Some((i, _)) => format!("{}…", &text[..i]),
        None => text.to_string(),
    }
}

#[derive(Debug, Clone, Copy)]
struct Token<'a> {
    text: &'a str,
    /// Byte offset of the token in the text.
    start: usize,
}

/// Splits the text at whitespace (as `char::is_whitespace`) and around `(` and `)`, byte by byte
/// over ASCII; line and column are worked out only for an error ([`Lexer::locate`]).
#[derive(Clone)]
struct Lexer<'a> {
    text: &'a str,
    pos: usize,
}

/// What a byte is to the lexer: part of a token, ASCII whitespace (as `char::is_whitespace` has
/// it: tab, line feed, vertical tab, form feed, carriage return, space), a parenthesis, or the
/// start or continuation of a character beyond ASCII (decided by decoding it).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Class {
    Solid,
    Space,
    Paren,
    Wide,
}

const CLASSES: [Class; 256] = {
    let mut t = [Class::Solid; 256];
    let mut b = 0x80;
    while b < 256 {
        t[b] = Class::Wide;
        b += 1;
    }
    t[b' ' as usize] = Class::Space;
    let mut b = b'\t';
    while b <= b'\r' {
        t[b as usize] = Class::Space;
        b += 1;
    }
    t[b'(' as usize] = Class::Paren;
    t[b')' as usize] = Class::Paren;
    t
};

impl<'a> Lexer<'a> {
    fn new(text: &'a str) -> Self {
        Self { text, pos: 0 }
    }

    /// Line and column (both from 1, the column in characters) of the next character.
    fn position(&self) -> (u32, u32) {
        self.locate(self.pos)
    }

    /// Line and column (both from 1, the column in characters) of byte offset `pos`.
    fn locate(&self, pos: usize) -> (u32, u32) {
        let before = &self.text[..pos];
        let line_start = before.rfind('\n').map_or(0, |i| i + 1);
        let line = before.bytes().filter(|&b| b == b'\n').count() + 1;
        let col = before[line_start..].chars().count() + 1;
        (u32::try_from(line).unwrap_or(u32::MAX), u32::try_from(col).unwrap_or(u32::MAX))
    }

    /// Next token: `(`, `)`, or a run of other non-whitespace characters.
    fn next_token(&mut self) -> Option<Token<'a>> {
        let (text, bytes) = (self.text, self.text.as_bytes());
        // The length of the character beyond ASCII at `i`, and whether it is whitespace.
        let wide =
            |i: usize| text[i..].chars().next().map_or((1, false), |c| (c.len_utf8(), c.is_whitespace()));
        let mut i = self.pos;
        let start = loop {
            let Some(&b) = bytes.get(i) else {
                // At the end: positions of an error name the end of the text.
                self.pos = i;
                return None;
            };
            match CLASSES[b as usize] {
                Class::Space => i += 1,
                Class::Wide => match wide(i) {
                    (len, true) => i += len,
                    _ => break i,
                },
                _ => break i,
            }
        };
        if CLASSES[bytes[start] as usize] == Class::Paren {
            i += 1;
        } else {
            while let Some(&b) = bytes.get(i) {
                match CLASSES[b as usize] {
                    Class::Solid => i += 1,
                    Class::Wide => match wide(i) {
                        (len, false) => i += len,
                        _ => break,
                    },
                    _ => break,
                }
            }
        }
        self.pos = i;
        Some(Token { text: &text[start..i], start })
    }
}

struct Reader<'a, 'f> {
    lx: Lexer<'a>,
    file: &'f str,
}

impl<'a> Reader<'a, '_> {
    fn err(&self, (line, col): (u32, u32), kind: PrtErrorKind) -> PrtError {
        PrtError { file: self.file.to_string(), line, col, kind }
    }

    fn at(&self, tok: &Token<'_>, kind: PrtErrorKind) -> PrtError {
        self.err(self.lx.locate(tok.start), kind)
    }

    fn next(&mut self, expected: &'static str) -> Result<Token<'a>, PrtError> {
        match self.lx.next_token() {
            Some(t) => Ok(t),
            None => Err(self.err(self.lx.position(), PrtErrorKind::UnexpectedEof(expected))),
        }
    }

    fn integer(&mut self, expected: &'static str) -> Result<(Token<'a>, i64), PrtError> {
        let tok = self.next(expected)?;
        match tok.text.parse::<i64>() {
            Ok(v) => Ok((tok, v)),
            Err(_) => Err(self.at(&tok, PrtErrorKind::NotANumber { found: shown(tok.text), expected })),
        }
    }

    /// A header count, with its position.
    fn count(&mut self, what: &'static str) -> Result<((u32, u32), u32), PrtError> {
        let (tok, v) = self.integer("a count")?;
        let Ok(v) = u32::try_from(v) else {
            return Err(self.at(&tok, PrtErrorKind::CountTooLarge { what, count: v.max(0) as u64 }));
        };
        Ok((self.lx.locate(tok.start), v))
    }

    /// A leaf or cluster number below `limit`.
    fn index(&mut self, what: &'static str, limit: u32) -> Result<u32, PrtError> {
        let (tok, v) = self.integer(if what == "leaf" { "a leaf number" } else { "a cluster number" })?;
        match u32::try_from(v) {
            Ok(u) if u < limit => Ok(u),
            _ => Err(self.at(&tok, PrtErrorKind::OutOfRange { what, value: v, limit })),
        }
    }

    fn punct(&mut self, p: &'static str, expected: &'static str) -> Result<(), PrtError> {
        let tok = self.next(expected)?;
        if tok.text != p {
            return Err(self.at(&tok, PrtErrorKind::Stray { found: shown(tok.text), expected }));
        }
        Ok(())
    }

    fn coord(&mut self) -> Result<f64, PrtError> {
        let tok = self.next("a coordinate")?;
        let Some(v) = crate::decimal::parse_f64(tok.text) else {
            return Err(
                self.at(&tok, PrtErrorKind::NotANumber { found: shown(tok.text), expected: "a coordinate" })
            );
        };
        if !v.is_finite() {
            return Err(self.at(&tok, PrtErrorKind::NonFinite(shown(tok.text))));
        }
        Ok(v)
    }

    /// Checks that `num_portals` portal lines can fit the text that remains; returns its length.
    fn check_portal_count(&self, num_portals: u32) -> Result<usize, PrtError> {
        let remaining = self.lx.text.len().saturating_sub(self.lx.pos);
        if (num_portals as usize).saturating_mul(MIN_PORTAL_CHARS) > remaining {
            let kind = PrtErrorKind::CountTooLarge { what: "portal", count: num_portals.into() };
            return Err(self.err(self.lx.position(), kind));
        }
        Ok(remaining)
    }

    /// `num_portals` portal lines (already checked by [`Reader::check_portal_count`]) naming
    /// `what`s below `limit`; `flags`: q3map2's flags field follows the two leaves.
    fn portals(
        &mut self,
        num_portals: u32,
        limit: u32,
        what: &'static str,
        flags: bool,
    ) -> Result<Vec<PrtPortal>, PrtError> {
        let mut portals = Vec::with_capacity(num_portals as usize);
        for _ in 0..num_portals {
            portals.push(self.portal(limit, what, flags)?);
        }
        Ok(portals)
    }

    /// No token may follow the last record.
    fn end(&mut self) -> Result<(), PrtError> {
        match self.lx.next_token() {
            Some(tok) => Err(self.at(&tok, PrtErrorKind::Trailing(shown(tok.text)))),
            None => Ok(()),
        }
    }

    /// A point count: 3 to [`MAX_POINTS`].
    fn point_count(&mut self) -> Result<usize, PrtError> {
        let (tok, n) = self.integer("a point count")?;
        if !(3..=MAX_POINTS as i64).contains(&n) {
            return Err(self.at(&tok, PrtErrorKind::BadPointCount(n)));
        }
        Ok(n as usize)
    }

    /// A portal line; `flags`: q3map2's flags field follows the two leaves (read and dropped).
    fn portal(&mut self, limit: u32, what: &'static str, flags: bool) -> Result<PrtPortal, PrtError> {
        let n = self.point_count()?;
        let a = self.index(what, limit)?;
        let b = self.index(what, limit)?;
        if flags {
            self.integer("portal flags")?;
        }
        Ok(PrtPortal { leaves: [a, b], winding: self.winding(n)? })
    }

    /// A q3map2 solid face, `<n> <cluster> (x y z)…`: checked, then dropped.
    fn solid_face(&mut self, limit: u32) -> Result<(), PrtError> {
        let n = self.point_count()?;
        self.index("cluster", limit)?;
        self.winding(n).map(drop)
    }

    /// `n` points `(x y z)`.
    fn winding(&mut self, n: usize) -> Result<Winding, PrtError> {
        let mut points = Vec::with_capacity(n);
        for _ in 0..n {
            self.punct("(", "`(` opening a point")?;
            let x = self.coord()?;
            let y = self.coord()?;
            let z = self.coord()?;
            self.punct(")", "`)` closing a point")?;
            points.push(DVec3::new(x, y, z));
        }
        Ok(Winding::new(points))
    }

    /// PRT2: per cluster, its leaves terminated by `-1`; every leaf exactly once.
    fn cluster_lists(&mut self, num_leaves: u32, num_clusters: u32) -> Result<Vec<u32>, PrtError> {
        const NONE: u32 = u32::MAX;
        let mut of = vec![NONE; num_leaves as usize];
        for cluster in 0..num_clusters {
            loop {
                let (tok, v) = self.integer("a leaf number or -1")?;
                if v == -1 {
                    break;
                }
                let leaf = match u32::try_from(v) {
                    Ok(u) if u < num_leaves => u,
                    _ => {
                        return Err(self.at(
                            &tok,
                            PrtErrorKind::OutOfRange { what: "leaf", value: v, limit: num_leaves },
                        ));
                    }
                };
                let slot = &mut of[leaf as usize];
                if *slot != NONE {
                    return Err(self.at(&tok, PrtErrorKind::LeafTwice(leaf)));
                }
                *slot = cluster;
            }
        }
        if let Some(leaf) = of.iter().position(|&c| c == NONE) {
            return Err(self.err(self.lx.position(), PrtErrorKind::LeafMissing(leaf as u32)));
        }
        Ok(of)
    }
}

#[cfg(test)]
mod tests;
