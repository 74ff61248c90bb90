//! The compiled level: Sightline's in-memory data model, written to disk as `.slvl`.
//!
//! # Conventions
//! - Coordinates and plane distances are `f32` world units (the compiler works in `f64` and
//!   converts only when it emits a level).
//! - A node's `children[0]` is the **front** side of its plane (`normal · p - dist >= 0`) and
//!   `children[1]` the back. A child `c >= 0` is node `c`; `c < 0` is leaf `-(c + 1)` (as Quake).
//! - Leaves with [`Contents::Solid`] have `cluster == -1`; every other leaf of the world tree
//!   (model 0) belongs to exactly one cluster `0..num_clusters`. Leaves of brush-model subtrees
//!   have no cluster (-1) and no PVS row. Without detail brushes each non-solid world leaf is its
//!   own cluster.
//! - Portal `i` joins `leaves[0]`, on the **front** of its plane, and `leaves[1]`, on the back:
//!   the plane's normal points into `leaves[0]`, as a `.prt` winding faces into its first leaf.
//!   Winding points are clockwise seen from the front, so the winding's own plane is `plane`.
//! - PVS rows are per cluster: row `c` has one bit per cluster (bit `j` = byte `j >> 3`, bit
//!   `j & 7`, least significant first), stored Quake-RLE compressed ([`crate::rle`]); `pvs_offsets[c]`
//!   is the byte offset of row `c` in `pvs_data`. An empty `pvs_offsets` means "no vis: everything
//!   visible".

use thiserror::Error;

use crate::bits;
use crate::rle::{self, RleError};

/// What fills a leaf. The numeric values are Quake's `CONTENTS_*` codes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[repr(i32)]
pub enum Contents {
    /// Open air.
    Empty = -1,
    /// Solid rock: not part of any cluster.
    Solid = -2,
    /// Water (see-through).
    Water = -3,
    /// Slime (see-through).
    Slime = -4,
    /// Lava (see-through).
    Lava = -5,
    /// Sky: drawn as sky, and opaque to sight like solid (Quake makes no vis portals into sky).
    Sky = -6,
}

impl Contents {
    /// From Quake's code; `None` for an unknown code.
    pub fn from_code(code: i32) -> Option<Self> {
        Some(match code {
            -1 => Self::Empty,
            -2 => Self::Solid,
            -3 => Self::Water,
            -4 => Self::Slime,
            -5 => Self::Lava,
            -6 => Self::Sky,
            _ => return None,
        })
    }

    /// Quake's code.
    pub fn code(self) -> i32 {
        self as i32
    }

    /// True for every contents except solid: the leaf is open space with a cluster (sky leaves
    /// are open but opaque to sight; see [`Contents::Sky`]).
    pub fn is_open(self) -> bool {
        self != Self::Solid
    }
}

/// A plane as stored: unit normal and distance.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct LevelPlane {
    /// Unit normal (front side is where it points).
    pub normal: [f32; 3],
    /// `normal · p` for points on the plane.
    pub dist: f32,
}

/// An interior node of the BSP tree.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Node {
    /// Index into [`Level::planes`].
    pub plane: u32,
    /// Front child then back child; see the module docs for the encoding.
    pub children: [i32; 2],
    /// Bounds of everything below this node.
    pub mins: [f32; 3],
    /// Bounds of everything below this node.
    pub maxs: [f32; 3],
}

/// A convex cell of the tree.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Leaf {
    /// What fills it.
    pub contents: Contents,
    /// Cluster index, or -1 for solid leaves.
    pub cluster: i32,
    /// Bounds of the cell (clipped to the world bounds).
    pub mins: [f32; 3],
    /// Bounds of the cell.
    pub maxs: [f32; 3],
    /// First entry in [`Level::leaf_faces`].
    pub first_face: u32,
    /// Number of entries in [`Level::leaf_faces`].
    pub num_faces: u32,
}

/// A drawable polygon.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Face {
    /// Index into [`Level::planes`]; the face is seen from the plane's front.
    pub plane: u32,
    /// First corner in [`Level::vertices`].
    pub first_vertex: u32,
    /// Number of corners (at least 3), clockwise seen from the front.
    pub num_vertices: u32,
    /// Index into [`Level::textures`].
    pub texture: u32,
}

