//! Quake 3 BSP files (`IBSP`, version 46, and Quake Live's 47 with the same lumps), read as far as
//! vis, the runtime and validation need them.
//!
//! [`read`] checks the header and every lump it decodes against the file: planes (finite),
//! nodes (plane and child indices in range, no cycle), leaves (cluster `-1` or below the leaf
//! count, as every cluster holds a leaf), models (at least the world's; bounds as stored, which
//! [`to_level`] repairs when unusable, [`super::bounds`]), the entity text, and the visibility
//! lump (lump 16: `int32 numClusters`, `int32 clusterBytes`, then `numClusters` rows of
//! `clusterBytes` **uncompressed** bytes). Every count is checked
//! against the bytes present before anything is allocated. [`vis_lump`] lays out a visibility
//! lump as q3map2 does (rows of `((n + 63) & !63) / 8` bytes, pad bits zero) and
//! [`write_with_visibility`] puts it into a file, keeping every other byte (q3map2 also stamps its
//! command line into the entity lump; Sightline does not), and reads the result back.
//! [`to_level`] turns the file into a [`Level`] whose solid leaves are exactly the leaves that
//! block sight.
//!
//! # Conventions (Quake 3's)
//! - Row `c` belongs to cluster `c`; bit `j` (byte `j >> 3`, bit `j & 7`) means cluster `j`, with
//!   no shift. Bits at and past `numClusters` are ignored on reading and written as zero.
//! - A leaf with cluster `-1` is *opaque*: q3map2 gives that cluster only to leaves filled by an
//!   opaque structural brush (or outside the map), the eye can never be in one and sight never
//!   passes it. Detail brushes, patches and translucent surfaces never make a leaf opaque (they
//!   do not split the tree into clusters), so they do not block sight in the [`Level`].
//! - Nodes are 36 bytes (`int32 plane`, `int32 children[2]`, `int32 mins[3], maxs[3]`), a child
//!   `c < 0` being leaf `-(c + 1)`; a point with `normal · p - dist >= 0` goes to `children[0]`.
//!   The world's tree starts at node 0 (a file without nodes is one leaf, leaf 0).
//! - Leaves are 48 bytes (`int32 cluster, area, mins[3], maxs[3]`, then leaf surface and leaf
//!   brush ranges, not decoded here); planes 16 (`float normal[3], dist`); models 40 (`float
//!   mins[3], maxs[3]`, then surface and brush ranges).

use super::lumps::invalid;
use super::{BspError, LumpEntry};
use crate::bits;
use crate::le::Rec;
use crate::level::{Contents, Leaf, Level, LevelPlane, Model, Node};
use crate::rle;
use crate::tree_check::find_cycle;

/// The four bytes that start a Quake 3 BSP (as a Quake 2 one).
pub const MAGIC: [u8; 4] = *b"IBSP";
/// The versions this module reads: Quake 3 (46) and Quake Live (47).
pub const VERSIONS: [i32; 2] = [46, 47];
/// Number of lumps.
pub const NUM_LUMPS: usize = 17;
/// Size of the header: magic, version and 17 `(offset, length)` pairs.
pub const HEADER_BYTES: usize = 8 + NUM_LUMPS * 8;
/// Bytes of the visibility lump before the rows (`numClusters`, `clusterBytes`).
pub const VIS_HEADER_BYTES: usize = 8;

const PLANE_BYTES: usize = 16;
const NODE_BYTES: usize = 36;
const LEAF_BYTES: usize = 48;
const MODEL_BYTES: usize = 40;

/// Lump indices, in header order.
pub mod lump {
    /// Entity text.
    pub const ENTITIES: usize = 0;
    /// Planes.
    pub const PLANES: usize = 2;
    /// Nodes.
    pub const NODES: usize = 3;
    /// Leaves.
    pub const LEAVES: usize = 4;
    /// Models.
    pub const MODELS: usize = 7;
    /// Visibility (`numClusters`, `clusterBytes`, rows).
    pub const VISIBILITY: usize = 16;
    /// Lump names, for messages.
    pub const NAMES: [&str; super::NUM_LUMPS] = [
        "entities",
        "shaders",
        "planes",
        "nodes",
        "leaves",
        "leafsurfaces",
        "leafbrushes",
        "models",
        "brushes",
        "brushsides",
        "drawverts",
        "drawindexes",
        "fogs",
        "surfaces",
        "lightmaps",
        "lightgrid",
        "visibility",
    ];
}

