//! `.slvl`, Sightline's level file: a little-endian header, a lump directory and one lump of
//! fixed-layout records per field of [`Level`]. The byte layout is documented in `docs/slvl.md`.
//!
//! Reading never trusts the file: the directory is checked against the file size, every length is
//! checked before anything is allocated (a compressed lump may claim at most
//! `min(MAX_LUMP, 255 * compressed + 16)` bytes, lz4's largest possible expansion, and all lumps
//! together at most [`MAX_TOTAL_EXPANSION`] times the file size plus 16 MiB), checksums are
//! verified, lumps of unknown kinds are skipped, and [`validate`] checks every index before the
//! level is returned, so code holding a level from [`read`] may index without checks.

mod checksum;
mod decode;
mod encode;
mod validate;

pub use checksum::crc32;
pub use validate::validate;

use crate::le::Rec;
use crate::level::Level;
use std::borrow::Cow;
use thiserror::Error;

/// First four bytes of every `.slvl` file.
pub const MAGIC: [u8; 4] = *b"SLVL";
/// Format version written by [`write()`]; [`read`] accepts exactly this version.
pub const VERSION: u32 = 1;
/// Bytes of the file header: magic, version, lump count, reserved.
pub const HEADER_BYTES: usize = 16;
/// Bytes of one directory entry.
pub const DIR_ENTRY_BYTES: usize = 40;
/// Lump data starts are aligned to this many bytes.
pub const LUMP_ALIGN: usize = 8;
/// Largest uncompressed lump a reader accepts.
pub const MAX_LUMP: u64 = 1 << 30;
/// All lumps of a file together may expand to at most this many times the file size (plus
/// 16 MiB); bounds the memory a small hostile file can make the reader take.
pub const MAX_TOTAL_EXPANSION: u64 = 64;

/// The lump kinds this version knows. Codes are stable; readers skip codes they do not know.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(u32)]
pub enum LumpKind {
    /// [`Level::entities`]: UTF-8 text.
    Entities = 1,
    /// [`Level::textures`]: `u32` byte length then UTF-8 bytes, per name.
    Textures = 2,
    /// [`Level::planes`]: 16-byte records.
    Planes = 3,
    /// [`Level::nodes`]: 36-byte records.
    Nodes = 4,
    /// [`Level::leaves`]: 40-byte records.
    Leaves = 5,
    /// [`Level::leaf_faces`]: `u32` each.
    LeafFaces = 6,
    /// [`Level::faces`]: 16-byte records.
    Faces = 7,
    /// [`Level::vertices`]: 12-byte records.
    Vertices = 8,
    /// [`Level::portals`]: 20-byte records.
    Portals = 9,
    /// [`Level::models`]: 36-byte records.
    Models = 10,
    /// [`Level::num_clusters`]: one `u32`.
    Clusters = 11,
    /// [`Level::pvs_offsets`]: `u32` each.
    PvsOffsets = 12,
    /// [`Level::pvs_data`]: bytes.
    PvsData = 13,
    /// [`Level::gvs_cells`]: 32-byte records.
    GvsCells = 14,
    /// [`Level::gvs_faces`]: `u32` each.
    GvsFaces = 15,
    /// [`Level::face_draw`]: 44-byte records (optional: absent in older files).
    FaceDraw = 16,
    /// [`Level::texture_sizes`]: 8-byte records (optional: absent in older files).
    TextureSizes = 17,
    /// [`Level::portal_file`]: one `u64`, or empty for `None` (optional: absent in older files).
    PortalFile = 18,
}

impl LumpKind {
    /// Every kind, in the order [`write()`] stores them.
    pub const ALL: [LumpKind; 18] = [
        Self::Entities,
        Self::Textures,
        Self::Planes,
        Self::Nodes,
        Self::Leaves,
        Self::LeafFaces,
        Self::Faces,
        Self::Vertices,
        Self::Portals,
        Self::Models,
        Self::Clusters,
        Self::PvsOffsets,
        Self::PvsData,
        Self::GvsCells,
        Self::GvsFaces,
        Self::FaceDraw,
        Self::TextureSizes,
        Self::PortalFile,
    ];

