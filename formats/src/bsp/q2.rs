//! Quake 2 BSP files (`IBSP`, version 38).
//!
//! [`read`] checks the header and every lump against the file, decodes and checks every lump a
//! level needs ([`to_level`]: planes and vertices finite, every index in range, the node graph
//! acyclic, a world model), so vis, `info`, `validate` and the runtime take and refuse the same
//! files; it reads each leaf's `cluster` and validates the visibility lump (`dvis_t`:
//! `numclusters`, then a PVS and a PHS offset per
//! cluster, measured from the start of the lump, then the rows in Quake's zero-run RLE): every
//! count is checked against the bytes before anything is allocated, every offset must lie in the
//! lump and every row must decode. [`vis_lump`] lays out a new visibility lump (all PVS rows, then
//! all PHS rows, as q2tools and ericw-tools write them) and [`write_with_visibility`] puts it into
//! a file, keeping every other byte, and reads the result back.
//!
//! # Conventions (Quake 2's)
//! - Row `c` belongs to cluster `c`; bit `j` (byte `j >> 3`, bit `j & 7`) means cluster `j`, with
//!   no shift. Rows have `(numclusters + 7) / 8` bytes.
//! - A leaf with cluster `-1` (solid) has no row. Leaves are 28-byte records: `int32 contents`,
//!   `int16 cluster`, `int16 area`, bounds and indices (not decoded here).

use super::lumps::invalid;
use super::{BspError, LumpEntry};

mod level;
use crate::bits;
use crate::le::Rec;
use crate::rle;
pub(crate) use level::level_as_stored;
pub use level::{contents, to_level};

/// The four bytes that start a Quake 2 BSP.
pub const MAGIC: [u8; 4] = *b"IBSP";
/// The version this module reads.
pub const VERSION: i32 = 38;
/// Number of lumps.
pub const NUM_LUMPS: usize = 19;
/// Size of the header: magic, version and 19 `(offset, length)` pairs.
pub const HEADER_BYTES: usize = 8 + NUM_LUMPS * 8;
/// Bytes of one leaf record.
pub const LEAF_BYTES: usize = 28;

/// Lump indices, in header order.
pub mod lump {
    /// Visibility (`dvis_t`).
    pub const VISIBILITY: usize = 3;
    /// Leaves.
    pub const LEAVES: usize = 8;
    /// Lump names, for messages.
    pub const NAMES: [&str; super::NUM_LUMPS] = [
        "entities",
        "planes",
        "vertices",
        "visibility",
        "nodes",
        "texinfo",
        "faces",
        "lighting",
        "leaves",
        "leaffaces",
        "leafbrushes",
        "edges",
        "surfedges",
        "models",
        "brushes",
        "brushsides",
        "pop",
        "areas",
        "areaportals",
    ];
}

/// True when `bytes` start like a Quake 2 BSP (`IBSP`, any version).
pub fn is_q2(bytes: &[u8]) -> bool {
    bytes.starts_with(&MAGIC)
}

/// The visibility lump of a Quake 2 BSP, validated.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Q2Vis {
    /// Clusters with rows.
    pub num_clusters: usize,
    /// Per cluster, the PVS and PHS row offsets from the start of the lump.
    pub offsets: Vec<[u32; 2]>,
    /// The whole lump, header included.
    pub data: Vec<u8>,
}

/// Which row of a cluster.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Q2Row {
    /// Potentially visible set.
    Pvs = 0,
    /// Potentially hearable set.
    Phs = 1,
}

impl Q2Row {
    /// `"PVS"` or `"PHS"`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Pvs => "PVS",
            Self::Phs => "PHS",
        }
    }
}

impl Q2Vis {
    /// Bytes of one uncompressed row.
    pub fn row_bytes(&self) -> usize {
        bits::bytes::len(self.num_clusters)
    }

    /// The compressed bytes of row `which` of cluster `c` (exactly the bytes the decoder reads).
    pub fn compressed_row(&self, c: usize, which: Q2Row) -> Option<&[u8]> {
        let at = *self.offsets.get(c)?.get(which as usize)? as usize;
        let data = self.data.get(at..)?;
        let mut scratch = vec![0; self.row_bytes()];
        let used = rle::decode_row(data, self.row_bytes(), &mut scratch).ok()?;
        data.get(..used)
    }