/// How a face is textured and lit: Quake's texinfo projection and the face's light-map fields.
///
/// Texture coordinates in texels of a point `p` (world units) on the face are
/// `s = s[0..3] · p + s[3]` and `t = t[0..3] · p + t[3]`; divide by the texture's size
/// ([`Level::texture_sizes`]) for normalised coordinates. Quake's light map of the face starts at
/// `floor(min s / 16)` (and `t`) over its corners, as in Quake's `CalcSurfaceExtents`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct FaceDraw {
    /// S axis (texels per world unit along x, y, z) and offset (texels).
    pub s: [f32; 4],
    /// T axis and offset, as `s`.
    pub t: [f32; 4],
    /// Quake texinfo flags (bit 0 "special": sky or liquid, warped and not light-mapped).
    pub flags: u32,
    /// Light styles of the face's light maps; 255 ends the list (Quake's `styles`).
    pub styles: [u8; 4],
    /// Byte offset of the face's first light map in the source BSP's lighting lump; -1 for none
    /// (a level compiled by Sightline has no light maps).
    pub light_offset: i32,
}

impl FaceDraw {
    /// No texture projection and no light map (every axis zero).
    pub const NONE: FaceDraw =
        FaceDraw { s: [0.0; 4], t: [0.0; 4], flags: 0, styles: [255; 4], light_offset: -1 };
}

/// An opening between two non-solid leaves.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Portal {
    /// Front-side leaf then back-side leaf of `plane`.
    pub leaves: [u32; 2],
    /// Index into [`Level::planes`].
    pub plane: u32,
    /// First corner in [`Level::vertices`].
    pub first_vertex: u32,
    /// Number of corners.
    pub num_vertices: u32,
}

/// A brush model: model 0 is the world, the others are brush entities (doors, platforms...).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Model {
    /// Root of the model's tree, encoded like a node child.
    pub head_node: i32,
    /// Bounds.
    pub mins: [f32; 3],
    /// Bounds.
    pub maxs: [f32; 3],
    /// First face in [`Level::faces`].
    pub first_face: u32,
    /// Number of faces.
    pub num_faces: u32,
}

/// Everything a compiled level holds. Indices are validated when a level is read from disk, so
/// code holding a `Level` from [`crate::slvl::read`] may index without checks.
#[derive(Debug, Clone, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Level {
    /// The entity text, Quake `.map` syntax without brushes.
    pub entities: String,
    /// Texture names; faces refer to them by index.
    pub textures: Vec<String>,
    /// Texture sizes in texels (`[width, height]`, `[0, 0]` when unknown), one per texture, or
    /// empty when the source had none (a `.map` names textures but does not size them).
    pub texture_sizes: Vec<[u32; 2]>,
    /// Planes.
    pub planes: Vec<LevelPlane>,
    /// Interior nodes; the world's root is `models[0].head_node`.
    pub nodes: Vec<Node>,
    /// Leaves.
    pub leaves: Vec<Leaf>,
    /// Face indices listed by leaves.
    pub leaf_faces: Vec<u32>,
    /// Faces.
    pub faces: Vec<Face>,
    /// Texture projection and light map of each face (`face_draw[i]` belongs to `faces[i]`), or
    /// empty when the source had none (levels written before this field existed).
    pub face_draw: Vec<FaceDraw>,
    /// Corners of faces and portals.
    pub vertices: Vec<[f32; 3]>,
    /// Portals: openings sight passes through, between non-solid leaves (sky only to sky).
    pub portals: Vec<Portal>,
    /// Brush models.
    pub models: Vec<Model>,
    /// Number of clusters (PVS row length in bits).
    pub num_clusters: u32,
    /// Byte offset of each cluster's compressed row in `pvs_data`; empty when vis was not run.
    pub pvs_offsets: Vec<u32>,
    /// Concatenated Quake-RLE rows.
    pub pvs_data: Vec<u8>,
    /// GVS view cells (empty unless `sightline gvs` stored its result in the level).
    pub gvs_cells: Vec<GvsCell>,
    /// Face indices listed by GVS cells.
    pub gvs_faces: Vec<u32>,
    /// The portal file written with this level, as [`crate::prt::fingerprint`] of its bytes: set by
    /// whoever writes the level and its `.prt` together (`sightline compile`), it tells whether a
    /// `.prt` beside a level is the one that belongs to it. `None` when the level was written
    /// without one (a leaking map, a level converted from a BSP, levels from before this field).
    pub portal_file: Option<u64>,
}