    /// The kind with this code, if this version knows it.
    pub fn from_code(code: u32) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.code() == code)
    }

    /// Stored code.
    pub fn code(self) -> u32 {
        self as u32
    }

    /// Name for messages.
    pub fn name(self) -> &'static str {
        match self {
            Self::Entities => "entities",
            Self::Textures => "textures",
            Self::Planes => "planes",
            Self::Nodes => "nodes",
            Self::Leaves => "leaves",
            Self::LeafFaces => "leaf_faces",
            Self::Faces => "faces",
            Self::Vertices => "vertices",
            Self::Portals => "portals",
            Self::Models => "models",
            Self::Clusters => "clusters",
            Self::PvsOffsets => "pvs_offsets",
            Self::PvsData => "pvs_data",
            Self::GvsCells => "gvs_cells",
            Self::GvsFaces => "gvs_faces",
            Self::FaceDraw => "face_draw",
            Self::TextureSizes => "texture_sizes",
            Self::PortalFile => "portal_file",
        }
    }

    /// Size of one fixed record; 1 for byte lumps and 0 for the variable-length texture names.
    pub fn record_bytes(self) -> usize {
        match self {
            Self::Entities | Self::PvsData => 1,
            Self::Textures => 0,
            Self::Planes | Self::Faces => 16,
            Self::Nodes | Self::Models => 36,
            Self::Leaves => 40,
            Self::LeafFaces | Self::PvsOffsets | Self::GvsFaces | Self::Clusters => 4,
            Self::Vertices => 12,
            Self::Portals => 20,
            Self::GvsCells => 32,
            Self::FaceDraw => 44,
            Self::TextureSizes | Self::PortalFile => 8,
        }
    }
}

/// How a lump's bytes are stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum Codec {
    /// As they are.
    Raw = 0,
    /// One `lz4_flex` block (no size prefix; the size is the directory's uncompressed length).
    Lz4 = 1,
}

/// One directory entry as stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct DirEntry {
    /// Lump kind code (see [`LumpKind`]; unknown codes are allowed and skipped).
    pub kind: u32,
    /// Byte offset of the stored bytes in the file.
    pub offset: u64,
    /// Stored length.
    pub length: u64,
    /// Length after decompression.
    pub uncompressed_length: u64,
    /// Codec code (see [`Codec`]).
    pub codec: u32,
    /// [`crc32`] of the uncompressed bytes.
    pub checksum: u32,
}

/// Options for [`write()`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct WriteOptions {
    /// Store each lump lz4-compressed when that makes it smaller.
    pub compress: bool,
}

/// Everything that can be wrong with a `.slvl` file or a level.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[non_exhaustive]
pub enum SlvlError {
    /// The file cannot hold the header.
    #[error("file is {len} bytes, shorter than the {HEADER_BYTES}-byte .slvl header")]
    TooShort {
        /// File length.
        len: usize,
    },
    /// Wrong magic.
    #[error("byte 0: not a .slvl file (starts with {magic:02x?})")]
    Magic {
        /// The first four bytes.
        magic: [u8; 4],
    },
    /// Unsupported format version.
    #[error("byte 4: .slvl format version {version} is not supported (this reader reads {VERSION})")]
    Version {
        /// Stored version.
        version: u32,
    },
    /// The directory is inconsistent with the file.
    #[error("byte {offset}: {detail}")]
    Directory {
        /// Byte offset of the offending field or entry.
        offset: u64,
        /// What is wrong.
        detail: String,
    },
    /// A lump's stored bytes are unusable (size, codec, checksum, decompression).
    #[error("byte {offset}: lump {lump}: {detail}")]
    Lump {
        /// Byte offset of the lump in the file.
        offset: u64,
        /// Lump name.
        lump: &'static str,
        /// What is wrong.
        detail: String,
    },
    /// A record holds a bad value or an index out of range.
    #[error("lump {lump}, record {index} (byte {offset} of the uncompressed lump): {detail}")]
    Invalid {
        /// Lump name.
        lump: &'static str,
        /// Record index.
        index: usize,
        /// Byte offset of the record inside the uncompressed lump.
        offset: u64,
        /// What is wrong.
        detail: String,
    },
}

