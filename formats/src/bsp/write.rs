//! Replacing the visibility lump of an existing BSP file.

use super::lumps::{splice_lump, write_err};
use super::{Bsp, BspError, HEADER_BYTES, LumpEntry, NUM_LUMPS, lump, parse, read};

/// Checks that visdata can be written into a file with these lumps, as [`write_with_visdata`]
/// needs: the visibility lump (unless it is empty) lies past the header, and it shares no byte with
/// another non-empty lump (an empty visibility lump must not sit strictly inside one); the leaves
/// lump, whose records get new `visofs` and ambient levels, shares no byte with the header or
/// another non-empty lump. The error names both byte ranges. Files from BSP compilers never
/// overlap their lumps; [`super::read`] accepts overlaps, since reading does not care.
pub fn check_vis_layout(lumps: &[LumpEntry; NUM_LUMPS]) -> Result<(), BspError> {
    let overlap = |lump: usize, other: String, o: LumpEntry| BspError::Overlap {
        lump: lump::NAMES[lump],
        offset: lumps[lump].offset,
        end: lumps[lump].end(),
        other,
        other_offset: o.offset,
        other_end: o.end(),
    };
    let header = LumpEntry { offset: 0, length: HEADER_BYTES };
    let vis = lumps[lump::VISIBILITY];
    if vis.offset < HEADER_BYTES {
        // An empty visibility lump recorded in the header gets its data appended at the end.
        if vis.length > 0 {
            return Err(overlap(lump::VISIBILITY, "the header".into(), header));
        }
    } else {
        for (j, l) in lumps.iter().enumerate() {
            if j != lump::VISIBILITY && l.length > 0 && l.offset < vis.end() && vis.offset < l.end() {
                return Err(overlap(lump::VISIBILITY, format!("lump {}", lump::NAMES[j]), *l));
            }
        }
    }
    let leaves = lumps[lump::LEAVES];
    if leaves.length > 0 {
        if leaves.offset < HEADER_BYTES {
            return Err(overlap(lump::LEAVES, "the header".into(), header));
        }
        for (j, l) in lumps.iter().enumerate() {
            let apart = l.offset >= leaves.end() || leaves.offset >= l.end();
            if j != lump::LEAVES && j != lump::VISIBILITY && l.length > 0 && !apart {
                return Err(overlap(lump::LEAVES, format!("lump {}", lump::NAMES[j]), *l));
            }
        }
    }
    Ok(())
}

/// Returns `original` (which parses as `bsp`) with the visibility lump replaced by `visdata` and
/// vis leaf `j`'s row at `row_offsets[j]`: in Quake's numbering vis leaf `j` is BSP leaf `j + 1`,
/// whose `visofs` becomes that offset. Leaves without an entry in `row_offsets` (leaf 0, brush-model
/// leaves) keep their `visofs`. `ambient`, when given, holds the ambient levels of every leaf. See
/// [`write_with_visdata`] for what else changes (nothing).
pub fn write_vis_rows(
    original: &[u8],
    bsp: &Bsp,
    visdata: &[u8],
    row_offsets: &[u32],
    ambient: Option<&[[u8; 4]]>,
) -> Result<Vec<u8>, BspError> {
    let mut visofs: Vec<i32> = bsp.leaves.iter().map(|l| l.visofs).collect();
    for (j, &o) in row_offsets.iter().enumerate() {
        if let Some(slot) = visofs.get_mut(j + 1) {
            *slot = i32::try_from(o).map_err(|_| write_err("visdata larger than 2 GiB"))?;
        }
    }
    write_with_visdata(original, visdata, &visofs, ambient)
}

/// Returns `original` with lump 4 replaced by `visdata`, every leaf's `visofs` set from
/// `leaf_visofs` (one per leaf: for vis leaves `-1` or the offset of a row in `visdata`; other
/// leaves are not read by engines) and, when given, every leaf's ambient sound levels (water, sky,
/// slime, lava).
///
/// Lumps stored after the visibility lump move with it; Quake's 4-byte alignment of lump starts is
/// kept (the padding written is zero bytes). An empty visibility lump recorded inside the header
/// (offset 0) gets its new data appended at the end of the file. Every other byte of every other lump is unchanged, so
/// writing back the visdata a file already has reproduces it exactly. The result is read back
/// with [`read`] before it is returned, so a file that would not load is never produced. Lumps laid
/// out so that this cannot work are refused first ([`check_vis_layout`]).
pub fn write_with_visdata(
    original: &[u8],
    visdata: &[u8],
    leaf_visofs: &[i32],
    ambient: Option<&[[u8; 4]]>,
) -> Result<Vec<u8>, BspError> {
    let (version, lumps) = parse::read_header(original)?;
    check_vis_layout(&lumps)?;
    let leaf_bytes = version.leaf_bytes();
    let leaves = lumps[lump::LEAVES];
    if !leaves.length.is_multiple_of(leaf_bytes) {
        return Err(BspError::LumpSize {
            offset: leaves.offset,
            name: "leaves",
            length: leaves.length,
            record: leaf_bytes,
        });
    }
    let num_leaves = leaves.length / leaf_bytes;
    if leaf_visofs.len() != num_leaves {
        return Err(write_err(format!("{} visofs given for {num_leaves} leaves", leaf_visofs.len())));
    }
    if let Some(a) = ambient.filter(|a| a.len() != num_leaves) {
        return Err(write_err(format!("{} ambient levels given for {num_leaves} leaves", a.len())));
    }
    let (mut out, header) = splice_lump(original, &lumps, lump::VISIBILITY, HEADER_BYTES, visdata)?;

    let leaves_at = header[lump::LEAVES].offset;
    let ambient_at = version.leaf_ambient_offset();
    for (i, &ofs) in leaf_visofs.iter().enumerate() {
        let rec = leaves_at + i * leaf_bytes;
        out[rec + 4..rec + 8].copy_from_slice(&ofs.to_le_bytes());
        if let Some(levels) = ambient.and_then(|a| a.get(i)) {
            out[rec + ambient_at..rec + ambient_at + 4].copy_from_slice(levels);
        }
    }
    read(&out)?;
    Ok(out)
}
