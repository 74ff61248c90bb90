//! Quake's zero-run compression of PVS rows.
//!
//! A non-zero byte is copied as it is; a run of `n` zero bytes (`1..=255`, longer runs are split)
//! is written as the two bytes `0, n`. Rows are compressed independently, so any row decodes alone
//! in `O(row)` time. Decoding stops as soon as the row is full, so rows can be stored back to back
//! (or share storage, as Quake's leaves of one cluster do) without any length prefix.
//!
//! This is the only decoder in Sightline: [`decode_row`] writes a byte row, [`decode_row_words`]
//! a [`crate::bits`] word row (what the runtime holds, without a byte buffer in between), and
//! [`decode_row_vec`] allocates the byte row.

use thiserror::Error;

/// Why a compressed row could not be decoded.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[non_exhaustive]
pub enum RleError {
    /// The input ended before the row was full.
    #[error("compressed PVS row truncated at byte {offset}: {decoded} of {row_bytes} bytes decoded")]
    Truncated {
        /// Offset in the input where more bytes were needed.
        offset: usize,
        /// Bytes of the row produced so far.
        decoded: usize,
        /// Bytes the row should have.
        row_bytes: usize,
    },
    /// A zero run reaches past the end of the row.
    #[error(
        "zero run of {run} bytes at byte {offset} overflows the row ({decoded} of {row_bytes} bytes decoded)"
    )]
    RunOverflow {
        /// Offset in the input of the run's leading zero.
        offset: usize,
        /// Run length.
        run: usize,
        /// Bytes of the row produced before the run.
        decoded: usize,
        /// Bytes the row should have.
        row_bytes: usize,
    },
    /// The output buffer is shorter than the requested row.
    #[error("output buffer of {len} bytes is shorter than the row ({row_bytes} bytes)")]
    OutputTooSmall {
        /// Length of the output buffer.
        len: usize,
        /// Bytes the row should have.
        row_bytes: usize,
    },
}

/// Appends the compressed form of `bits` (one uncompressed row) to `out`.
pub fn encode_row(bits: &[u8], out: &mut Vec<u8>) {
    let mut i = 0;
    while i < bits.len() {
        let byte = bits[i];
        if byte != 0 {
            out.push(byte);
            i += 1;
            continue;
        }
        let run = bits[i..].iter().take(255).take_while(|&&b| b == 0).count();
        // `run` is in 1..=255 because bits[i] == 0 and at most 255 were taken.
        out.push(0);
        out.push(run as u8);
        i += run;
    }
}

/// Decodes one row of `row_bytes` bytes from the start of `data` into `out[..row_bytes]` and
/// returns how many bytes of `data` it consumed.
///
/// A `0, 0` pair (an empty run, which no encoder writes but Quake engines accept) is skipped.
pub fn decode_row(data: &[u8], row_bytes: usize, out: &mut [u8]) -> Result<usize, RleError> {
    let Some(row) = out.get_mut(..row_bytes) else {
        return Err(RleError::OutputTooSmall { len: out.len(), row_bytes });
    };
    row.fill(0);
    decode_nonzero(data, row_bytes, |at, byte| {
        if let Some(b) = row.get_mut(at) {
            *b = byte;
        }
    })
}

/// Decodes one row of `row_bytes` bytes from the start of `data` straight into a word row (the
/// [`crate::bits`] layout: the row's byte `j` is bits `8 * (j % 8)..` of word `j / 8`, so the
/// words' little-endian bytes are the decoded row) and returns how many bytes of `data` it
/// consumed. The `row_bytes.div_ceil(8)` words of the row are overwritten; `out` may be longer.
/// Allocates nothing; the same rules and errors as [`decode_row`] (lengths in
/// [`RleError::OutputTooSmall`] are in bytes).
#[inline]
pub fn decode_row_words(data: &[u8], row_bytes: usize, out: &mut [u64]) -> Result<usize, RleError> {
    let Some(row) = out.get_mut(..row_bytes.div_ceil(8)) else {
        return Err(RleError::OutputTooSmall { len: out.len().saturating_mul(8), row_bytes });
    };
    row.fill(0);
    decode_nonzero(data, row_bytes, |at, byte| {
        if let Some(w) = row.get_mut(at >> 3) {
            *w |= u64::from(byte) << ((at & 7) * 8);
        }
    })
}

/// The decoder: calls `put(j, byte)` for each non-zero byte `j` of the row, in order (zero runs
/// are skipped, so the caller clears the row first), and returns the bytes of `data` consumed.
#[inline(always)]
fn decode_nonzero(data: &[u8], row_bytes: usize, mut put: impl FnMut(usize, u8)) -> Result<usize, RleError> {
    let mut pos = 0;
    let mut filled = 0;
    while filled < row_bytes {
        let Some(&byte) = data.get(pos) else {
            return Err(RleError::Truncated { offset: pos, decoded: filled, row_bytes });
        };
        if byte != 0 {
            put(filled, byte);
            filled += 1;
            pos += 1;
            continue;
        }
        let Some(&run) = data.get(pos + 1) else {
            return Err(RleError::Truncated { offset: pos + 1, decoded: filled, row_bytes });
        };
        let run = usize::from(run);
        if run > row_bytes - filled {
            return Err(RleError::RunOverflow { offset: pos, run, decoded: filled, row_bytes });
        }
        filled += run;
        pos += 2;
    }
    Ok(pos)
}