/// True when `bytes` start like a Quake 3 BSP: `IBSP` and version 46 or 47.
pub fn is_q3(bytes: &[u8]) -> bool {
    let version = bytes.get(4..8).map(|v| i32::from_le_bytes([v[0], v[1], v[2], v[3]]));
    bytes.starts_with(&MAGIC) && version.is_some_and(|v| VERSIONS.contains(&v))
}

/// Bytes of one row as q3map2 writes it for `num_clusters` clusters: a multiple of 8.
pub fn row_bytes_for(num_clusters: usize) -> usize {
    num_clusters.next_multiple_of(64) / 8
}

/// The visibility lump of a Quake 3 BSP, validated.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Q3Vis {
    /// Clusters with rows.
    pub num_clusters: usize,
    /// Bytes per row, as stored (at least `(num_clusters + 7) / 8`).
    pub cluster_bytes: usize,
    /// The rows, back to back (`num_clusters * cluster_bytes` bytes; bytes past them dropped).
    pub rows: Vec<u8>,
}

impl Q3Vis {
    /// Row `c` as stored (pad bits included); empty when `c` is not a cluster.
    pub fn row(&self, c: usize) -> &[u8] {
        let at = c.saturating_mul(self.cluster_bytes);
        self.rows.get(at..at.saturating_add(self.cluster_bytes)).unwrap_or_default()
    }

    /// Whether cluster `from` sees cluster `to`.
    pub fn sees(&self, from: usize, to: usize) -> bool {
        to < self.num_clusters && bits::bytes::get(self.row(from), to)
    }

    /// Ordered visible cluster pairs, self included (pad bits not counted).
    pub fn pairs(&self) -> u64 {
        (0..self.num_clusters).map(|c| self.visible_from(c) as u64).sum()
    }

    /// Clusters cluster `c` sees, itself included when its bit is set.
    pub fn visible_from(&self, c: usize) -> usize {
        (0..self.num_clusters).filter(|&j| bits::bytes::get(self.row(c), j)).count()
    }
}

/// A plane: `normal · p = dist`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Q3Plane {
    /// Unit normal.
    pub normal: [f32; 3],
    /// Distance from the origin.
    pub dist: f32,
}

/// A node of the world's tree.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Q3Node {
    /// Plane index.
    pub plane: u32,
    /// Front and back child (`c < 0`: leaf `-(c + 1)`).
    pub children: [i32; 2],
    /// Bounds.
    pub mins: [i32; 3],
    /// Bounds.
    pub maxs: [i32; 3],
}

/// A leaf.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Q3Leaf {
    /// Cluster (`-1`: opaque).
    pub cluster: i32,
    /// Area (for area portals).
    pub area: i32,
    /// Bounds.
    pub mins: [i32; 3],
    /// Bounds.
    pub maxs: [i32; 3],
}

/// A model's bounds (model 0 is the world).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Q3Model {
    /// Bounds.
    pub mins: [f32; 3],
    /// Bounds.
    pub maxs: [f32; 3],
}

/// A Quake 3 BSP, read as far as vis, the runtime and validation need it.
#[derive(Debug, Clone, PartialEq)]
pub struct Q3Bsp {
    /// The version field (46 or 47).
    pub version: i32,
    /// Header entries, in lump order (each inside the file).
    pub lumps: [LumpEntry; NUM_LUMPS],
    /// Entity text (up to the first NUL, lossily UTF-8).
    pub entities: String,
    /// Planes.
    pub planes: Vec<Q3Plane>,
    /// Nodes (node 0 is the world's root).
    pub nodes: Vec<Q3Node>,
    /// Leaves.
    pub leaves: Vec<Q3Leaf>,
    /// Models.
    pub models: Vec<Q3Model>,
    /// The visibility lump; `None` when it is empty (before vis).
    pub vis: Option<Q3Vis>,
}