/// Serializes a level. Does not validate it: call [`validate`] first when the level was built by
/// code that might be wrong, since [`read`] rejects what [`validate`] rejects.
pub fn write(level: &Level, opts: &WriteOptions) -> Vec<u8> {
    let lumps: Vec<(LumpKind, Vec<u8>)> =
        LumpKind::ALL.into_iter().map(|kind| (kind, encode::lump_bytes(level, kind))).collect();
    let mut out = Vec::new();
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&(lumps.len() as u32).to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    let dir_at = out.len();
    out.resize(dir_at + lumps.len() * DIR_ENTRY_BYTES, 0);
    for (i, (kind, raw)) in lumps.iter().enumerate() {
        let compressed = if opts.compress && !raw.is_empty() {
            Some(lz4_flex::block::compress(raw)).filter(|c| c.len() < raw.len())
        } else {
            None
        };
        let (codec, stored) = match &compressed {
            Some(c) => (Codec::Lz4, c.as_slice()),
            None => (Codec::Raw, raw.as_slice()),
        };
        out.resize(out.len().next_multiple_of(LUMP_ALIGN), 0);
        let entry = DirEntry {
            kind: kind.code(),
            offset: out.len() as u64,
            length: stored.len() as u64,
            uncompressed_length: raw.len() as u64,
            codec: codec as u32,
            checksum: crc32(raw),
        };
        out.extend_from_slice(stored);
        let at = dir_at + i * DIR_ENTRY_BYTES;
        out[at..at + DIR_ENTRY_BYTES].copy_from_slice(&encode::dir_entry(&entry));
    }
    out
}

/// Reads the header and directory, checking every entry against the file.
pub fn directory(bytes: &[u8]) -> Result<Vec<DirEntry>, SlvlError> {
    if bytes.len() < HEADER_BYTES {
        return Err(SlvlError::TooShort { len: bytes.len() });
    }
    let mut head = Rec::new(bytes);
    let magic: [u8; 4] = head.take();
    if magic != MAGIC {
        return Err(SlvlError::Magic { magic });
    }
    let version = head.u32();
    if version != VERSION {
        return Err(SlvlError::Version { version });
    }
    let count = head.u32() as usize;
    let room = (bytes.len() - HEADER_BYTES) / DIR_ENTRY_BYTES;
    if count > room {
        return Err(SlvlError::Directory {
            offset: 8,
            detail: format!("{count} directory entries do not fit the {}-byte file", bytes.len()),
        });
    }
    let mut entries = Vec::with_capacity(count);
    for i in 0..count {
        let at = HEADER_BYTES + i * DIR_ENTRY_BYTES;
        let mut r = Rec::new(&bytes[at..at + DIR_ENTRY_BYTES]);
        let entry = DirEntry {
            kind: r.u32(),
            codec: r.u32(),
            offset: r.u64(),
            length: r.u64(),
            uncompressed_length: r.u64(),
            checksum: r.u32(),
        };
        if entry.offset.checked_add(entry.length).is_none_or(|end| end > bytes.len() as u64) {
            return Err(SlvlError::Directory {
                offset: at as u64,
                detail: format!(
                    "lump kind {} at {} with {} bytes lies outside the {}-byte file",
                    entry.kind,
                    entry.offset,
                    entry.length,
                    bytes.len()
                ),
            });
        }
        entries.push(entry);
    }
    Ok(entries)
}

/// Parses and validates a `.slvl` file.
pub fn read(bytes: &[u8]) -> Result<Level, SlvlError> {
    let entries = directory(bytes)?;
    let mut known: Vec<(LumpKind, &DirEntry)> = Vec::new();
    for (i, entry) in entries.iter().enumerate() {
        let Some(kind) = LumpKind::from_code(entry.kind) else { continue };
        if known.iter().any(|&(k, _)| k == kind) {
            return Err(SlvlError::Directory {
                offset: (HEADER_BYTES + i * DIR_ENTRY_BYTES) as u64,
                detail: format!("second {} lump", kind.name()),
            });
        }
        known.push((kind, entry));
    }
    let mut budget = (bytes.len() as u64).saturating_mul(MAX_TOTAL_EXPANSION).saturating_add(16 << 20);
    let mut level = Level::default();
    for (kind, entry) in known {
        if entry.uncompressed_length > budget {
            return Err(lump_err(
                entry,
                kind,
                "the lumps expand beyond the reader's limit for a file this size",
            ));
        }
        budget -= entry.uncompressed_length;
        let data = lump_data(bytes, entry, kind)?;
        decode::lump_into(&mut level, kind, &data)?;
    }
    validate(&level)?;
    Ok(level)
}

