//! The lump table every Quake-family BSP shares (an `i32` offset and length per lump after the
//! magic), read and rewritten the same way for Quake 1, Half-Life, Quake 2 and Quake 3: records of
//! a lump, the `IBSP` header, one lump spliced in while every other byte stays.

use super::{BspError, LumpEntry};
use crate::le::Rec;

/// The magic of Quake 2 and Quake 3 files.
pub const IBSP: [u8; 4] = *b"IBSP";

/// True when `bytes` start with `IBSP` (Quake 2 or Quake 3, any version).
pub fn is_ibsp(bytes: &[u8]) -> bool {
    bytes.starts_with(&IBSP)
}

/// A lump's bytes split into records of `size`, each with its byte offset in the file, for any
/// Quake-family lump table (`names` names the lumps in errors).
pub(crate) fn lump_records<'a, const N: usize>(
    bytes: &'a [u8],
    lumps: &[LumpEntry; N],
    names: &[&'static str; N],
    index: usize,
    size: usize,
) -> Result<impl Iterator<Item = (usize, Rec<'a>)> + use<'a, N>, BspError> {
    let entry = lumps[index];
    if !entry.length.is_multiple_of(size) {
        return Err(BspError::LumpSize {
            offset: entry.offset,
            name: names[index],
            length: entry.length,
            record: size,
        });
    }
    let data = bytes.get(entry.offset..entry.end()).unwrap_or_default();
    Ok(data.chunks_exact(size).enumerate().map(move |(i, chunk)| (entry.offset + i * size, Rec::new(chunk))))
}

pub(crate) fn invalid(offset: usize, what: impl Into<String>, detail: impl Into<String>) -> BspError {
    BspError::Invalid { offset, what: what.into(), detail: detail.into() }
}

/// The lump table of a Quake-family BSP header at `head`'s position: per lump an `i32` offset and
/// length, each lump inside the file (`bytes`). `names` names the lumps in errors.
/// Reads an `IBSP` header (Quake 2 and Quake 3 share its shape): the magic, a version from
/// `versions` (named as `expected` in the error), then the lump table of `names.len()` lumps,
/// each inside the file. `game` names the header in errors. Returns the version and the lumps.
pub(crate) fn read_ibsp_header<const N: usize>(
    bytes: &[u8],
    game: &str,
    versions: &[i32],
    expected: &str,
    names: &[&'static str; N],
) -> Result<(i32, [LumpEntry; N]), BspError> {
    let header_bytes = 8 + 8 * N;
    let what = format!("{game} header");
    if bytes.len() < header_bytes {
        return Err(invalid(0, what, format!("file is {} bytes, shorter than {header_bytes}", bytes.len())));
    }
    let mut head = Rec::new(bytes);
    let magic: [u8; 4] = head.take();
    if magic != *b"IBSP" {
        return Err(BspError::Version { magic });
    }
    let version = head.i32();
    if !versions.contains(&version) {
        return Err(invalid(4, what, format!("version {version}, expected {expected}")));
    }
    Ok((version, read_lump_table(bytes, &mut head, names)?))
}

pub(crate) fn read_lump_table<const N: usize>(
    bytes: &[u8],
    head: &mut Rec<'_>,
    names: &[&'static str; N],
) -> Result<[LumpEntry; N], BspError> {
    let mut lumps = [LumpEntry::default(); N];
    for (i, entry) in lumps.iter_mut().enumerate() {
        let header_offset = head.pos;
        let (offset, length) = (head.i32(), head.i32());
        let bounds_err = || BspError::LumpBounds {
            header_offset,
            lump: i,
            name: names[i],
            offset: offset.into(),
            length: length.into(),
            file_len: bytes.len(),
        };
        let (Ok(off), Ok(len)) = (usize::try_from(offset), usize::try_from(length)) else {
            return Err(bounds_err());
        };
        if off.checked_add(len).is_none_or(|end| end > bytes.len()) {
            return Err(bounds_err());
        }
        *entry = LumpEntry { offset: off, length: len };
    }
    Ok(lumps)
}

pub(crate) fn align4(x: usize) -> usize {
    x.next_multiple_of(4)
}

pub(crate) fn write_err(msg: impl Into<String>) -> BspError {
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
