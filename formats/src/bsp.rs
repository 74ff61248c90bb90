//! Quake BSP files: BSP29, BSP2 and BSP2-RMQ (`2PSB`), and Half-Life's BSP30.
//!
//! BSP30 keeps BSP29's lumps and records; it differs only outside what is decoded here (RGB
//! light maps, WAD3 miptex that may embed pixels and a palette after the 40-byte header this
//! reader takes the name and size from), so it reads, vis-writes and converts exactly as BSP29.
//!
//! [`read`] checks the header and every lump against the file, decodes the lumps that visibility
//! and drawing need into typed records, and validates every index (node children, planes, faces,
//! edges, vertices, texinfo, marksurfaces, model head nodes, `visofs` and the PVS row each vis leaf
//! points at; the node graph must be acyclic; planes and vertices must be finite), so code holding
//! a [`Bsp`] may index its vectors without checks, and [`to_level`] of it passes
//! [`crate::slvl::validate`]. Stored node, leaf and model bounds are taken as they are, whatever
//! they hold (nothing in the file depends on them): [`to_level`] replaces those that are not
//! usable ([`bounds`]). A file without clipnodes (`qbsp -noclip`) has no clip hulls, and the clip
//! hull roots of its models are not read.
//! [`write_with_visdata`] replaces the visibility lump of an existing file and keeps every other
//! lump byte-identical ([`write_vis_rows`] from one row offset per vis leaf); [`check_vis_layout`]
//! tells beforehand whether a file's lumps allow that (vis asks before computing anything);
//! [`to_level`] turns a BSP into Sightline's [`crate::level::Level`]. Quake 2 and Quake 3 files
//! (`IBSP`) are refused here with [`BspError::OtherGame`]; [`q2`] and [`q3`] read them.
//!
//! # Conventions (Quake's)
//! - Node children use Quake's encoding, widened to `i32`: `c >= 0` is node `c`, `c < 0` is leaf
//!   `-(c + 1)`. BSP29 stores them as 16 bits; like current engines, a stored value `p` (read
//!   unsigned) below the node count is a node, otherwise leaf `65535 - p`.
//! - Leaf 0 is the shared solid leaf. Leaf `i + 1` (for `i < visleafs`) owns PVS row `i`, in which
//!   bit `j` (byte `j >> 3`, bit `j & 7`, least significant first) means leaf `j + 1` is visible.
//!   `visofs == -1`, or an empty visibility lump, means "no vis data: everything visible"; the
//!   `visofs` of leaf 0 and of brush-model leaves is never read (qbsp leaves 0 there).
//! - A face with `side != 0` is seen from the back of its plane. Its corners, read through
//!   surfedges (`e >= 0`: `edges[e].0`; `e < 0`: `edges[-e].1`), run clockwise seen from the side
//!   it faces.

pub mod bounds;
mod compiled;
mod convert;
mod lumps;
mod parse;
pub mod q2;
pub mod q3;
mod write;

pub use compiled::{CompiledMap, Game, Parsed};
pub use convert::to_level;
pub use write::{check_vis_layout, write_vis_rows, write_with_visdata};

use crate::bits;
use crate::rle::{self, RleError};
use thiserror::Error;

/// Number of lumps in every BSP version handled here.
pub const NUM_LUMPS: usize = 15;
/// Size of the header: version plus 15 `(offset, length)` pairs.
pub const HEADER_BYTES: usize = 4 + NUM_LUMPS * 8;

/// Lump indices, in header order.
pub mod lump {
    /// Entity text.
    pub const ENTITIES: usize = 0;
    /// Planes.
    pub const PLANES: usize = 1;
    /// Miptex directory and texture data.
    pub const TEXTURES: usize = 2;
    /// Vertices.
    pub const VERTICES: usize = 3;
    /// Compressed PVS rows.
    pub const VISIBILITY: usize = 4;
    /// Nodes.
    pub const NODES: usize = 5;
    /// Texture projection records.
    pub const TEXINFO: usize = 6;
    /// Faces.
    pub const FACES: usize = 7;
    /// Light maps.
    pub const LIGHTING: usize = 8;
    /// Collision hulls.
    pub const CLIPNODES: usize = 9;
    /// Leaves.
    pub const LEAVES: usize = 10;
    /// Face lists of leaves.
    pub const MARKSURFACES: usize = 11;
    /// Edges.
    pub const EDGES: usize = 12;
    /// Signed edge lists of faces.
    pub const SURFEDGES: usize = 13;
    /// Models.
    pub const MODELS: usize = 14;
    /// Lump names, for messages.
    pub const NAMES: [&str; super::NUM_LUMPS] = [
        "entities",
        "planes",
        "textures",
        "vertices",
        "visibility",
        "nodes",
        "texinfo",
        "faces",
        "lighting",
        "clipnodes",
        "leaves",
        "marksurfaces",
        "edges",
        "surfedges",
        "models",
    ];
}