fn lump_err(entry: &DirEntry, kind: LumpKind, detail: impl Into<String>) -> SlvlError {
    SlvlError::Lump { offset: entry.offset, lump: kind.name(), detail: detail.into() }
}

/// The uncompressed bytes of one lump, checksum verified.
fn lump_data<'a>(bytes: &'a [u8], entry: &DirEntry, kind: LumpKind) -> Result<Cow<'a, [u8]>, SlvlError> {
    // `directory` checked offset + length against the file.
    let stored = &bytes[entry.offset as usize..(entry.offset + entry.length) as usize];
    let data = match entry.codec {
        c if c == Codec::Raw as u32 => {
            if entry.uncompressed_length != entry.length {
                return Err(lump_err(
                    entry,
                    kind,
                    "raw lump whose uncompressed length differs from its length",
                ));
            }
            Cow::Borrowed(stored)
        }
        c if c == Codec::Lz4 as u32 => {
            let cap = MAX_LUMP.min(entry.length.saturating_mul(255).saturating_add(16));
            if entry.uncompressed_length > cap {
                return Err(lump_err(
                    entry,
                    kind,
                    format!(
                        "claims {} bytes, more than {cap} bytes can expand to",
                        entry.uncompressed_length
                    ),
                ));
            }
            let mut out = vec![0; entry.uncompressed_length as usize];
            let n = lz4_flex::block::decompress_into(stored, &mut out)
                .map_err(|e| lump_err(entry, kind, format!("lz4: {e}")))?;
            if n != out.len() {
                return Err(lump_err(entry, kind, format!("decompresses to {n} bytes, not {}", out.len())));
            }
            Cow::Owned(out)
        }
        other => return Err(lump_err(entry, kind, format!("unknown codec {other}"))),
    };
    let sum = crc32(&data);
    if sum != entry.checksum {
        return Err(lump_err(
            entry,
            kind,
            format!("checksum {sum:08x} does not match {:08x}", entry.checksum),
        ));
    }
    Ok(data)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::level::{Contents, Face, FaceDraw, GvsCell, Leaf, LevelPlane, Model, Node, Portal};
    use proptest::prelude::*;

    /// Random fields on the project's generator.
    struct Rng(sightline_job::rng::SplitMix64);

    impl Rng {
        fn next(&mut self) -> u64 {
            self.0.next_u64()
        }

        fn below(&mut self, n: usize) -> usize {
            self.0.below(n.max(1))
        }

        fn f(&mut self) -> f32 {
            (self.next() % 20001) as f32 / 10.0 - 1000.0
        }

        fn v3(&mut self) -> [f32; 3] {
            [self.f(), self.f(), self.f()]
        }
    }

    /// A random level that satisfies every invariant [`validate`] checks.
    pub(crate) fn random_level(seed: u64) -> Level {
        let mut r = Rng(sightline_job::rng::SplitMix64::new(seed));
        let mut level = Level {
            entities: format!("{{\n\"classname\" \"worldspawn\"\n\"message\" \"é {seed}\"\n}}\n"),
            ..Level::default()
        };
        level.textures = (0..1 + r.below(4)).map(|i| format!("tex{i}_{}", r.below(100))).collect();
        level.planes =
            (0..1 + r.below(8)).map(|_| LevelPlane { normal: [0.0, 0.0, 1.0], dist: r.f() }).collect();
        level.vertices = (0..3 + r.below(40)).map(|_| r.v3()).collect();
        let (np, nv) = (level.planes.len(), level.vertices.len());
        let span = |r: &mut Rng| {
            let n = 3 + r.below(nv - 2);
            let first = r.below(nv - n + 1);
            (first as u32, n as u32)
        };
        for _ in 0..1 + r.below(12) {
            let (first_vertex, num_vertices) = span(&mut r);
            let texture = r.below(level.textures.len()) as u32;
            level.faces.push(Face { plane: r.below(np) as u32, first_vertex, num_vertices, texture });
        }
        let nf = level.faces.len();
        if r.below(2) == 0 {
            level.face_draw = (0..nf)
                .map(|_| FaceDraw {
                    s: [r.f(), r.f(), r.f(), r.f()],
                    t: [r.f(), r.f(), r.f(), r.f()],
                    flags: r.below(3) as u32,
                    styles: [r.below(256) as u8, 255, 255, 255],
                    light_offset: r.below(1000) as i32 - 1,
                })
                .collect();
            level.texture_sizes = (0..level.textures.len()).map(|_| [r.below(512) as u32, 64]).collect();
            level.portal_file = Some(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15));
        }
        level.leaf_faces = (0..r.below(30)).map(|_| r.below(nf) as u32).collect();
        let num_leaves = 2 + r.below(10);
        level.num_clusters = r.below(num_leaves) as u32;
        for i in 0..num_leaves {
            let solid = i == 0 || r.below(4) == 0;
            let contents = if solid {
                Contents::Solid
            } else {
                [Contents::Empty, Contents::Water, Contents::Sky][r.below(3)]
            };
            let cluster = if solid || level.num_clusters == 0 {
                -1
            } else {
                r.below(level.num_clusters as usize) as i32
            };
            let first = r.below(level.leaf_faces.len() + 1);
            let count = r.below(level.leaf_faces.len() - first + 1);
            level.leaves.push(Leaf {
                contents,
                cluster,
                mins: r.v3(),
                maxs: r.v3(),
                first_face: first as u32,
                num_faces: count as u32,
            });
        }
        // A tree whose children only point forward, so it has no cycle.
        let num_nodes = r.below(8);
        for i in 0..num_nodes {
            let child = |r: &mut Rng| {
                if i + 1 < num_nodes && r.below(2) == 0 {
                    (i + 1 + r.below(num_nodes - i - 1)) as i32
                } else {
                    -(r.below(num_leaves) as i32) - 1
                }
            };
            let children = [child(&mut r), child(&mut r)];
            level.nodes.push(Node { plane: r.below(np) as u32, children, mins: r.v3(), maxs: r.v3() });
        }
        for _ in 0..r.below(6) {
            let (first_vertex, num_vertices) = span(&mut r);
            let leaves = [r.below(num_leaves) as u32, r.below(num_leaves) as u32];
            level.portals.push(Portal { leaves, plane: r.below(np) as u32, first_vertex, num_vertices });
        }
        for _ in 0..1 + r.below(3) {
            let head_node = if num_nodes > 0 { r.below(num_nodes) as i32 } else { -1 };
            let first = r.below(nf + 1);
            let count = r.below(nf - first + 1);
            level.models.push(Model {
                head_node,
                mins: r.v3(),
                maxs: r.v3(),
                first_face: first as u32,
                num_faces: count as u32,
            });
        }
        if level.num_clusters > 0 && r.below(4) != 0 {
            let row_bytes = level.row_bytes();
            for _ in 0..level.num_clusters {
                level.pvs_offsets.push(level.pvs_data.len() as u32);
                let row: Vec<u8> =
                    (0..row_bytes).map(|_| if r.below(3) == 0 { r.next() as u8 } else { 0 }).collect();
                crate::rle::encode_row(&row, &mut level.pvs_data);
            }
        }
        for _ in 0..r.below(4) {
            level.gvs_faces.extend((0..r.below(5)).map(|_| r.below(nf) as u32));
        }
        for _ in 0..r.below(4) {
            let first = r.below(level.gvs_faces.len() + 1);
            let count = r.below(level.gvs_faces.len() - first + 1);
            level.gvs_cells.push(GvsCell {
                mins: r.v3(),
                maxs: r.v3(),
                first_face: first as u32,
                num_faces: count as u32,
            });
        }
        level
    }

    fn rewrite_directory(bytes: &[u8], edit: impl FnOnce(&mut Vec<DirEntry>)) -> Vec<u8> {
        let mut entries = directory(bytes).unwrap();
        edit(&mut entries);
        let mut out = bytes.to_vec();
        out[8..12].copy_from_slice(&(entries.len() as u32).to_le_bytes());
        // Room for the directory: lumps keep their absolute offsets, so append entries only if
        // the file has space; tests below only replace or append within the old directory size.
        for (i, e) in entries.iter().enumerate() {
            let at = HEADER_BYTES + i * DIR_ENTRY_BYTES;
            out[at..at + DIR_ENTRY_BYTES].copy_from_slice(&encode::dir_entry(e));
        }
        out
    }

    #[test]
    fn empty_level_round_trips() {
        let bytes = write(&Level::default(), &WriteOptions::default());
        assert_eq!(&bytes[..4], b"SLVL");
        assert_eq!(read(&bytes), Ok(Level::default()));
    }

    /// A tree needs a world model to root it; faces alone (GVS results for a mesh) do not.
    #[test]
    fn a_tree_without_a_world_model_is_refused() {
        let leaf = Leaf {
            contents: Contents::Empty,
            cluster: -1,
            mins: [0.0; 3],
            maxs: [0.0; 3],
            first_face: 0,
            num_faces: 0,
        };
        let world = Model { head_node: -1, mins: [0.0; 3], maxs: [0.0; 3], first_face: 0, num_faces: 0 };
        let level = Level { leaves: vec![leaf], models: vec![world], ..Level::default() };
        assert_eq!(read(&write(&level, &WriteOptions::default())), Ok(level.clone()));
        let rootless = Level { models: Vec::new(), ..level };
        let e = read(&write(&rootless, &WriteOptions::default())).unwrap_err();
        assert!(matches!(e, SlvlError::Invalid { lump: "models", index: 0, .. }), "{e:?}");
        assert!(
            e.to_string().contains("no world model (model 0) to root the tree of 0 nodes and 1 leaves"),
            "{e}"
        );
        let mut faces = random_level(5);
        (faces.nodes, faces.leaves, faces.models, faces.portals) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        (faces.num_clusters, faces.pvs_offsets, faces.pvs_data) = (0, Vec::new(), Vec::new());
        assert_eq!(validate(&faces), Ok(()), "faces alone");
    }

    #[test]
    fn unknown_kinds_are_skipped_and_duplicates_rejected() {
        let level = random_level(7);
        let bytes = write(&level, &WriteOptions::default());
        // Turn the GVS faces entry into an unknown kind: the level reads without GVS faces...
        let unknown = rewrite_directory(&bytes, |e| {
            e.iter_mut().for_each(|e| {
                if e.kind == LumpKind::GvsFaces.code() {
                    e.kind = 999;
                }
            })
        });
        let mut expected = level.clone();
        expected.gvs_faces.clear();
        expected.gvs_cells.iter_mut().for_each(|c| c.num_faces = 0);
        let read_back = read(&unknown);
        if level.gvs_cells.iter().all(|c| c.num_faces == 0) {
            expected.gvs_cells = level.gvs_cells.clone();
            assert_eq!(read_back, Ok(expected));
        } else {
            assert!(matches!(read_back, Err(SlvlError::Invalid { lump: "gvs_cells", .. })));
        }
        // ...and a second planes lump is an error.
        let dup = rewrite_directory(&bytes, |e| e[0].kind = LumpKind::Planes.code());
        assert!(matches!(read(&dup), Err(SlvlError::Directory { .. })));
    }

    #[test]
    fn files_without_draw_lumps_read_without_draw_data() {
        let level = (0..).map(random_level).find(|l| !l.face_draw.is_empty()).unwrap();
        let bytes = write(&level, &WriteOptions::default());
        let old = rewrite_directory(&bytes, |e| {
            e.retain(|e| ![LumpKind::FaceDraw.code(), LumpKind::TextureSizes.code()].contains(&e.kind))
        });
        let mut expected = level.clone();
        expected.face_draw.clear();
        expected.texture_sizes.clear();
        assert_eq!(read(&old), Ok(expected));
        let mut short = level.clone();
        short.face_draw.pop();
        assert!(matches!(validate(&short), Err(SlvlError::Invalid { lump: "face_draw", .. })));
        let mut sizes = level.clone();
        sizes.texture_sizes.push([1, 1]);
        assert!(matches!(validate(&sizes), Err(SlvlError::Invalid { lump: "texture_sizes", .. })));
        let mut nan = level;
        nan.face_draw[0].t[3] = f32::NAN;
        assert!(matches!(validate(&nan), Err(SlvlError::Invalid { lump: "face_draw", index: 0, .. })));
    }

    #[test]
    fn rejects_bad_checksum_codec_and_claimed_sizes() {
        let level = random_level(11);
        let bytes = write(&level, &WriteOptions { compress: true });
        let sum = rewrite_directory(&bytes, |e| e[2].checksum ^= 1);
        assert!(matches!(read(&sum), Err(SlvlError::Lump { lump: "planes", .. })));
        let codec = rewrite_directory(&bytes, |e| e[2].codec = 7);
        assert!(matches!(read(&codec), Err(SlvlError::Lump { .. })));
        let huge = rewrite_directory(&bytes, |e| e[2].uncompressed_length = u64::MAX);
        assert!(matches!(read(&huge), Err(SlvlError::Lump { .. })));
        let outside = rewrite_directory(&bytes, |e| e[3].offset = u64::MAX - 2);
        assert!(matches!(read(&outside), Err(SlvlError::Directory { .. })));
        let mut count = bytes.clone();
        count[8..12].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(matches!(read(&count), Err(SlvlError::Directory { offset: 8, .. })));
        assert!(matches!(read(&bytes[..10]), Err(SlvlError::TooShort { .. })));
        let mut version = bytes.clone();
        version[4] = 2;
        assert_eq!(read(&version), Err(SlvlError::Version { version: 2 }));
    }

    #[test]
    fn validation_catches_bad_indices() {
        let mut level = random_level(3);
        level.nodes = vec![Node { plane: 0, children: [0, -1], mins: [0.0; 3], maxs: [0.0; 3] }];
        assert!(matches!(validate(&level), Err(SlvlError::Invalid { lump: "nodes", .. })));
        level.nodes[0].children[0] = -1 - level.leaves.len() as i32;
        assert!(matches!(validate(&level), Err(SlvlError::Invalid { lump: "nodes", .. })));
        level.nodes.clear();
        level.models.iter_mut().for_each(|m| m.head_node = -1);
        assert_eq!(validate(&level), Ok(()));
        level.faces[0].num_vertices = level.vertices.len() as u32 + 1;
        assert!(matches!(validate(&level), Err(SlvlError::Invalid { lump: "faces", index: 0, .. })));
        let mut level = random_level(3);
        level.num_clusters = 1;
        level.leaves.iter_mut().for_each(|l| l.cluster = if l.contents == Contents::Solid { -1 } else { 0 });
        level.pvs_offsets = vec![0];
        level.pvs_data = vec![0, 2];
        assert!(matches!(validate(&level), Err(SlvlError::Invalid { lump: "pvs_offsets", .. })));
        level.pvs_data = vec![1];
        assert_eq!(validate(&level), Ok(()));
        level.leaves[0].cluster = 0;
        assert!(matches!(validate(&level), Err(SlvlError::Invalid { lump: "leaves", index: 0, .. })));
    }

    proptest! {
        #[test]
        fn write_then_read_is_identity(seed in any::<u64>(), compress in any::<bool>()) {
            let level = random_level(seed);
            prop_assert_eq!(validate(&level), Ok(()));
            let bytes = write(&level, &WriteOptions { compress });
            prop_assert_eq!(read(&bytes), Ok(level));
        }

        #[test]
        fn mutated_files_never_panic(seed in any::<u64>(), flips in prop::collection::vec((any::<usize>(), any::<u8>()), 1..4)) {
            let mut bytes = write(&random_level(seed), &WriteOptions { compress: seed % 2 == 0 });
            for (at, x) in flips {
                let n = bytes.len();
                bytes[at % n] ^= x.max(1);
            }
            let _ = read(&bytes);
        }
    }
}