/// Decodes one row into a new vector of `row_bytes` bytes.
pub fn decode_row_vec(data: &[u8], row_bytes: usize) -> Result<Vec<u8>, RleError> {
    // Each input byte yields at most 255 output bytes: refuse early rather than allocate a row
    // the input cannot fill.
    if row_bytes > data.len().saturating_mul(255) {
        return Err(RleError::Truncated { offset: data.len(), decoded: 0, row_bytes });
    }
    let mut row = vec![0; row_bytes];
    decode_row(data, row_bytes, &mut row)?;
    Ok(row)
}

/// Number of set bits in an uncompressed row.
pub fn count_bits(row: &[u8]) -> usize {
    row.iter().map(|b| b.count_ones() as usize).sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn encodes_runs_and_literals() {
        let mut out = Vec::new();
        encode_row(&[0, 0, 0, 5, 0, 7], &mut out);
        assert_eq!(out, [0, 3, 5, 0, 1, 7]);
    }

    #[test]
    fn splits_long_runs() {
        let mut out = Vec::new();
        encode_row(&[0; 600], &mut out);
        assert_eq!(out, [0, 255, 0, 255, 0, 90]);
    }

    #[test]
    fn rejects_truncation_and_overflow() {
        let mut row = [0u8; 4];
        assert!(matches!(decode_row(&[1, 2], 4, &mut row), Err(RleError::Truncated { offset: 2, .. })));
        assert!(matches!(decode_row(&[1, 0], 4, &mut row), Err(RleError::Truncated { offset: 2, .. })));
        assert!(matches!(decode_row(&[1, 0, 4], 4, &mut row), Err(RleError::RunOverflow { offset: 1, .. })));
        assert!(matches!(decode_row(&[1], 4, &mut [0u8; 2]), Err(RleError::OutputTooSmall { .. })));
        assert!(matches!(decode_row_words(&[1], 9, &mut [0u64; 1]), Err(RleError::OutputTooSmall { .. })));
        assert!(matches!(
            decode_row_words(&[1, 0], 4, &mut [0u64; 1]),
            Err(RleError::Truncated { offset: 2, .. })
        ));
        assert!(decode_row_vec(&[0], 1000).is_err());
    }

    #[test]
    fn stops_when_row_is_full() {
        let mut row = [9u8; 3];
        assert_eq!(decode_row(&[0, 0, 1, 0, 2, 0xff, 0xff], 3, &mut row), Ok(5));
        assert_eq!(row, [1, 0, 0]);
        assert_eq!(decode_row(&[], 0, &mut row), Ok(0));
    }

    fn rows() -> impl Strategy<Value = Vec<u8>> {
        prop_oneof![
            // Sparse: mostly zero bytes, long runs.
            prop::collection::vec(prop_oneof![9 => Just(0u8), 1 => any::<u8>()], 0..2000),
            // Dense: any byte.
            prop::collection::vec(any::<u8>(), 0..600),
        ]
    }

    proptest! {
        #[test]
        fn round_trip(bits in rows(), tail in prop::collection::vec(any::<u8>(), 0..8)) {
            let mut packed = Vec::new();
            encode_row(&bits, &mut packed);
            let used = packed.len();
            packed.extend_from_slice(&tail);
            let mut out = vec![0xAA; bits.len() + 3];
            prop_assert_eq!(decode_row(&packed, bits.len(), &mut out), Ok(used));
            prop_assert_eq!(&out[..bits.len()], &bits[..]);
            prop_assert_eq!(decode_row_vec(&packed, bits.len()), Ok(bits.clone()));
            let mut words = vec![u64::MAX; bits.len().div_ceil(8) + 1];
            prop_assert_eq!(decode_row_words(&packed, bits.len(), &mut words), Ok(used));
            let mut bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
            bytes.truncate(bits.len());
            prop_assert_eq!(&bytes, &bits);
            prop_assert_eq!(words.last().copied(), Some(u64::MAX));
            let zero_runs_ok = packed[..used].windows(2).all(|w| w[0] != 0 || w[1] != 0);
            prop_assert!(zero_runs_ok);
        }

        #[test]
        fn never_panics(data in prop::collection::vec(any::<u8>(), 0..64), row in 0usize..100) {
            let mut out = vec![0; row];
            let bytes = decode_row(&data, row, &mut out);
            if let Ok(used) = bytes {
                prop_assert!(used <= data.len());
            }
            let mut words = vec![0; row.div_ceil(8)];
            prop_assert_eq!(decode_row_words(&data, row, &mut words), bytes);
        }
    }
}