/// Which flavour of BSP a file is; decides record sizes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BspVersion {
    /// Quake's original: version `29`, 16-bit node/leaf bounds, indices and children.
    Bsp29,
    /// `BSP2`: 32-bit indices and children, float bounds.
    Bsp2,
    /// `2PSB` (BSP2-RMQ): 32-bit indices and children, 16-bit bounds.
    Bsp2Rmq,
    /// Half-Life (GoldSrc): version `30`, BSP29's records.
    Bsp30,
}

impl BspVersion {
    /// Every version this module reads.
    pub const ALL: [Self; 4] = [Self::Bsp29, Self::Bsp2, Self::Bsp2Rmq, Self::Bsp30];

    /// The four bytes that start the file.
    pub fn magic(self) -> [u8; 4] {
        match self {
            Self::Bsp29 => 29i32.to_le_bytes(),
            Self::Bsp2 => *b"BSP2",
            Self::Bsp2Rmq => *b"2PSB",
            Self::Bsp30 => 30i32.to_le_bytes(),
        }
    }

    /// Short name for messages and `info`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Bsp29 => "BSP29",
            Self::Bsp2 => "BSP2",
            Self::Bsp2Rmq => "BSP2-RMQ",
            Self::Bsp30 => "BSP30",
        }
    }

    /// The game family: `"Half-Life"` for BSP30, else `"Quake"`.
    pub fn game(self) -> &'static str {
        if self == Self::Bsp30 { "Half-Life" } else { "Quake" }
    }

    /// True for BSP29's 16-bit indices, children and face fields (BSP29 and BSP30).
    pub fn narrow(self) -> bool {
        matches!(self, Self::Bsp29 | Self::Bsp30)
    }

    /// Bytes of one node record.
    pub fn node_bytes(self) -> usize {
        match self {
            Self::Bsp29 | Self::Bsp30 => 24,
            Self::Bsp2 => 44,
            Self::Bsp2Rmq => 32,
        }
    }

    /// Bytes of one leaf record.
    pub fn leaf_bytes(self) -> usize {
        match self {
            Self::Bsp29 | Self::Bsp30 => 28,
            Self::Bsp2 => 44,
            Self::Bsp2Rmq => 32,
        }
    }

    /// Byte offset of the four ambient levels inside a leaf record.
    pub fn leaf_ambient_offset(self) -> usize {
        self.leaf_bytes() - 4
    }
}

/// One header entry as stored (already checked to lie inside the file).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct LumpEntry {
    /// Byte offset from the start of the file.
    pub offset: usize,
    /// Length in bytes.
    pub length: usize,
}

impl LumpEntry {
    /// One past the last byte.
    pub fn end(&self) -> usize {
        self.offset + self.length
    }
}

/// A plane record.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BspPlane {
    /// Unit normal.
    pub normal: [f32; 3],
    /// `normal · p` on the plane.
    pub dist: f32,
    /// Quake's axial type code (0..=5).
    pub kind: i32,
}

/// A node record, children decoded to Quake's signed encoding (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BspNode {
    /// Index into [`Bsp::planes`].
    pub plane: u32,
    /// Front child (`normal · p - dist >= 0`) then back child.
    pub children: [i32; 2],
    /// Bounds.
    pub mins: [f32; 3],
    /// Bounds.
    pub maxs: [f32; 3],
    /// First face in [`Bsp::faces`].
    pub first_face: u32,
    /// Number of faces.
    pub num_faces: u32,
}