impl Q3Bsp {
    /// Clusters the leaves name: the largest leaf cluster plus one.
    pub fn leaf_cluster_count(&self) -> usize {
        self.leaves.iter().map(|l| (l.cluster + 1).max(0) as usize).max().unwrap_or(0)
    }
}

/// Reads the header: magic, version 46 or 47 and 17 lumps inside the file.
pub fn read_header(bytes: &[u8]) -> Result<(i32, [LumpEntry; NUM_LUMPS]), BspError> {
    super::lumps::read_ibsp_header(bytes, "Quake 3", &VERSIONS, "46 or 47", &lump::NAMES)
}

/// The records of lump `index`, each with its byte offset; the length must be a multiple of
/// `size` (so the count is bounded by the bytes present).
fn records<'a>(
    bytes: &'a [u8],
    lumps: &[LumpEntry; NUM_LUMPS],
    index: usize,
    size: usize,
) -> Result<impl Iterator<Item = (usize, Rec<'a>)>, BspError> {
    super::lumps::lump_records(bytes, lumps, &lump::NAMES, index, size)
}

fn ivec3(r: &mut Rec<'_>) -> [i32; 3] {
    [r.i32(), r.i32(), r.i32()]
}

/// Parses and validates a Quake 3 BSP (see the module docs).
pub fn read(bytes: &[u8]) -> Result<Q3Bsp, BspError> {
    let (version, lumps) = read_header(bytes)?;
    let ent = lumps[lump::ENTITIES];
    let ent = bytes.get(ent.offset..ent.end()).unwrap_or_default();
    let ent = ent.split(|&b| b == 0).next().unwrap_or_default();
    let entities = String::from_utf8_lossy(ent).into_owned();

    let mut planes = Vec::new();
    for (i, (at, mut r)) in records(bytes, &lumps, lump::PLANES, PLANE_BYTES)?.enumerate() {
        let p = Q3Plane { normal: r.vec3(), dist: r.f32() };
        if !p.normal.iter().chain([&p.dist]).all(|v| v.is_finite()) {
            return Err(invalid(at, format!("plane {i}"), "non-finite value"));
        }
        planes.push(p);
    }
    let mut leaves = Vec::new();
    // Every cluster holds a leaf, so a cluster number is below the leaf count: this bounds what
    // the clusters may cost (a row each, `clusters²` bits) by the file's size.
    let leaf_count = lumps[lump::LEAVES].length / LEAF_BYTES;
    for (i, (at, mut r)) in records(bytes, &lumps, lump::LEAVES, LEAF_BYTES)?.enumerate() {
        let l = Q3Leaf { cluster: r.i32(), area: r.i32(), mins: ivec3(&mut r), maxs: ivec3(&mut r) };
        if l.cluster < -1 || i64::from(l.cluster) >= leaf_count as i64 {
            let detail = format!("cluster {} (-1, or below the {leaf_count} leaves)", l.cluster);
            return Err(invalid(at, format!("leaf {i}"), detail));
        }
        leaves.push(l);
    }
    let mut nodes = Vec::new();
    let node_count = lumps[lump::NODES].length / NODE_BYTES;
    for (i, (at, mut r)) in records(bytes, &lumps, lump::NODES, NODE_BYTES)?.enumerate() {
        let plane = r.i32();
        let children = [r.i32(), r.i32()];
        if usize::try_from(plane).is_err() || plane as usize >= planes.len() {
            return Err(invalid(at, format!("node {i}"), format!("plane {plane} of {}", planes.len())));
        }
        for c in children {
            let ok = if c >= 0 {
                (c as usize) < node_count
            } else {
                usize::try_from(-(i64::from(c) + 1)).is_ok_and(|l| l < leaves.len())
            };
            if !ok {
                return Err(invalid(
                    at + 4,
                    format!("node {i}"),
                    format!("child {c} names no node (of {node_count}) or leaf (of {})", leaves.len()),
                ));
            }
        }
        nodes.push(Q3Node { plane: plane as u32, children, mins: ivec3(&mut r), maxs: ivec3(&mut r) });
    }
    let children: Vec<[i32; 2]> = nodes.iter().map(|n| n.children).collect();
    if let Some(i) = find_cycle(&children) {
        return Err(invalid(
            lumps[lump::NODES].offset + i * NODE_BYTES,
            format!("node {i}"),
            "lies on a cycle",
        ));
    }
    if nodes.is_empty() && leaves.is_empty() {
        return Err(invalid(lumps[lump::LEAVES].offset, "leaves", "no nodes and no leaves: no world tree"));
    }
    let models: Vec<Q3Model> = records(bytes, &lumps, lump::MODELS, MODEL_BYTES)?
        .map(|(_, mut r)| Q3Model { mins: r.vec3(), maxs: r.vec3() })
        .collect();
    if models.is_empty() {
        return Err(invalid(lumps[lump::MODELS].offset, "models", "no world model"));
    }

    let vis_entry = lumps[lump::VISIBILITY];
    let vis = if vis_entry.length == 0 {
        None
    } else {
        let data = bytes.get(vis_entry.offset..vis_entry.end()).unwrap_or_default();
        Some(read_vis(data, vis_entry.offset)?)
    };
    if let Some(v) = &vis
        && let Some((i, l)) =
            leaves.iter().enumerate().find(|(_, l)| l.cluster >= 0 && l.cluster as usize >= v.num_clusters)
    {
        return Err(invalid(
            lumps[lump::LEAVES].offset + i * LEAF_BYTES,
            format!("leaf {i}"),
            format!("cluster {} >= the {} clusters of the visibility lump", l.cluster, v.num_clusters),
        ));
    }
    Ok(Q3Bsp { version, lumps, entities, planes, nodes, leaves, models, vis })
}

