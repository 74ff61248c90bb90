//! External `.vis` files that Quake engines load beside a map ("vispatch", Maddes 2001): a PVS for
//! a BSP29 map kept outside the `.bsp`, so a map can be re-vised (for example with see-through
//! water) without touching it. Quakespasm, vkQuake, QSS and Mark V read them (behind the
//! `external_vis` cvar): `maps/NAME.vis` first, then `GAMEDIR.vis` in the game folder, and take the
//! first record whose name matches the map's file name. Not to be confused with
//! [`crate::visfile`], Sightline's own `SLVIS001` file of rows for a `.prt`.
//!
//! # Layout (little-endian)
//! A file is a chain of records, each:
//! - `char map_name[32]`: the BSP's file name (`e1m1.bsp`), NUL-padded; engines compare it without
//!   regard to case;
//! - `i32 len`: the bytes of the record after this 36-byte header;
//! - `i32 vislen` and `vislen` bytes of visdata: Quake RLE rows, exactly as the BSP's visibility
//!   lump;
//! - `i32 leaflen` and `leaflen` bytes of BSP29 leaves (28 bytes each, every leaf of the file,
//!   brush-model leaves included) whose `visofs` point into that visdata.
//!
//! An engine replaces the BSP's visibility and leaf lumps with the record's and uses every other
//! lump as it is. Engines skip a non-matching record by `len + 36` bytes, stop at a record with
//! `len <= 0`, and fall back to the BSP's own visdata when `vislen <= 0`; they load records for
//! BSP29 maps only. [`read`] checks every length against the bytes that remain and every `visofs`
//! against its visdata; [`write()`] refuses what an engine could not find or use (a name of 32 bytes
//! or more, two records of one name, empty visdata, leaves that are not 28-byte records).

use crate::bits;
use crate::bsp::{self, BspError, BspVersion};
use crate::rle::{self, RleError};

/// Bytes of a record header: the map name and the record length.
pub const HEADER_BYTES: usize = 36;
/// Bytes of the map name field (the name itself is at most one less: it ends with a NUL).
pub const NAME_BYTES: usize = 32;
/// Bytes of one BSP29 leaf record.
pub const LEAF_BYTES: usize = 28;

/// One map's record.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct VisPatchRecord {
    /// The BSP's file name, `e1m1.bsp` (at most 31 bytes).
    pub map_name: String,
    /// Compressed PVS rows (the visibility lump).
    pub visdata: Vec<u8>,
    /// The leaf lump: BSP29 leaf records, `visofs` into [`VisPatchRecord::visdata`].
    pub leaves: Vec<u8>,
}