/// A leaf record.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BspLeaf {
    /// Quake contents code (-1 empty, -2 solid, -3 water, -4 slime, -5 lava, -6 sky; others kept).
    pub contents: i32,
    /// Byte offset of the leaf's PVS row in [`Bsp::visdata`], or -1.
    pub visofs: i32,
    /// Bounds.
    pub mins: [f32; 3],
    /// Bounds.
    pub maxs: [f32; 3],
    /// First entry in [`Bsp::marksurfaces`].
    pub first_marksurface: u32,
    /// Number of entries.
    pub num_marksurfaces: u32,
    /// Ambient sound levels: water, sky, slime, lava.
    pub ambient: [u8; 4],
}

/// A texture projection record.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TexInfo {
    /// S and T axes with offsets.
    pub vecs: [[f32; 4]; 2],
    /// Index into [`Bsp::textures`].
    pub miptex: u32,
    /// Flags (bit 0: special, i.e. sky or liquid, not lightmapped).
    pub flags: i32,
}

/// A face record.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BspFace {
    /// Index into [`Bsp::planes`].
    pub plane: u32,
    /// True when the face is seen from the back of its plane.
    pub back: bool,
    /// First entry in [`Bsp::surfedges`].
    pub first_edge: u32,
    /// Number of edges (at least 3).
    pub num_edges: u32,
    /// Index into [`Bsp::texinfo`].
    pub texinfo: u32,
    /// Light styles.
    pub styles: [u8; 4],
    /// Byte offset into the lighting lump, or -1.
    pub light_offset: i32,
}

/// A model record.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BspModel {
    /// Bounds.
    pub mins: [f32; 3],
    /// Bounds.
    pub maxs: [f32; 3],
    /// Origin.
    pub origin: [f32; 3],
    /// Hull 0 root (node child encoding) then the three clip hull roots (clipnode indices, or a
    /// negative contents code for an empty hull; not meaningful in a file without clipnodes).
    pub head_nodes: [i32; 4],
    /// Leaves with PVS rows (meaningful for model 0).
    pub visleafs: u32,
    /// First face in [`Bsp::faces`].
    pub first_face: u32,
    /// Number of faces.
    pub num_faces: u32,
}

/// A texture directory entry; `None` in [`Bsp::textures`] marks a missing texture (offset -1).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MipTex {
    /// Name, up to 15 characters (lossily decoded).
    pub name: String,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

/// A parsed, validated BSP file.
#[derive(Debug, Clone, PartialEq)]
pub struct Bsp {
    /// File flavour.
    pub version: BspVersion,
    /// Header entries, in lump order.
    pub lumps: [LumpEntry; NUM_LUMPS],
    /// Entity text up to the first NUL (lossily decoded).
    pub entities: String,
    /// Planes.
    pub planes: Vec<BspPlane>,
    /// Texture directory.
    pub textures: Vec<Option<MipTex>>,
    /// Vertices.
    pub vertices: Vec<[f32; 3]>,
    /// Compressed PVS rows.
    pub visdata: Vec<u8>,
    /// Nodes.
    pub nodes: Vec<BspNode>,
    /// Texture projections.
    pub texinfo: Vec<TexInfo>,
    /// Faces.
    pub faces: Vec<BspFace>,
    /// Number of clipnode records (their content is not decoded); 0 for a file without clip hulls.
    pub num_clipnodes: usize,
    /// Leaves.
    pub leaves: Vec<BspLeaf>,
    /// Face indices listed by leaves.
    pub marksurfaces: Vec<u32>,
    /// Edges as vertex index pairs.
    pub edges: Vec<[u32; 2]>,
    /// Signed edge indices listed by faces.
    pub surfedges: Vec<i32>,
    /// Models; model 0 is the world.
    pub models: Vec<BspModel>,
}

