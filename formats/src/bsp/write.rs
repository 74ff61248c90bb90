//! Replacing the visibility lump of an existing BSP file.

use super::{Bsp, BspError, HEADER_BYTES, LumpEntry, NUM_LUMPS, lump, parse, read};

fn align4(x: usize) -> usize {
    x.next_multiple_of(4)
}

fn write_err(msg: impl Into<String>) -> BspError {
    BspError::Write(msg.into())
}

/// `original` with lump `index` of its lump table `lumps` replaced by `data`; the table is stored
/// right before byte `header_bytes` (the end of the header), 8 bytes per lump (offset, length),
/// as in every Quake-family BSP. Lumps stored after the old one move with it, keeping Quake's
/// 4-byte alignment (zero padding) when the old lump was padded; empty lumps after or inside it
/// stay next to its data; every other byte is unchanged. An empty lump recorded inside the header
/// (offset 0 from some compilers) gets its data appended at the end of the file, 4-aligned.
/// Returns the new file and its lump table (not read back: callers check what they wrote).
pub(crate) fn splice_lump<const N: usize>(
    original: &[u8],
    lumps: &[LumpEntry; N],
    index: usize,
    header_bytes: usize,
    data: &[u8],
) -> Result<(Vec<u8>, [LumpEntry; N]), BspError> {
    let mut old = lumps[index];
    let appended;
    let original = if old.offset < header_bytes {
        let mut padded = original.to_vec();
        padded.resize(align4(padded.len()), 0);
        old = LumpEntry { offset: padded.len(), length: 0 };
        appended = padded;
        &appended[..]
    } else {
        original
    };
    let (old_start, old_end) = (old.offset, old.end());
    // Where the bytes after the lump start: after its alignment padding when no lump starts
    // inside that padding, else right after it.
    let first_follow = lumps
        .iter()
        .enumerate()
        .filter(|&(j, l)| j != index && l.length > 0 && l.offset >= old_end)
        .map(|(_, l)| l.offset)
        .min()
        .unwrap_or(original.len());
    let padded = align4(old_end) <= first_follow;
    let (tail_old, tail_new) = if padded {
        (align4(old_end), align4(old_start + data.len()))
    } else {
        (old_end, old_start + data.len())
    };

    let mut out = Vec::with_capacity(original.len() + data.len() + 4);
    out.extend_from_slice(original.get(..old_start).unwrap_or_default());
    out.extend_from_slice(data);
    out.resize(tail_new, 0);
    out.extend_from_slice(original.get(tail_old..).unwrap_or_default());

    // Header: the new lump, then every lump that followed it moves by the same amount.
    let mut header = *lumps;
    header[index] = LumpEntry { offset: old_start, length: data.len() };
    for (j, l) in header.iter_mut().enumerate() {
        if j == index {
            continue;
        }
        if l.length > 0 && l.offset >= old_end {
            l.offset = l.offset - tail_old + tail_new;
        } else if l.length == 0 && l.offset > old_start {
            // An empty lump after or inside the old one: keep it next to the data.
            l.offset =
                if l.offset >= tail_old { l.offset - tail_old + tail_new } else { old_start + data.len() };
        }
    }
    let table_at = header_bytes - N * 8;
    for (j, l) in header.iter().enumerate() {
        let at = table_at + j * 8;
        let offset = i32::try_from(l.offset).map_err(|_| write_err("file grows beyond 2 GiB"))?;
        let length = i32::try_from(l.length).map_err(|_| write_err("lump beyond 2 GiB"))?;
        let Some(slot) = out.get_mut(at..at + 8) else {
            return Err(write_err("file shorter than its header"));
        };
        slot[..4].copy_from_slice(&offset.to_le_bytes());
        slot[4..].copy_from_slice(&length.to_le_bytes());
    }
    Ok((out, header))
}

/// Checks that lump `index` of `lumps` (a file whose header ends at byte `header_bytes`; `names`
/// names the lumps) can be replaced by [`splice_lump`]: when not empty it lies past the header and
/// shares no byte with another non-empty lump; when empty it is not strictly inside one. The
/// Quake 2 and Quake 3 visibility lumps are checked this way.
pub(crate) fn check_lump_apart<const N: usize>(
    lumps: &[LumpEntry; N],
    index: usize,
    header_bytes: usize,
    names: &[&'static str; N],
) -> Result<(), BspError> {
    let this = lumps[index];
    let overlap = |other: String, o: LumpEntry| BspError::Overlap {
        lump: names[index],
        offset: this.offset,
        end: this.end(),
        other,
        other_offset: o.offset,
        other_end: o.end(),
    };
    if this.offset < header_bytes {
        if this.length > 0 {
            return Err(overlap("the header".into(), LumpEntry { offset: 0, length: header_bytes }));
        }
        return Ok(());
    }
    for (j, l) in lumps.iter().enumerate() {
        let shares = if this.length > 0 {
            l.offset < this.end() && this.offset < l.end()
        } else {
            l.offset < this.offset && this.offset < l.end()
        };
        if j != index && l.length > 0 && shares {
            return Err(overlap(format!("lump {}", names[j]), *l));
        }
    }
    Ok(())
}

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