/// What is wrong with an external `.vis` file or a record to write.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum VisPatchError {
    /// Fewer than [`HEADER_BYTES`] bytes remain where a record starts.
    #[error("byte {offset}: a record header needs {HEADER_BYTES} bytes, only {remaining} remain")]
    Truncated {
        /// Where the record starts.
        offset: usize,
        /// Bytes left in the file.
        remaining: usize,
    },
    /// The name field has no terminating NUL, or is empty.
    #[error("byte {offset}: the map name is empty or not NUL-terminated within {NAME_BYTES} bytes")]
    Name {
        /// Where the name starts.
        offset: usize,
    },
    /// A length field is negative, or larger than what remains of its record or file.
    #[error("byte {offset}: {what} length {len} does not fit the {room} bytes that remain")]
    Length {
        /// Where the length field is.
        offset: usize,
        /// `"record"`, `"visdata"` or `"leaf lump"`.
        what: &'static str,
        /// The stored length.
        len: i64,
        /// Bytes available for it.
        room: usize,
    },
    /// The record's lengths do not add up to its `len`, or its leaves are not whole records.
    #[error("byte {offset}: record of `{name}`: {detail}")]
    Record {
        /// Where the record starts.
        offset: usize,
        /// Its map name.
        name: String,
        /// What is wrong.
        detail: String,
    },
    /// A leaf's `visofs` lies outside its record's visdata.
    #[error("byte {offset}: leaf {leaf} of `{name}` has visofs {visofs}, outside its {vislen}-byte visdata")]
    Visofs {
        /// Where the leaf record starts.
        offset: usize,
        /// Its map name.
        name: String,
        /// Leaf index.
        leaf: usize,
        /// The stored offset.
        visofs: i32,
        /// Length of the record's visdata.
        vislen: usize,
    },
    /// A leaf asked for is not a vis leaf of the record, or its row does not decode.
    #[error("record of `{name}`: PVS row of leaf {leaf}")]
    Row {
        /// Its map name.
        name: String,
        /// Leaf index.
        leaf: usize,
        /// Decoder error.
        source: RleError,
    },
    /// A leaf index outside `1..=visleafs`, or beyond the record's leaves, was asked for its row.
    #[error("record of `{name}`: leaf {leaf} has no PVS row ({leaves} leaves, vis leaves 1..={visleafs})")]
    NotAVisLeaf {
        /// Its map name.
        name: String,
        /// Requested leaf.
        leaf: usize,
        /// Leaves in the record.
        leaves: usize,
        /// Vis leaves asked about.
        visleafs: usize,
    },
    /// A record cannot be written as it is.
    #[error("cannot write the record of `{name}`: {detail}")]
    Write {
        /// Its map name.
        name: String,
        /// Why.
        detail: String,
    },
    /// The BSP a record was to be made from is not BSP29, the only version engines load external
    /// `.vis` records for.
    #[error("{version} file: engines load external .vis files for BSP29 maps only")]
    NotBsp29 {
        /// The BSP's version name.
        version: &'static str,
    },
    /// The BSP a record was to be made from does not read.
    #[error("invalid BSP")]
    Bsp(#[source] BspError),
}

impl VisPatchRecord {
    /// The record of a vised BSP29 file: its name, and copies of its visibility and leaf lumps.
    pub fn from_bsp29(map_name: &str, bsp_bytes: &[u8]) -> Result<Self, VisPatchError> {
        let file = bsp::read(bsp_bytes).map_err(VisPatchError::Bsp)?;
        if file.version != BspVersion::Bsp29 {
            return Err(VisPatchError::NotBsp29 { version: file.version.name() });
        }
        let lump = |i: usize| {
            let l = file.lumps[i];
            bsp_bytes.get(l.offset..l.end()).unwrap_or_default().to_vec()
        };
        Ok(Self {
            map_name: map_name.to_string(),
            visdata: lump(bsp::lump::VISIBILITY),
            leaves: lump(bsp::lump::LEAVES),
        })
    }

    /// Number of leaf records.
    pub fn num_leaves(&self) -> usize {
        self.leaves.len() / LEAF_BYTES
    }

    /// The stored `visofs` of `leaf`, when the record has that leaf.
    pub fn visofs(&self, leaf: usize) -> Option<i32> {
        let at = leaf.checked_mul(LEAF_BYTES)? + 4;
        let b = self.leaves.get(at..at + 4)?;
        Some(i32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    /// The uncompressed PVS row of `leaf` (`1..=visleafs`, `visleafs` being the map's): bit `j`
    /// means leaf `j + 1` is visible; `visofs == -1` sees every vis leaf.
    pub fn decode_row(&self, leaf: usize, visleafs: usize) -> Result<Vec<u8>, VisPatchError> {
        let not_vis = || VisPatchError::NotAVisLeaf {
            name: self.map_name.clone(),
            leaf,
            leaves: self.num_leaves(),
            visleafs,
        };
        if !(1..=visleafs).contains(&leaf) {
            return Err(not_vis());
        }
        let visofs = self.visofs(leaf).ok_or_else(not_vis)?;
        let row_bytes = bits::bytes::len(visleafs);
        let Ok(visofs) = usize::try_from(visofs) else {
            let mut row = vec![0; row_bytes];
            bits::bytes::fill_prefix(&mut row, visleafs);
            return Ok(row);
        };
        let data = self.visdata.get(visofs..).unwrap_or_default();
        rle::decode_row_vec(data, row_bytes).map_err(|source| VisPatchError::Row {
            name: self.map_name.clone(),
            leaf,
            source,
        })
    }
}

/// True when `name` can be a record's map name: 1 to 31 bytes, none of them NUL.
pub fn valid_name(name: &str) -> bool {
    !name.is_empty() && name.len() < NAME_BYTES && !name.as_bytes().contains(&0)
}

/// The first record named `map_name` (compared without regard to ASCII case, as engines do).
pub fn find<'a>(records: &'a [VisPatchRecord], map_name: &str) -> Option<&'a VisPatchRecord> {
    records.iter().find(|r| r.map_name.eq_ignore_ascii_case(map_name))
}