/// Everything that can be wrong with a BSP file or a write request.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[non_exhaustive]
pub enum BspError {
    /// The file cannot hold the header.
    #[error("file is {len} bytes, shorter than the {HEADER_BYTES}-byte BSP header")]
    TooShort {
        /// File length.
        len: usize,
    },
    /// A Quake 2 or Quake 3 BSP (`IBSP`), which this reader does not take: [`q2::read`] and
    /// [`q3::read`] do.
    #[error(
        "byte 0: {} BSP (IBSP {version}), not a Quake 1 BSP (29, BSP2, 2PSB) or Half-Life BSP (30)",
        game.name()
    )]
    OtherGame {
        /// The game, as [`Game::sniff`] tells it.
        game: Game,
        /// The version field (38 for Quake 2, 46 or 47 for Quake 3).
        version: i32,
    },
    /// Unknown version field.
    #[error("byte 0: unknown BSP version {magic:02x?} (expected 29, BSP2, 2PSB or 30)")]
    Version {
        /// The first four bytes.
        magic: [u8; 4],
    },
    /// A header entry points outside the file.
    #[error(
        "byte {header_offset}: lump {lump} ({name}) has offset {offset} and length {length}, outside the {file_len}-byte file"
    )]
    LumpBounds {
        /// Byte offset of the header entry.
        header_offset: usize,
        /// Lump index.
        lump: usize,
        /// Lump name.
        name: &'static str,
        /// Stored offset.
        offset: i64,
        /// Stored length.
        length: i64,
        /// File length.
        file_len: usize,
    },
    /// A lump's length does not fit its records.
    #[error("byte {offset}: lump {name} is {length} bytes, not a multiple of its {record}-byte record")]
    LumpSize {
        /// Lump offset.
        offset: usize,
        /// Lump name.
        name: &'static str,
        /// Lump length.
        length: usize,
        /// Record size.
        record: usize,
    },
    /// A record holds a bad value or index.
    #[error("byte {offset}: {what}: {detail}")]
    Invalid {
        /// Byte offset of the record in the file.
        offset: usize,
        /// Which record (`"node 12"`).
        what: String,
        /// What is wrong.
        detail: String,
    },
    /// A PVS row does not decode.
    #[error("byte {offset}: PVS row of leaf {leaf}")]
    Row {
        /// Byte offset of the row in the file.
        offset: usize,
        /// Leaf index.
        leaf: usize,
        /// Decoder error.
        source: RleError,
    },
    /// A Quake 2 PVS or PHS row does not decode, or a cluster without a row was asked for one.
    #[error("byte {offset}: {which} row of cluster {cluster}")]
    ClusterRow {
        /// Byte offset of the row in the file (or in the lump, for a lump read alone).
        offset: usize,
        /// Cluster index.
        cluster: usize,
        /// `"PVS"` or `"PHS"`.
        which: &'static str,
        /// Decoder error.
        source: RleError,
    },
    /// A leaf index outside `1..=visleafs` was asked for its PVS.
    #[error("leaf {leaf} has no PVS row (vis leaves are 1..={visleafs})")]
    NotAVisLeaf {
        /// Requested leaf.
        leaf: usize,
        /// Vis leaves in the file.
        visleafs: usize,
    },
    /// Two lumps share bytes that writing visdata needs apart ([`check_vis_layout`]): the
    /// visibility lump (rewritten) or the leaves lump (whose `visofs` and ambient levels are
    /// rewritten) and another lump or the header.
    #[error(
        "byte {offset}: lump {lump} (bytes {offset}..{end}) overlaps {other} (bytes {other_offset}..{other_end}); \
         vis rewrites the {lump} lump and needs it apart from every other lump"
    )]
    Overlap {
        /// The lump vis rewrites (`"visibility"` or `"leaves"`).
        lump: &'static str,
        /// Its first byte in the file.
        offset: usize,
        /// One past its last byte.
        end: usize,
        /// What it overlaps: `"lump NAME"` or `"the header"`.
        other: String,
        /// The other's first byte.
        other_offset: usize,
        /// One past the other's last byte.
        other_end: usize,
    },
    /// Arguments of [`write_with_visdata`] do not match the file.
    #[error("cannot write visdata: {0}")]
    Write(String),
}

/// Parses and validates a BSP file.
pub fn read(bytes: &[u8]) -> Result<Bsp, BspError> {
    parse::read(bytes)
}

/// Summary of the PVS stored in a BSP.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PvsStats {
    /// Leaves with rows.
    pub visleafs: usize,
    /// Mean number of visible leaves per vis leaf (bits set in its row; "no vis" counts all).
    pub avg_visible: f64,
    /// Largest number of visible leaves of one vis leaf.
    pub max_visible: usize,
    /// Ordered visible (vis leaf, vis leaf) pairs, self included: the bits set in all rows.
    pub pairs: u64,
    /// Size of the visibility lump.
    pub visdata_bytes: usize,
}

impl Bsp {
    /// Number of leaves with PVS rows (world model's `visleafs`).
    pub fn visleafs(&self) -> usize {
        self.models.first().map_or(0, |m| m.visleafs as usize)
    }