/// Validates a visibility lump (`data`, found at byte `at` of the file).
pub fn read_vis(data: &[u8], at: usize) -> Result<Q3Vis, BspError> {
    let what = "visibility lump";
    if data.len() < VIS_HEADER_BYTES {
        return Err(invalid(
            at,
            what,
            format!("{} bytes cannot hold numClusters and clusterBytes", data.len()),
        ));
    }
    let mut head = Rec::new(data);
    let (n, cb) = (head.i32(), head.i32());
    let Ok(num_clusters) = usize::try_from(n) else {
        return Err(invalid(at, what, format!("negative numClusters {n}")));
    };
    let Ok(cluster_bytes) = usize::try_from(cb) else {
        return Err(invalid(at + 4, what, format!("negative clusterBytes {cb}")));
    };
    if cluster_bytes < bits::bytes::len(num_clusters) {
        return Err(invalid(
            at + 4,
            what,
            format!("clusterBytes {cluster_bytes} cannot hold {num_clusters} clusters"),
        ));
    }
    let body = data.len() - VIS_HEADER_BYTES;
    let Some(size) = num_clusters.checked_mul(cluster_bytes).filter(|&s| s <= body) else {
        return Err(invalid(
            at,
            what,
            format!(
                "{num_clusters} rows of {cluster_bytes} bytes need more than the {body} bytes after the header"
            ),
        ));
    };
    let rows = data[VIS_HEADER_BYTES..VIS_HEADER_BYTES + size].to_vec();
    Ok(Q3Vis { num_clusters, cluster_bytes, rows })
}

/// A visibility lump for `num_clusters` clusters whose rows `rows` holds back to back, each
/// `(num_clusters + 7) / 8` bytes in Quake's bit order ([`crate::bits::bytes`]): the header, then
/// every row widened to [`row_bytes_for`] bytes, bits at and past `num_clusters` cleared.
pub fn vis_lump(num_clusters: usize, rows: &[u8]) -> Result<Vec<u8>, BspError> {
    let src = bits::bytes::len(num_clusters);
    if rows.len() != num_clusters * src {
        return Err(BspError::Write(format!(
            "{} bytes of rows for {num_clusters} clusters of {src} bytes",
            rows.len()
        )));
    }
    let cb = row_bytes_for(num_clusters);
    let too_big = || BspError::Write("visibility lump larger than 2 GiB".into());
    let total =
        num_clusters.checked_mul(cb).and_then(|b| b.checked_add(VIS_HEADER_BYTES)).ok_or_else(too_big)?;
    i32::try_from(total).map_err(|_| too_big())?;
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(&(num_clusters as i32).to_le_bytes());
    out.extend_from_slice(&(cb as i32).to_le_bytes());
    let mut row = vec![0u8; cb];
    let mut valid = vec![0u8; src];
    bits::bytes::fill_prefix(&mut valid, num_clusters);
    for r in rows.chunks_exact(src.max(1)).take(num_clusters) {
        row.fill(0);
        for (k, (&b, &m)) in r.iter().zip(&valid).enumerate() {
            row[k] = b & m;
        }
        out.extend_from_slice(&row);
    }
    Ok(out)
}