/// Reads a whole external `.vis` file, checking every length and `visofs` (see the module docs).
pub fn read(bytes: &[u8]) -> Result<Vec<VisPatchRecord>, VisPatchError> {
    let mut records = Vec::new();
    let mut at = 0;
    while at < bytes.len() {
        let (record, next) = read_record(bytes, at)?;
        records.push(record);
        at = next;
    }
    Ok(records)
}

/// A little-endian `i32` at `at` (the caller has checked four bytes remain).
fn i32_at(bytes: &[u8], at: usize) -> i32 {
    let b = bytes.get(at..at + 4).unwrap_or(&[0; 4]);
    i32::from_le_bytes([b[0], b[1], b[2], b[3]])
}

/// A length field at `at`, which must lie in `0..=room` (`room` counted from after the field).
fn length(bytes: &[u8], at: usize, end: usize, what: &'static str) -> Result<usize, VisPatchError> {
    let room = end.saturating_sub(at + 4);
    if at + 4 > end {
        return Err(VisPatchError::Length { offset: at, what, len: -1, room: end.saturating_sub(at) });
    }
    let len = i32_at(bytes, at);
    usize::try_from(len).ok().filter(|&l| l <= room).ok_or(VisPatchError::Length {
        offset: at,
        what,
        len: len.into(),
        room,
    })
}

/// The record starting at `at`, and where the next one starts.
fn read_record(bytes: &[u8], at: usize) -> Result<(VisPatchRecord, usize), VisPatchError> {
    let remaining = bytes.len() - at;
    if remaining < HEADER_BYTES {
        return Err(VisPatchError::Truncated { offset: at, remaining });
    }
    let name_field = &bytes[at..at + NAME_BYTES];
    let name_len = name_field.iter().position(|&b| b == 0).filter(|&n| n > 0);
    let Some(name_len) = name_len else { return Err(VisPatchError::Name { offset: at }) };
    let map_name = String::from_utf8_lossy(&name_field[..name_len]).into_owned();
    let len = i32_at(bytes, at + NAME_BYTES);
    let body = at + HEADER_BYTES;
    let end = match usize::try_from(len) {
        Ok(l) if l > 0 && l <= bytes.len() - body => body + l,
        _ => {
            return Err(VisPatchError::Length {
                offset: at + NAME_BYTES,
                what: "record",
                len: len.into(),
                room: bytes.len() - body,
            });
        }
    };
    let vislen = length(bytes, body, end, "visdata")?;
    let vis_start = body + 4;
    let leaf_field = vis_start + vislen;
    let leaflen = length(bytes, leaf_field, end, "leaf lump")?;
    let leaf_start = leaf_field + 4;
    let record_err = |detail: String| VisPatchError::Record { offset: at, name: map_name.clone(), detail };
    if leaf_start + leaflen != end {
        return Err(record_err(format!(
            "its length {len} is not 8 plus its {vislen} bytes of visdata and {leaflen} bytes of leaves"
        )));
    }
    if !leaflen.is_multiple_of(LEAF_BYTES) {
        return Err(record_err(format!(
            "its {leaflen}-byte leaf lump is not whole {LEAF_BYTES}-byte leaves"
        )));
    }
    let record = VisPatchRecord {
        map_name,
        visdata: bytes[vis_start..leaf_field].to_vec(),
        leaves: bytes[leaf_start..end].to_vec(),
    };
    for leaf in 0..record.num_leaves() {
        let visofs = record.visofs(leaf).unwrap_or(-1);
        if visofs < -1 || usize::try_from(visofs).is_ok_and(|v| v >= vislen) {
            return Err(VisPatchError::Visofs {
                offset: leaf_start + leaf * LEAF_BYTES,
                name: record.map_name.clone(),
                leaf,
                visofs,
                vislen,
            });
        }
    }
    Ok((record, end))
}