    /// Bytes in one uncompressed PVS row.
    pub fn row_bytes(&self) -> usize {
        bits::bytes::len(self.visleafs())
    }

    /// The uncompressed PVS row of `leaf` (`1..=visleafs`): bit `j` set means leaf `j + 1` is
    /// visible. A leaf with `visofs == -1`, or any leaf when the visdata is empty, sees every vis
    /// leaf.
    pub fn decode_leaf_pvs(&self, leaf: usize) -> Result<Vec<u8>, BspError> {
        let mut row = vec![0; self.row_bytes()];
        self.decode_leaf_pvs_into(leaf, &mut row)?;
        Ok(row)
    }

    /// As [`Bsp::decode_leaf_pvs`], into `row` (at least [`Bsp::row_bytes`] long).
    pub fn decode_leaf_pvs_into(&self, leaf: usize, row: &mut [u8]) -> Result<(), BspError> {
        let visleafs = self.visleafs();
        let info = match self.leaves.get(leaf) {
            Some(info) if (1..=visleafs).contains(&leaf) => info,
            _ => return Err(BspError::NotAVisLeaf { leaf, visleafs }),
        };
        let row_bytes = self.row_bytes();
        let row_err = |offset, source| BspError::Row { offset, leaf, source };
        let Some(row) = row.get_mut(..row_bytes) else {
            return Err(row_err(0, RleError::OutputTooSmall { len: row.len(), row_bytes }));
        };
        let visofs = usize::try_from(info.visofs).ok().filter(|_| !self.visdata.is_empty());
        let Some(visofs) = visofs else {
            bits::bytes::fill_prefix(row, visleafs);
            return Ok(());
        };
        let vis_lump = self.lumps[lump::VISIBILITY].offset;
        let data = self.visdata.get(visofs..).unwrap_or_default();
        rle::decode_row(data, row_bytes, row).map_err(|e| row_err(vis_lump + visofs, e))?;
        Ok(())
    }

    /// Visible-leaf statistics over all vis leaves; `None` when the file has no vis leaves.
    pub fn pvs_stats(&self) -> Result<Option<PvsStats>, BspError> {
        let visleafs = self.visleafs();
        if visleafs == 0 {
            return Ok(None);
        }
        let mut row = vec![0; self.row_bytes()];
        let mut total = 0usize;
        let mut max = 0usize;
        for leaf in 1..=visleafs {
            self.decode_leaf_pvs_into(leaf, &mut row)?;
            let n = rle::count_bits(&row);
            total += n;
            max = max.max(n);
        }
        Ok(Some(PvsStats {
            visleafs,
            avg_visible: total as f64 / visleafs as f64,
            max_visible: max,
            pairs: total as u64,
            visdata_bytes: self.visdata.len(),
        }))
    }