    /// Decodes row `which` of cluster `c` into `out` (at least [`Q2Vis::row_bytes`] long). Error
    /// offsets are from the start of the lump.
    pub fn decode_into(&self, c: usize, which: Q2Row, out: &mut [u8]) -> Result<(), BspError> {
        let Some(&pair) = self.offsets.get(c) else {
            return Err(BspError::Write(format!("cluster {c} has no row ({} clusters)", self.num_clusters)));
        };
        let at = pair[which as usize] as usize;
        let data = self.data.get(at..).unwrap_or_default();
        rle::decode_row(data, self.row_bytes(), out).map(|_| ()).map_err(|source| BspError::Row {
            offset: at,
            leaf: c,
            source,
        })
    }

    /// Ordered cluster pairs `(c, j)` with bit `j` set in row `which` of `c`: the bits of every
    /// row, decoded one at a time.
    pub fn pairs(&self, which: Q2Row) -> Result<u64, BspError> {
        let mut row = vec![0; self.row_bytes()];
        let mut total = 0;
        for c in 0..self.num_clusters {
            self.decode_into(c, which, &mut row)?;
            total += rle::count_bits(&row) as u64;
        }
        Ok(total)
    }

    /// Every row `which` decoded, back to back: allocates `num_clusters * row_bytes` bytes, which
    /// the lump's size does not bound (engines decompress one row at a time).
    pub fn decode_all(&self, which: Q2Row) -> Result<Vec<u8>, BspError> {
        let rb = self.row_bytes();
        let mut out = vec![0; self.num_clusters * rb];
        for (c, row) in out.chunks_exact_mut(rb.max(1)).enumerate().take(self.num_clusters) {
            self.decode_into(c, which, row)?;
        }
        Ok(out)
    }
}

/// A Quake 2 BSP, read and checked (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Q2Bsp {
    /// Header entries, in lump order (each inside the file).
    pub lumps: [LumpEntry; NUM_LUMPS],
    /// Each leaf's cluster (`-1`: no cluster).
    pub leaf_clusters: Vec<i32>,
    /// The visibility lump; `None` when it is empty (before vis).
    pub vis: Option<Q2Vis>,
    /// The other lumps, for [`to_level`].
    geometry: level::Geometry,
}

impl Q2Bsp {
    /// Clusters the leaves name: the largest leaf cluster plus one.
    pub fn leaf_cluster_count(&self) -> usize {
        level::cluster_count(&self.leaf_clusters)
    }
}

/// Reads the header: magic, version 38 and 19 lumps inside the file.
pub fn read_header(bytes: &[u8]) -> Result<[LumpEntry; NUM_LUMPS], BspError> {
    let (_, lumps) = super::lumps::read_ibsp_header(bytes, "Quake 2", &[VERSION], "38", &lump::NAMES)?;
    Ok(lumps)
}

/// Parses and validates a Quake 2 BSP (see the module docs).
pub fn read(bytes: &[u8]) -> Result<Q2Bsp, BspError> {
    let lumps = read_header(bytes)?;
    let mut leaf_clusters = Vec::new();
    for (i, (at, mut r)) in
        super::lumps::lump_records(bytes, &lumps, &lump::NAMES, lump::LEAVES, LEAF_BYTES)?.enumerate()
    {
        let _contents = r.i32();
        let c = i32::from(r.i16());
        if c < -1 {
            return Err(invalid(at + 4, format!("leaf {i}"), format!("cluster {c}")));
        }
        leaf_clusters.push(c);
    }
    let vis_entry = lumps[lump::VISIBILITY];
    let vis = if vis_entry.length == 0 {
        None
    } else {
        let data = bytes.get(vis_entry.offset..vis_entry.end()).unwrap_or_default();
        Some(read_vis(data, vis_entry.offset)?)
    };
    if let Some(v) = &vis
        && let Some((i, &c)) =
            leaf_clusters.iter().enumerate().find(|&(_, &c)| c >= 0 && c as usize >= v.num_clusters)
    {
        return Err(invalid(
            lumps[lump::LEAVES].offset + i * LEAF_BYTES + 4,
            format!("leaf {i}"),
            format!("cluster {c} >= the {} clusters of the visibility lump", v.num_clusters),
        ));
    }
    let geometry = level::read_geometry(bytes, &lumps, &leaf_clusters, vis.as_ref())?;
    Ok(Q2Bsp { lumps, leaf_clusters, vis, geometry })
}