/// Checks that the visibility lump can be replaced (see [`super::q2::check_vis_layout`]).
pub fn check_vis_layout(lumps: &[LumpEntry; NUM_LUMPS]) -> Result<(), BspError> {
    super::lumps::check_lump_apart(lumps, lump::VISIBILITY, HEADER_BYTES, &lump::NAMES)
}

/// Returns `original` with its visibility lump replaced by `vis` (a whole lump, as [`vis_lump`]
/// makes). Lumps stored after the old visibility lump move with it, keeping 4-byte alignment;
/// every other byte is unchanged. The result is read back with [`read`] before it is returned.
pub fn write_with_visibility(original: &[u8], vis: &[u8]) -> Result<Vec<u8>, BspError> {
    let (_, lumps) = read_header(original)?;
    check_vis_layout(&lumps)?;
    let (out, _) = super::lumps::splice_lump(original, &lumps, lump::VISIBILITY, HEADER_BYTES, vis)?;
    read(&out)?;
    Ok(out)
}

/// Builds a [`Level`] from a validated Quake 3 BSP, for the runtime and validation.
///
/// - Planes, nodes and leaves map one to one (leaf `i` of the level is leaf `i` of the file);
///   the world model's head node is node 0 (leaf 0 when the file has no nodes). Bounds are the
///   stored ones where usable; [`super::bounds`] replaces the others (q3map2's leaf 0, which no
///   node names, stores `INT_MAX..INT_MIN`).
/// - Leaves with cluster `-1` are [`Contents::Solid`] (they block sight), every other leaf is
///   [`Contents::Empty`] with its cluster: brushes that do not make a leaf opaque (detail,
///   translucent, non-solid) and patches let sight through, which can only make validation find
///   more visible pairs, never fewer.
/// - `num_clusters` is the visibility lump's (else the clusters the leaves name); each row is
///   stored in Quake's RLE, `(num_clusters + 7) / 8` bytes before compression, pad bits cleared.
///   A file without a visibility lump gives a level without PVS.
/// - Only the world model is kept (brush models have no tree in Quake 3); the level has no faces,
///   no portals and no GVS cells.
pub fn to_level(bsp: &Q3Bsp) -> Level {
    let mut level = level_as_stored(bsp);
    super::bounds::repair(&mut level);
    level
}