    /// Corner vertex indices of face `face`, in stored order.
    pub fn face_vertex_indices(&self, face: &BspFace) -> impl Iterator<Item = u32> + '_ {
        let first = face.first_edge as usize;
        let edges = self.surfedges.get(first..first + face.num_edges as usize).unwrap_or_default();
        edges.iter().filter_map(|&e| {
            let edge = self.edges.get(e.unsigned_abs() as usize)?;
            Some(if e >= 0 { edge[0] } else { edge[1] })
        })
    }

    /// Texture name of a face; empty when the texture is missing from the file.
    pub fn face_texture_name(&self, face: &BspFace) -> &str {
        self.texinfo
            .get(face.texinfo as usize)
            .and_then(|ti| self.textures.get(ti.miptex as usize))
            .and_then(|t| t.as_ref())
            .map_or("", |t| t.name.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A minimal BSP29: one plane, one node splitting solid leaf 0 from empty leaf 1, one model,
    /// and `visdata` (leaf 1's row at offset 0). Lumps are laid out in index order, 4-aligned.
    fn tiny(visdata: &[u8], child: i16) -> Vec<u8> {
        let mut lumps: Vec<Vec<u8>> = vec![Vec::new(); NUM_LUMPS];
        lumps[lump::ENTITIES] = b"{\n\"classname\" \"worldspawn\"\n}\n\0".to_vec();
        lumps[lump::PLANES] =
            [0f32, 0.0, 1.0, 0.0].iter().flat_map(|f| f.to_le_bytes()).chain(2i32.to_le_bytes()).collect();
        lumps[lump::VISIBILITY] = visdata.to_vec();
        let mut node = 0i32.to_le_bytes().to_vec();
        for v in [child, -2, -64, -64, -64, 64, 64, 64, 0, 0] {
            node.extend_from_slice(&v.to_le_bytes());
        }
        lumps[lump::NODES] = node;
        let leaf = |contents: i32, visofs: i32| {
            let mut l = contents.to_le_bytes().to_vec();
            l.extend_from_slice(&visofs.to_le_bytes());
            l.extend_from_slice(&[0; 20]);
            l
        };
        lumps[lump::LEAVES] = [leaf(-2, -1), leaf(-1, 0)].concat();
        let mut model = vec![0u8; 36];
        for v in [0i32, -1, -1, -1, 1, 0, 0] {
            model.extend_from_slice(&v.to_le_bytes());
        }
        lumps[lump::MODELS] = model;
        let mut out = vec![0u8; HEADER_BYTES];
        out[..4].copy_from_slice(&29i32.to_le_bytes());
        for (i, data) in lumps.iter().enumerate() {
            out.resize(out.len().next_multiple_of(4), 0);
            let at = 4 + 8 * i;
            let offset = out.len() as i32;
            out[at..at + 4].copy_from_slice(&offset.to_le_bytes());
            out[at + 4..at + 8].copy_from_slice(&(data.len() as i32).to_le_bytes());
            out.extend_from_slice(data);
        }
        out
    }

    #[test]
    fn reads_a_tiny_bsp_and_its_row() {
        let bsp = read(&tiny(&[1], -1)).unwrap();
        assert_eq!(bsp.version, BspVersion::Bsp29);
        assert_eq!(bsp.visleafs(), 1);
        assert_eq!(bsp.nodes[0].children, [-1, -2]);
        assert_eq!(bsp.decode_leaf_pvs(1), Ok(vec![1]));
        assert!(matches!(bsp.decode_leaf_pvs(0), Err(BspError::NotAVisLeaf { leaf: 0, visleafs: 1 })));
        assert_eq!(bsp.pvs_stats().unwrap().unwrap().max_visible, 1);
        assert!(bsp.entities.contains("worldspawn"));
        let level = to_level(&bsp);
        assert_eq!(level.leaves[1].cluster, 0);
        assert_eq!(level.leaves[0].cluster, -1);
        assert_eq!(level.pvs_offsets, [0]);
    }

    #[test]
    fn errors_name_the_byte() {
        let good = tiny(&[1], -1);
        assert_eq!(read(&good[..100]), Err(BspError::TooShort { len: 100 }));
        let mut bad = good.clone();
        bad[0] = 31;
        assert!(matches!(read(&bad), Err(BspError::Version { .. })));
        // Half-Life's BSP30 has BSP29's records.
        bad[0] = 30;
        let hl = read(&bad).unwrap();
        assert_eq!((hl.version, hl.version.game()), (BspVersion::Bsp30, "Half-Life"));
        assert_eq!((hl.leaves, hl.nodes), (read(&good).unwrap().leaves, read(&good).unwrap().nodes));
        let q2 = read(b"IBSP\x26\0\0\0").unwrap_err();
        assert_eq!(q2, BspError::OtherGame { game: Game::Quake2, version: 38 });
        assert!(q2.to_string().contains("Quake 2 BSP (IBSP 38)"), "{q2}");
        let q3 = read(b"IBSP\x2e\0\0\0").unwrap_err();
        assert!(q3.to_string().starts_with("byte 0: Quake 3 BSP (IBSP 46), not a Quake 1"), "{q3}");
        let mut bad = good.clone();
        let at = 4 + 8 * lump::MODELS + 4;
        bad[at..at + 4].copy_from_slice(&1000i32.to_le_bytes());
        assert!(matches!(read(&bad), Err(BspError::LumpBounds { header_offset: 116, lump: 14, .. })));
        // Node child 5 (stored unsigned, >= node count) means leaf 65530: out of range.
        assert!(matches!(read(&tiny(&[1], 5)), Err(BspError::Invalid { .. })));
        // Node 0 as its own child.
        assert!(matches!(read(&tiny(&[1], 0)), Err(BspError::Invalid { .. })));
        // A run overflowing the one-byte row.
        assert!(matches!(read(&tiny(&[0, 2], -1)), Err(BspError::Row { leaf: 1, .. })));
        assert!(matches!(read(&tiny(&[0], -1)), Err(BspError::Row { leaf: 1, .. })));
    }

    #[test]
    fn stored_bounds_are_taken_whatever_they_hold_and_clip_hulls_may_be_absent() {
        let good = tiny(&[1], -1);
        let b = read(&good).unwrap();
        let (nodes, leaves, models) =
            (b.lumps[lump::NODES].offset, b.lumps[lump::LEAVES].offset, b.lumps[lump::MODELS].offset);
        // BSP29 node and leaf bounds are integers (inverted here); model bounds are floats.
        let mut odd = good.clone();
        odd[nodes + 8..nodes + 10].copy_from_slice(&100i16.to_le_bytes());
        odd[leaves + 28 + 8..leaves + 28 + 10].copy_from_slice(&100i16.to_le_bytes());
        odd[models..models + 4].copy_from_slice(&f32::NAN.to_le_bytes());
        odd[models + 12..models + 16].copy_from_slice(&f32::NEG_INFINITY.to_le_bytes());
        // No clipnodes (qbsp -noclip): every clip hull root 0 names nothing and is not read.
        odd[models + 40..models + 52].fill(0);
        let b = read(&odd).unwrap();
        assert_eq!((b.num_clipnodes, b.models[0].head_nodes), (0, [0; 4]));
        assert!(b.models[0].mins[0].is_nan() && b.nodes[0].mins[0] > b.nodes[0].maxs[0]);
        let level = to_level(&b);
        crate::slvl::validate(&level).unwrap();
        assert!(level.nodes.iter().all(|n| bounds::usable(n.mins, n.maxs)));
        assert!(level.leaves.iter().all(|l| bounds::usable(l.mins, l.maxs)));
        // With clipnodes present, a root must name one.
        let mut clip = odd.clone();
        let entry = 4 + 8 * lump::CLIPNODES;
        clip[entry + 4..entry + 8].copy_from_slice(&8i32.to_le_bytes());
        clip[models + 40..models + 44].copy_from_slice(&1i32.to_le_bytes());
        let e = read(&clip).unwrap_err();
        assert!(e.to_string().contains("model 0: clip hull root 1 >= 1 clipnodes"), "{e}");
        clip[models + 40..models + 44].copy_from_slice(&0i32.to_le_bytes());
        assert_eq!(read(&clip).map(|b| b.num_clipnodes), Ok(1));
    }

    #[test]
    fn visdata_write_back_moves_later_lumps() {
        let original = tiny(&[1], -1);
        let out =
            write_with_visdata(&original, &[0xff, 0, 0, 0, 0, 1], &[-1, 5], Some(&[[0; 4], [9, 8, 7, 6]]))
                .unwrap();
        let bsp = read(&out).unwrap();
        assert_eq!(bsp.visdata, [0xff, 0, 0, 0, 0, 1]);
        assert_eq!(bsp.leaves[1].visofs, 5);
        assert_eq!(bsp.leaves[1].ambient, [9, 8, 7, 6]);
        assert_eq!(bsp.decode_leaf_pvs(1), Ok(vec![1]));
        assert!(bsp.lumps.iter().all(|l| l.offset % 4 == 0));
        let before = read(&original).unwrap();
        assert_eq!((bsp.nodes, bsp.models, bsp.entities), (before.nodes, before.models, before.entities));
        assert!(matches!(write_with_visdata(&original, &[1], &[-1], None), Err(BspError::Write(_))));
        assert!(matches!(
            write_with_visdata(&original, &[1], &[-1, 0], Some(&[[0; 4]])),
            Err(BspError::Write(_))
        ));
        // An empty visibility lump recorded at offset 0: the rows are appended, 4-aligned.
        let mut at_zero = original.clone();
        let at = 4 + 8 * lump::VISIBILITY;
        at_zero[at..at + 4].copy_from_slice(&0i32.to_le_bytes());
        at_zero[at + 4..at + 8].copy_from_slice(&0i32.to_le_bytes());
        at_zero.push(7);
        let out = write_with_visdata(&at_zero, &[1], &[-1, 0], None).unwrap();
        assert_eq!(out.len(), at_zero.len().next_multiple_of(4) + 4);
        assert_eq!(&out[at_zero.len() - 1..at_zero.len()], &[7]);
        assert_eq!(read(&out).unwrap().lumps[lump::VISIBILITY].offset, at_zero.len().next_multiple_of(4));
        // A row offset outside the new visdata is caught by the read-back.
        assert!(write_with_visdata(&original, &[1], &[-1, 1], None).is_err());
    }

    /// Sets lump `index`'s header entry in `file`.
    fn set_lump(file: &mut [u8], index: usize, offset: usize, length: usize) {
        let at = 4 + 8 * index;
        file[at..at + 4].copy_from_slice(&(offset as i32).to_le_bytes());
        file[at + 4..at + 8].copy_from_slice(&(length as i32).to_le_bytes());
    }

    #[test]
    fn overlapping_lumps_are_refused_before_any_writing() {
        let good = tiny(&[1], -1);
        let lumps = read(&good).unwrap().lumps;
        assert_eq!(check_vis_layout(&lumps), Ok(()));
        let nodes = lumps[lump::NODES];
        // The visibility lump stretched over the nodes lump: refused by name and byte range.
        let mut bad = good.clone();
        set_lump(&mut bad, lump::VISIBILITY, nodes.offset, 4);
        let e = write_with_visdata(&bad, &[1], &[-1, 0], None).unwrap_err();
        let BspError::Overlap { lump: "visibility", offset, end, ref other, other_offset, other_end } = e
        else {
            panic!("{e:?}")
        };
        assert_eq!((offset, end, other.as_str()), (nodes.offset, nodes.offset + 4, "lump nodes"));
        assert_eq!((other_offset, other_end), (nodes.offset, nodes.end()));
        assert_eq!(
            e.to_string(),
            format!(
                "byte {o}: lump visibility (bytes {o}..{e4}) overlaps lump nodes (bytes {o}..{ne}); \
                 vis rewrites the visibility lump and needs it apart from every other lump",
                o = nodes.offset,
                e4 = nodes.offset + 4,
                ne = nodes.end()
            )
        );
        // An empty visibility lump strictly inside another lump, visdata over the header, leaves
        // sharing bytes with the models.
        let mut inside = good.clone();
        set_lump(&mut inside, lump::VISIBILITY, nodes.offset + 4, 0);
        assert!(matches!(
            check_vis_layout(&parse::read_header(&inside).unwrap().1),
            Err(BspError::Overlap { lump: "visibility", .. })
        ));
        let mut header = good.clone();
        set_lump(&mut header, lump::VISIBILITY, 8, 4);
        assert!(matches!(
            check_vis_layout(&parse::read_header(&header).unwrap().1),
            Err(BspError::Overlap { lump: "visibility", other, other_offset: 0, .. }) if other == "the header"
        ));
        let mut leaves = good.clone();
        set_lump(&mut leaves, lump::LEAVES, lumps[lump::MODELS].offset, 28);
        assert!(matches!(
            check_vis_layout(&parse::read_header(&leaves).unwrap().1),
            Err(BspError::Overlap { lump: "leaves", other, .. }) if other == "lump models"
        ));
        // An empty visibility lump recorded at offset 0 is fine: its data goes at the end.
        let mut at_zero = good.clone();
        set_lump(&mut at_zero, lump::VISIBILITY, 0, 0);
        assert_eq!(check_vis_layout(&parse::read_header(&at_zero).unwrap().1), Ok(()));
    }

    #[test]
    fn vis_rows_go_to_the_leaf_after_their_vis_leaf() {
        let original = tiny(&[1], -1);
        let bsp = read(&original).unwrap();
        let out = write_vis_rows(&original, &bsp, &[0, 1, 1], &[2], None).unwrap();
        let written = read(&out).unwrap();
        assert_eq!((written.leaves[0].visofs, written.leaves[1].visofs), (-1, 2));
        assert_eq!(written.decode_leaf_pvs(1), Ok(vec![1]));
        // The same bytes as spelling out every leaf's `visofs`.
        assert_eq!(out, write_with_visdata(&original, &[0, 1, 1], &[-1, 2], None).unwrap());
        assert!(matches!(
            write_vis_rows(&original, &bsp, &[1], &[u32::MAX], None),
            Err(BspError::Write(m)) if m.contains("2 GiB")
        ));
    }
}