/// A box view cell with the faces guided visibility sampling found visible from it.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct GvsCell {
    /// Bounds of the view cell.
    pub mins: [f32; 3],
    /// Bounds of the view cell.
    pub maxs: [f32; 3],
    /// First entry in [`Level::gvs_faces`].
    pub first_face: u32,
    /// Number of entries in [`Level::gvs_faces`].
    pub num_faces: u32,
}

impl Level {
    /// Bytes in one uncompressed PVS row.
    pub fn row_bytes(&self) -> usize {
        crate::bits::bytes::len(self.num_clusters as usize)
    }

    /// True when the level carries a PVS.
    pub fn has_vis(&self) -> bool {
        !self.pvs_offsets.is_empty()
    }

    /// Leaves that belong to a cluster (vis leaves).
    pub fn vis_leaves(&self) -> usize {
        self.leaves.iter().filter(|l| l.cluster >= 0).count()
    }

    /// Visible-leaf counts over the vis leaves, counted in leaves: a vis leaf sees the leaves of
    /// every cluster set in its cluster's row, and every vis leaf when the level has no PVS.
    /// `None` without vis leaves. A row that is missing or does not decode is an error.
    pub fn pvs_stats(&self) -> Result<Option<PvsStats>, PvsError> {
        let vis_leaves = self.vis_leaves();
        if vis_leaves == 0 {
            return Ok(None);
        }
        let clusters = self.num_clusters as usize;
        let mut leaves_in = vec![0usize; clusters];
        for leaf in &self.leaves {
            if let Some(n) = usize::try_from(leaf.cluster).ok().and_then(|c| leaves_in.get_mut(c)) {
                *n += 1;
            }
        }
        // Visible leaves seen from each cluster.
        let mut seen = vec![vis_leaves; clusters];
        if self.has_vis() {
            let mut row = vec![0u8; self.row_bytes()];
            for (cluster, seen) in seen.iter_mut().enumerate() {
                let offset = self.pvs_offsets.get(cluster).map_or(usize::MAX, |&o| o as usize);
                let data = self.pvs_data.get(offset..).ok_or(PvsError::RowOffset { cluster })?;
                rle::decode_row(data, row.len(), &mut row)
                    .map_err(|source| PvsError::Row { cluster, source })?;
                *seen = leaves_in
                    .iter()
                    .enumerate()
                    .filter(|&(j, _)| bits::bytes::get(&row, j))
                    .map(|(_, n)| n)
                    .sum();
            }
        }
        let mut total = 0usize;
        let mut max = 0usize;
        for leaf in &self.leaves {
            let Some(&n) = usize::try_from(leaf.cluster).ok().and_then(|c| seen.get(c)) else { continue };
            total += n;
            max = max.max(n);
        }
        Ok(Some(PvsStats { vis_leaves, avg_visible: total as f64 / vis_leaves as f64, max_visible: max }))
    }
}

/// Summary of a level's PVS, counted in leaves ([`Level::pvs_stats`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PvsStats {
    /// Leaves with a cluster.
    pub vis_leaves: usize,
    /// Mean number of leaves a vis leaf sees.
    pub avg_visible: f64,
    /// Largest number of leaves one vis leaf sees.
    pub max_visible: usize,
}

/// Why [`Level::pvs_stats`] could not decode the PVS.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[non_exhaustive]
pub enum PvsError {
    /// A row offset lies beyond `pvs_data`.
    #[error("cluster {cluster}: row offset out of range")]
    RowOffset {
        /// The cluster whose row is missing.
        cluster: usize,
    },
    /// A row does not decode.
    #[error("cluster {cluster}: bad row")]
    Row {
        /// The cluster whose row is damaged.
        cluster: usize,
        /// What is wrong with it.
        #[source]
        source: RleError,
    },
}