/// Validates a visibility lump (`data`, found at byte `at` of the file).
pub fn read_vis(data: &[u8], at: usize) -> Result<Q2Vis, BspError> {
    let what = "visibility lump";
    if data.len() < 4 {
        return Err(invalid(at, what, format!("{} bytes cannot hold numclusters", data.len())));
    }
    let n = i32::from_le_bytes([data[0], data[1], data[2], data[3]]);
    let Ok(num_clusters) = usize::try_from(n) else {
        return Err(invalid(at, what, format!("negative numclusters {n}")));
    };
    let header = num_clusters.checked_mul(8).and_then(|b| b.checked_add(4));
    let Some(header) = header.filter(|&h| h <= data.len()) else {
        return Err(invalid(
            at,
            what,
            format!("{num_clusters} clusters need more than the {} bytes", data.len()),
        ));
    };
    let offsets: Vec<[u32; 2]> = data[4..header]
        .chunks_exact(8)
        .map(|p| {
            let mut r = Rec::new(p);
            [r.u32(), r.u32()]
        })
        .collect();
    let row_bytes = bits::bytes::len(num_clusters);
    let mut scratch = vec![0; row_bytes];
    for (c, pair) in offsets.iter().enumerate() {
        for (k, &o) in pair.iter().enumerate() {
            let field = at + 4 + 8 * c + 4 * k;
            let name = if k == 0 { "PVS" } else { "PHS" };
            let o = o as usize;
            if o >= data.len() && row_bytes > 0 {
                return Err(invalid(
                    field,
                    format!("cluster {c}"),
                    format!("{name} offset {o} outside the {}-byte lump", data.len()),
                ));
            }
            let row = data.get(o..).unwrap_or_default();
            rle::decode_row(row, row_bytes, &mut scratch).map_err(|source| BspError::Row {
                offset: at + o,
                leaf: c,
                source,
            })?;
        }
    }
    Ok(Q2Vis { num_clusters, offsets, data: data.to_vec() })
}

/// A visibility lump from compressed rows: `numclusters`, the offsets, every PVS row, then every
/// PHS row (no sharing), as q2tools and ericw-tools lay it out. `pvs` and `phs` hold one
/// compressed row per cluster.
pub fn vis_lump<P: AsRef<[u8]>, H: AsRef<[u8]>>(pvs: &[P], phs: &[H]) -> Result<Vec<u8>, BspError> {
    if pvs.len() != phs.len() {
        return Err(BspError::Write(format!("{} PVS rows but {} PHS rows", pvs.len(), phs.len())));
    }
    let n = pvs.len();
    let too_big = || BspError::Write("visibility lump larger than 2 GiB".into());
    let mut out = Vec::new();
    out.extend_from_slice(&i32::try_from(n).map_err(|_| too_big())?.to_le_bytes());
    out.resize(4 + 8 * n, 0);
    let mut body = Vec::new();
    let mut put = |c: usize, k: usize, row: &[u8], out: &mut Vec<u8>| -> Result<(), BspError> {
        let ofs = i32::try_from(4 + 8 * n + body.len()).map_err(|_| too_big())?;
        out[4 + 8 * c + 4 * k..8 + 8 * c + 4 * k].copy_from_slice(&ofs.to_le_bytes());
        body.extend_from_slice(row);
        Ok(())
    };
    for (c, row) in pvs.iter().enumerate() {
        put(c, 0, row.as_ref(), &mut out)?;
    }
    for (c, row) in phs.iter().enumerate() {
        put(c, 1, row.as_ref(), &mut out)?;
    }
    out.extend_from_slice(&body);
    i32::try_from(out.len()).map_err(|_| too_big())?;
    Ok(out)
}

/// Checks that the visibility lump can be replaced: when not empty it lies past the header and
/// shares no byte with another non-empty lump; when empty it is not strictly inside one.
pub fn check_vis_layout(lumps: &[LumpEntry; NUM_LUMPS]) -> Result<(), BspError> {
    super::lumps::check_lump_apart(lumps, lump::VISIBILITY, HEADER_BYTES, &lump::NAMES)
}