/// The file holding `records` in order. Refuses a name that is empty, holds a NUL or takes
/// [`NAME_BYTES`] bytes or more, two names equal but for ASCII case, empty visdata (engines would
/// ignore the record), leaves that are not whole records, and anything past `i32` lengths.
pub fn write(records: &[VisPatchRecord]) -> Result<Vec<u8>, VisPatchError> {
    let mut out = Vec::new();
    for (i, r) in records.iter().enumerate() {
        let fail =
            |detail: &str| VisPatchError::Write { name: r.map_name.clone(), detail: detail.to_string() };
        if !valid_name(&r.map_name) {
            return Err(fail("a map name is 1 to 31 bytes without NUL"));
        }
        if records[..i].iter().any(|o| o.map_name.eq_ignore_ascii_case(&r.map_name)) {
            return Err(fail("another record has this name (engines would only ever find the first)"));
        }
        if r.visdata.is_empty() {
            return Err(fail("its visdata is empty (engines fall back to the BSP's own)"));
        }
        if !r.leaves.len().is_multiple_of(LEAF_BYTES) {
            return Err(fail("its leaf lump is not whole 28-byte leaves"));
        }
        let len = i32::try_from(8 + r.visdata.len() + r.leaves.len())
            .map_err(|_| fail("the record does not fit a 32-bit length"))?;
        let name = r.map_name.as_bytes();
        let mut field = [0u8; NAME_BYTES];
        field[..name.len()].copy_from_slice(name);
        out.extend_from_slice(&field);
        out.extend_from_slice(&len.to_le_bytes());
        // Both fit: their sum with 8 does.
        out.extend_from_slice(&(r.visdata.len() as i32).to_le_bytes());
        out.extend_from_slice(&r.visdata);
        out.extend_from_slice(&(r.leaves.len() as i32).to_le_bytes());
        out.extend_from_slice(&r.leaves);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Leaves with these `visofs` (other fields zero).
    fn leaves(visofs: &[i32]) -> Vec<u8> {
        let mut out = Vec::new();
        for &v in visofs {
            let mut leaf = [0u8; LEAF_BYTES];
            leaf[..4].copy_from_slice(&(-1i32).to_le_bytes());
            leaf[4..8].copy_from_slice(&v.to_le_bytes());
            out.extend_from_slice(&leaf);
        }
        out
    }

    fn record(name: &str) -> VisPatchRecord {
        // Leaf 0 (solid) has no row; leaves 1 and 2 of 3 vis leaves share the row 0b101, leaf 3
        // sees everything.
        VisPatchRecord { map_name: name.into(), visdata: vec![0b101], leaves: leaves(&[-1, 0, 0, -1]) }
    }

    #[test]
    fn records_round_trip_and_rows_decode() {
        let records = vec![record("e1m1.bsp"), record("DM2.bsp")];
        let bytes = write(&records).unwrap();
        assert_eq!(bytes.len(), 2 * (HEADER_BYTES + 8 + 1 + 4 * LEAF_BYTES));
        assert_eq!(&bytes[..9], b"e1m1.bsp\0");
        assert_eq!(i32::from_le_bytes(bytes[32..36].try_into().unwrap()), 8 + 1 + 4 * 28);
        let back = read(&bytes).unwrap();
        assert_eq!(back, records);
        let dm2 = find(&back, "dm2.BSP").expect("case-insensitive");
        assert_eq!(dm2.map_name, "DM2.bsp");
        assert_eq!(dm2.decode_row(1, 3), Ok(vec![0b101]));
        assert_eq!(dm2.decode_row(3, 3), Ok(vec![0b111]));
        assert!(matches!(dm2.decode_row(0, 3), Err(VisPatchError::NotAVisLeaf { leaf: 0, .. })));
        assert!(matches!(dm2.decode_row(4, 5), Err(VisPatchError::NotAVisLeaf { leaf: 4, .. })));
        assert!(find(&back, "e1m2.bsp").is_none());
        assert_eq!(read(&[]), Ok(Vec::new()));
    }

    #[test]
    fn the_writer_refuses_what_engines_could_not_use() {
        let long = "x".repeat(NAME_BYTES);
        for bad in [
            VisPatchRecord { map_name: long, ..record("a") },
            VisPatchRecord { map_name: String::new(), ..record("a") },
            VisPatchRecord { map_name: "a\0b".into(), ..record("a") },
            VisPatchRecord { visdata: Vec::new(), ..record("a") },
            VisPatchRecord { leaves: vec![0; 27], ..record("a") },
        ] {
            assert!(matches!(write(&[bad]), Err(VisPatchError::Write { .. })));
        }
        assert!(matches!(write(&[record("a.bsp"), record("A.BSP")]), Err(VisPatchError::Write { .. })));
        assert!(write(&[record(&"x".repeat(NAME_BYTES - 1))]).is_ok());
    }

    #[test]
    fn hostile_files_are_errors_naming_the_byte() {
        let good = write(&[record("a.bsp"), record("b.bsp")]).unwrap();
        let second = good.len() / 2;
        assert_eq!(
            read(&good[..second + 10]),
            Err(VisPatchError::Truncated { offset: second, remaining: 10 })
        );
        let mut no_nul = good.clone();
        no_nul[..NAME_BYTES].fill(b'x');
        assert_eq!(read(&no_nul), Err(VisPatchError::Name { offset: 0 }));
        let mut empty_name = good.clone();
        empty_name[0] = 0;
        assert_eq!(read(&empty_name), Err(VisPatchError::Name { offset: 0 }));
        for len in [0i32, -1, i32::MAX] {
            let mut bad = good.clone();
            bad[32..36].copy_from_slice(&len.to_le_bytes());
            assert!(matches!(read(&bad), Err(VisPatchError::Length { offset: 32, what: "record", .. })));
        }
        let mut vislen = good.clone();
        vislen[36..40].copy_from_slice(&1000i32.to_le_bytes());
        assert!(matches!(read(&vislen), Err(VisPatchError::Length { offset: 36, what: "visdata", .. })));
        let mut leaflen = good.clone();
        leaflen[41..45].copy_from_slice(&27i32.to_le_bytes());
        assert!(matches!(read(&leaflen), Err(VisPatchError::Record { offset: 0, .. })));
        // Leaf 1's visofs (byte 45 + 28 + 4) past the one-byte visdata.
        let mut visofs = good.clone();
        visofs[77..81].copy_from_slice(&1i32.to_le_bytes());
        assert!(matches!(read(&visofs), Err(VisPatchError::Visofs { offset: 73, leaf: 1, visofs: 1, .. })));
        let mut negative = good.clone();
        negative[77..81].copy_from_slice(&(-2i32).to_le_bytes());
        assert!(matches!(read(&negative), Err(VisPatchError::Visofs { leaf: 1, visofs: -2, .. })));
        // A row that does not decode is an error of the row, not a panic.
        let mut run = record("a.bsp");
        run.visdata = vec![0, 9];
        let run = &read(&write(&[run]).unwrap()).unwrap()[0];
        assert!(matches!(run.decode_row(1, 3), Err(VisPatchError::Row { leaf: 1, .. })));
    }

    #[test]
    fn records_come_only_from_bsp29_files() {
        assert!(matches!(VisPatchRecord::from_bsp29("x.bsp", b"BSP2"), Err(VisPatchError::Bsp(_))));
    }
}
