//! The `.vis` file: the PVS `sightline vis` computes for a `.prt` given alone, one Quake-RLE row
//! per vis leaf.
//!
//! # Layout
//! All integers are little-endian `u32`:
//! - the 8 bytes `SLVIS001`;
//! - `leaves`, `row_bytes` (uncompressed row length, `(leaves + 7) / 8`), `data_bytes`;
//! - `leaves` offsets, one per vis leaf, each the start of that leaf's row in the data;
//! - `data_bytes` bytes of rows compressed with [`crate::rle`]. Bit `j` of leaf `i`'s row
//!   ([`crate::bits::bytes`]) is set when vis leaf `i` sees vis leaf `j`. Leaves may share a row.
//!
//! [`read`] checks every count against the bytes present before it allocates, and every offset
//! against the data; it does not decode the rows.

use thiserror::Error;

use crate::le::Rec;

/// The first 8 bytes of every `.vis` file.
pub const MAGIC: [u8; 8] = *b"SLVIS001";

/// Bytes before the offsets: the magic and three counts.
pub const HEADER_BYTES: usize = 20;

/// The content of a `.vis` file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct VisFile {
    /// Uncompressed row length in bytes.
    pub row_bytes: u32,
    /// Start of each vis leaf's row in `data`.
    pub leaf_offsets: Vec<u32>,
    /// Compressed rows back to back.
    pub data: Vec<u8>,
}

/// Why a `.vis` file could not be read or written.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[non_exhaustive]
pub enum VisFileError {
    /// The file does not start with [`MAGIC`].
    #[error("not a .vis file (no SLVIS001 magic)")]
    Magic,
    /// The file is shorter than its counts say.
    #[error("truncated .vis file: {need} bytes needed, {have} present")]
    Truncated {
        /// Bytes the header claims.
        need: u64,
        /// Bytes in the file.
        have: usize,
    },
    /// Bytes follow the data.
    #[error("{extra} bytes after the end of the .vis data")]
    Trailing {
        /// Bytes beyond the data.
        extra: usize,
    },
    /// A leaf's row starts beyond the data.
    #[error("leaf {leaf}: row offset {offset} beyond the {data_bytes} data bytes")]
    Offset {
        /// The vis leaf.
        leaf: usize,
        /// Its offset.
        offset: u32,
        /// Size of the data.
        data_bytes: usize,
    },
    /// A count does not fit the file's 32-bit fields.
    #[error("{what} ({value}) does not fit a .vis file")]
    TooLarge {
        /// Which count.
        what: &'static str,
        /// Its value.
        value: usize,
    },
}

impl VisFile {
    /// The file's bytes (see the module docs).
    pub fn to_bytes(&self) -> Result<Vec<u8>, VisFileError> {
        write(self.row_bytes as usize, &self.leaf_offsets, &self.data)
    }
}

/// The bytes of a `.vis` file with these rows (see the module docs): `row_bytes` is the
/// uncompressed row length, `leaf_offsets` the start of each vis leaf's row in `data`.
pub fn write(row_bytes: usize, leaf_offsets: &[u32], data: &[u8]) -> Result<Vec<u8>, VisFileError> {
    let count = |what, value: usize| u32::try_from(value).map_err(|_| VisFileError::TooLarge { what, value });
    let counts = [
        count("leaf count", leaf_offsets.len())?,
        count("row length", row_bytes)?,
        count("data size", data.len())?,
    ];
    let mut out = Vec::with_capacity(HEADER_BYTES + 4 * leaf_offsets.len() + data.len());
    out.extend_from_slice(&MAGIC);
    for v in counts {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for o in leaf_offsets {
        out.extend_from_slice(&o.to_le_bytes());
    }
    out.extend_from_slice(data);
    Ok(out)
}

/// Reads a `.vis` file (see the module docs for what is checked).
pub fn read(bytes: &[u8]) -> Result<VisFile, VisFileError> {
    if bytes.get(..MAGIC.len()) != Some(&MAGIC[..]) {
        return Err(VisFileError::Magic);
    }
    let truncated = |need: u64| VisFileError::Truncated { need, have: bytes.len() };
    let head = bytes.get(MAGIC.len()..HEADER_BYTES).ok_or_else(|| truncated(HEADER_BYTES as u64))?;
    let mut rec = Rec::new(head);
    let (leaves, row_bytes, data_bytes) = (rec.u32(), rec.u32(), rec.u32());
    let need = HEADER_BYTES as u64 + 4 * u64::from(leaves) + u64::from(data_bytes);
    if (bytes.len() as u64) < need {
        return Err(truncated(need));
    }
    if bytes.len() as u64 > need {
        return Err(VisFileError::Trailing { extra: (bytes.len() as u64 - need) as usize });
    }
    let (offsets, data) = bytes[HEADER_BYTES..].split_at(4 * leaves as usize);
    let leaf_offsets: Vec<u32> = offsets.chunks_exact(4).map(|b| Rec::new(b).u32()).collect();
    if let Some((leaf, &offset)) = leaf_offsets.iter().enumerate().find(|&(_, &o)| o as usize >= data.len()) {
        return Err(VisFileError::Offset { leaf, offset, data_bytes: data.len() });
    }
    Ok(VisFile { row_bytes, leaf_offsets, data: data.to_vec() })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> VisFile {
        VisFile { row_bytes: 1, leaf_offsets: vec![0, 0, 1], data: vec![0x03, 0x04] }
    }

    #[test]
    fn layout_and_round_trip() {
        let bytes = sample().to_bytes().unwrap();
        assert_eq!(&bytes[..8], b"SLVIS001");
        assert_eq!(&bytes[8..20], &[3, 0, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0]);
        assert_eq!(&bytes[20..32], &[0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0]);
        assert_eq!(&bytes[32..], &[3, 4]);
        assert_eq!(read(&bytes).unwrap(), sample());
    }

    #[test]
    fn damaged_files_are_refused() {
        let bytes = sample().to_bytes().unwrap();
        assert_eq!(read(b"SLVIS002"), Err(VisFileError::Magic));
        assert!(matches!(read(&bytes[..12]), Err(VisFileError::Truncated { .. })));
        assert!(matches!(read(&bytes[..bytes.len() - 1]), Err(VisFileError::Truncated { .. })));
        let mut long = bytes.clone();
        long.push(0);
        assert_eq!(read(&long), Err(VisFileError::Trailing { extra: 1 }));
        let mut bad = bytes.clone();
        bad[28] = 2;
        assert!(matches!(read(&bad), Err(VisFileError::Offset { leaf: 2, offset: 2, .. })));
        // A huge leaf count in a tiny file is refused before anything is allocated.
        let mut huge = bytes;
        huge[8..12].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(matches!(read(&huge), Err(VisFileError::Truncated { .. })));
    }
}