/// Returns `original` with its visibility lump replaced by `vis` (a whole lump, as [`vis_lump`]
/// makes). Lumps stored after the old visibility lump move with it, keeping 4-byte alignment
/// (zero padding); every other byte is unchanged. An empty visibility lump recorded inside the
/// header gets its data appended at the end of the file. The result is read back with [`read`]
/// before it is returned.
pub fn write_with_visibility(original: &[u8], vis: &[u8]) -> Result<Vec<u8>, BspError> {
    let lumps = read_header(original)?;
    check_vis_layout(&lumps)?;
    let (out, _) = super::lumps::splice_lump(original, &lumps, lump::VISIBILITY, HEADER_BYTES, vis)?;
    read(&out)?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A minimal Quake 2 BSP: three leaves (clusters -1, 0, 1), the world model (leaf 0, no
    /// nodes), an entity lump after an empty visibility lump at the same offset, as ericw's qbsp
    /// writes it.
    pub(crate) fn tiny() -> Vec<u8> {
        let mut out = vec![0u8; HEADER_BYTES];
        out[..4].copy_from_slice(&MAGIC);
        out[4..8].copy_from_slice(&VERSION.to_le_bytes());
        let set = |out: &mut Vec<u8>, i: usize, o: usize, l: usize| {
            out[8 + 8 * i..12 + 8 * i].copy_from_slice(&(o as i32).to_le_bytes());
            out[12 + 8 * i..16 + 8 * i].copy_from_slice(&(l as i32).to_le_bytes());
        };
        let leaves_at = out.len();
        for c in [-1i16, 0, 1] {
            let mut rec = [0u8; LEAF_BYTES];
            rec[4..6].copy_from_slice(&c.to_le_bytes());
            out.extend_from_slice(&rec);
        }
        set(&mut out, lump::LEAVES, leaves_at, 3 * LEAF_BYTES);
        let models_at = out.len();
        out.extend_from_slice(&[0u8; 36]);
        for v in [-1i32, 0, 0] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        set(&mut out, 13, models_at, 48);
        let ents_at = out.len();
        out.extend_from_slice(b"{\n\"classname\" \"worldspawn\"\n}\n\0");
        let ents_len = out.len() - ents_at;
        set(&mut out, 0, ents_at, ents_len);
        set(&mut out, lump::VISIBILITY, ents_at, 0);
        out
    }

    #[test]
    fn writes_reads_and_moves_the_lumps_after() {
        let original = tiny();
        let bsp = read(&original).unwrap();
        assert_eq!(bsp.leaf_clusters, [-1, 0, 1]);
        assert_eq!((bsp.vis.as_ref(), bsp.leaf_cluster_count()), (None, 2));
        let vis = vis_lump(&[[1u8], [3]], &[[3u8], [3]]).unwrap();
        assert_eq!(vis.len(), 4 + 16 + 4);
        let out = write_with_visibility(&original, &vis).unwrap();
        let back = read(&out).unwrap();
        let v = back.vis.unwrap();
        assert_eq!(v.offsets, [[20, 22], [21, 23]]);
        assert_eq!(v.decode_all(Q2Row::Pvs).unwrap(), [1, 3]);
        assert_eq!(v.decode_all(Q2Row::Phs).unwrap(), [3, 3]);
        assert_eq!(v.compressed_row(1, Q2Row::Phs), Some(&[3u8][..]));
        let ents = back.lumps[0];
        assert_eq!(ents.offset % 4, 0);
        assert_eq!(&out[ents.offset..ents.end()], &original[bsp.lumps[0].offset..bsp.lumps[0].end()]);
        assert_eq!(&out[..8], &original[..8]);
        // Writing the same lump again keeps the file.
        assert_eq!(write_with_visibility(&out, &vis).unwrap(), out);
    }

    #[test]
    fn hostile_lumps_are_refused_with_offsets() {
        let original = tiny();
        let vis = vis_lump(&[[1u8], [3]], &[[3u8], [3]]).unwrap();
        let good = write_with_visibility(&original, &vis).unwrap();
        let at = read(&good).unwrap().lumps[lump::VISIBILITY].offset;
        let mut bad = good.clone();
        bad[at..at + 4].copy_from_slice(&i32::MAX.to_le_bytes());
        assert!(matches!(read(&bad), Err(BspError::Invalid { offset, .. }) if offset == at));
        let mut bad = good.clone();
        bad[at + 4..at + 8].copy_from_slice(&500u32.to_le_bytes());
        assert!(matches!(read(&bad), Err(BspError::Invalid { offset, .. }) if offset == at + 4));
        // Two clusters named by the leaves, one in the lump.
        let one = write_with_visibility(&original, &vis_lump(&[[1u8]], &[[1u8]]).unwrap());
        assert!(matches!(one, Err(BspError::Invalid { .. })));
        let mut bad = good.clone();
        bad[4] = 39;
        assert!(matches!(read(&bad), Err(BspError::Invalid { offset: 4, .. })));
        assert!(read(&good[..100]).is_err());
    }
}