/// [`to_level`] with the stored bounds as they are, usable or not.
pub(crate) fn level_as_stored(bsp: &Q3Bsp) -> Level {
    let planes = bsp.planes.iter().map(|p| LevelPlane { normal: p.normal, dist: p.dist }).collect();
    let f = |v: [i32; 3]| v.map(|x| x as f32);
    let nodes = bsp
        .nodes
        .iter()
        .map(|n| Node { plane: n.plane, children: n.children, mins: f(n.mins), maxs: f(n.maxs) })
        .collect();
    let leaves = bsp
        .leaves
        .iter()
        .map(|l| Leaf {
            contents: if l.cluster < 0 { Contents::Solid } else { Contents::Empty },
            cluster: l.cluster,
            mins: f(l.mins),
            maxs: f(l.maxs),
            first_face: 0,
            num_faces: 0,
        })
        .collect();
    let num_clusters = bsp.vis.as_ref().map_or(bsp.leaf_cluster_count(), |v| v.num_clusters);
    let (mut pvs_offsets, mut pvs_data) = (Vec::new(), Vec::new());
    if let Some(v) = &bsp.vis {
        let mut row = vec![0u8; bits::bytes::len(num_clusters)];
        let mut valid = vec![0u8; row.len()];
        bits::bytes::fill_prefix(&mut valid, num_clusters);
        for c in 0..num_clusters {
            for ((out, &b), &m) in row.iter_mut().zip(v.row(c)).zip(&valid) {
                *out = b & m;
            }
            pvs_offsets.push(pvs_data.len() as u32);
            rle::encode_row(&row, &mut pvs_data);
        }
    }
    let world = bsp.models.first();
    let models = vec![Model {
        head_node: if bsp.nodes.is_empty() { -1 } else { 0 },
        mins: world.map_or([0.0; 3], |m| m.mins),
        maxs: world.map_or([0.0; 3], |m| m.maxs),
        first_face: 0,
        num_faces: 0,
    }];
    Level {
        entities: bsp.entities.clone(),
        textures: Vec::new(),
        planes,
        nodes,
        leaves,
        leaf_faces: Vec::new(),
        faces: Vec::new(),
        vertices: Vec::new(),
        portals: Vec::new(),
        models,
        num_clusters: num_clusters as u32,
        pvs_offsets,
        pvs_data,
        gvs_cells: Vec::new(),
        gvs_faces: Vec::new(),
        ..Level::default()
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A minimal Quake 3 BSP: one node splitting x = 0 between leaf 1 (cluster 0, front) and leaf
    /// 2 (cluster 1, back), an opaque leaf 0, the world model, and an empty visibility lump at the
    /// entity lump's offset, as q3map2 writes it before vis.
    pub(crate) fn tiny() -> Vec<u8> {
        let mut out = vec![0u8; HEADER_BYTES];
        out[..4].copy_from_slice(&MAGIC);
        out[4..8].copy_from_slice(&46i32.to_le_bytes());
        let set = |out: &mut Vec<u8>, i: usize, o: usize, l: usize| {
            out[8 + 8 * i..12 + 8 * i].copy_from_slice(&(o as i32).to_le_bytes());
            out[12 + 8 * i..16 + 8 * i].copy_from_slice(&(l as i32).to_le_bytes());
        };
        let put =
            |out: &mut Vec<u8>, v: &[i32]| v.iter().for_each(|x| out.extend_from_slice(&x.to_le_bytes()));
        let at = out.len();
        for x in [1.0f32, 0.0, 0.0, 0.0] {
            out.extend_from_slice(&x.to_le_bytes());
        }
        set(&mut out, lump::PLANES, at, PLANE_BYTES);
        let at = out.len();
        put(&mut out, &[0, -2, -3, -64, -64, -64, 64, 64, 64]);
        set(&mut out, lump::NODES, at, NODE_BYTES);
        let at = out.len();
        for cluster in [-1, 0, 1] {
            put(&mut out, &[cluster, 0, -64, -64, -64, 64, 64, 64, 0, 0, 0, 0]);
        }
        set(&mut out, lump::LEAVES, at, 3 * LEAF_BYTES);
        let at = out.len();
        for x in [-64.0f32, -64.0, -64.0, 64.0, 64.0, 64.0] {
            out.extend_from_slice(&x.to_le_bytes());
        }
        put(&mut out, &[0, 0, 0, 0]);
        set(&mut out, lump::MODELS, at, MODEL_BYTES);
        let at = out.len();
        out.extend_from_slice(b"{\n\"classname\" \"worldspawn\"\n}\n\0");
        let len = out.len() - at;
        set(&mut out, lump::ENTITIES, at, len);
        set(&mut out, lump::VISIBILITY, at, 0);
        out
    }

    #[test]
    fn writes_reads_and_moves_the_lumps_after() {
        let original = tiny();
        let bsp = read(&original).unwrap();
        assert_eq!(bsp.leaves.iter().map(|l| l.cluster).collect::<Vec<_>>(), [-1, 0, 1]);
        assert_eq!((bsp.vis.as_ref(), bsp.leaf_cluster_count()), (None, 2));
        // Row 0 sees both, row 1 only itself; a stray pad bit (bit 2) is cleared.
        let lump = vis_lump(2, &[0b111, 0b10]).unwrap();
        assert_eq!(lump.len(), 8 + 2 * 8);
        assert_eq!(&lump[..8], &[2, 0, 0, 0, 8, 0, 0, 0]);
        assert_eq!(&lump[8..16], &[3, 0, 0, 0, 0, 0, 0, 0]);
        let out = write_with_visibility(&original, &lump).unwrap();
        let back = read(&out).unwrap();
        let v = back.vis.as_ref().unwrap();
        assert_eq!((v.num_clusters, v.cluster_bytes, v.pairs()), (2, 8, 3));
        assert!(v.sees(0, 1) && !v.sees(1, 0) && !v.sees(0, 2));
        let ents = back.lumps[lump::ENTITIES];
        assert_eq!(&out[ents.offset..ents.end()], &original[bsp.lumps[0].offset..bsp.lumps[0].end()]);
        assert_eq!(
            write_with_visibility(&out, &lump).unwrap(),
            out,
            "rewriting the same lump keeps the file"
        );

        let level = to_level(&back);
        crate::slvl::validate(&level).unwrap();
        assert_eq!(
            level.leaves.iter().map(|l| l.contents).collect::<Vec<_>>(),
            [Contents::Solid, Contents::Empty, Contents::Empty]
        );
        assert_eq!((level.num_clusters, level.pvs_offsets.len()), (2, 2));
        assert_eq!(level.pvs_stats().unwrap().map(|s| s.max_visible), Some(2));
    }

    #[test]
    fn hostile_lumps_are_refused_with_offsets() {
        let original = tiny();
        let good = write_with_visibility(&original, &vis_lump(2, &[3, 3]).unwrap()).unwrap();
        let at = read(&good).unwrap().lumps[lump::VISIBILITY].offset;
        let mut bad = good.clone();
        bad[at..at + 4].copy_from_slice(&60i32.to_le_bytes());
        assert!(
            matches!(read(&bad), Err(BspError::Invalid { offset, .. }) if offset == at),
            "rows past the lump"
        );
        bad[at..at + 4].copy_from_slice(&i32::MAX.to_le_bytes());
        assert!(matches!(read(&bad), Err(BspError::Invalid { .. })));
        let mut bad = good.clone();
        bad[at + 4..at + 8].copy_from_slice(&0i32.to_le_bytes());
        assert!(matches!(read(&bad), Err(BspError::Invalid { offset, .. }) if offset == at + 4));
        // Leaves naming more clusters than the lump has.
        assert!(matches!(
            write_with_visibility(&original, &vis_lump(1, &[1]).unwrap()),
            Err(BspError::Invalid { .. })
        ));
        let nodes = read(&good).unwrap().lumps[lump::NODES].offset;
        let mut bad = good.clone();
        bad[nodes + 4..nodes + 8].copy_from_slice(&0i32.to_le_bytes());
        assert!(matches!(read(&bad), Err(BspError::Invalid { .. })), "a node that is its own child");
        let mut bad = good.clone();
        bad[nodes + 8..nodes + 12].copy_from_slice(&(-9i32).to_le_bytes());
        assert!(matches!(read(&bad), Err(BspError::Invalid { .. })), "a child past the leaves");
        let mut bad = good.clone();
        bad[4] = 38;
        assert!(matches!(read(&bad), Err(BspError::Invalid { offset: 4, .. })));
        assert!(read(&good[..100]).is_err());
        assert!(is_q3(&good) && !is_q3(&bad) && !is_q3(b"IBSP"));
        // No world model: engines refuse the map, and so does every reader here.
        let mut bad = good.clone();
        let entry = 8 + 8 * lump::MODELS + 4;
        bad[entry..entry + 4].copy_from_slice(&0i32.to_le_bytes());
        let e = read(&bad).unwrap_err();
        assert!(e.to_string().contains("models: no world model"), "{e}");
    }

    #[test]
    fn unusable_model_bounds_are_read_and_repaired_in_the_level() {
        let mut file = tiny();
        let models = read(&file).unwrap().lumps[lump::MODELS].offset;
        file[models..models + 4].copy_from_slice(&f32::NAN.to_le_bytes());
        file[models + 12..models + 16].copy_from_slice(&f32::NEG_INFINITY.to_le_bytes());
        let bsp = read(&file).unwrap();
        assert!(bsp.models[0].mins[0].is_nan());
        let level = to_level(&bsp);
        crate::slvl::validate(&level).unwrap();
        // No faces: the map's extent (the nodes' and leaves' boxes) stands in.
        assert_eq!((level.models[0].mins, level.models[0].maxs), ([-64.0; 3], [64.0; 3]));
    }
}
