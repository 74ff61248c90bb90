//! Bit rows: the one place that knows how a row of bits is laid out in memory.
//!
//! Two layouts are in use:
//! - **Word rows** (`&[u64]`, the functions at the top of this module): bit `i` is word `i / 64`,
//!   bit `i % 64`. Vis and the runtime hold their rows this way.
//! - **Byte rows** (`&[u8]`, [`bytes`]): Quake's uncompressed PVS row, bit `i` is byte `i / 8`,
//!   bit `i % 8`, least significant first. This is what [`crate::rle`] compresses. A word row's
//!   little-endian bytes are the byte row of the same bits ([`to_bytes`]).
//!
//! Setting or clearing a bit beyond the row is ignored and reading one gives `false`, so hostile
//! indices never panic.

/// Words needed for `bits` bits.
#[inline]
pub fn words(bits: usize) -> usize {
    bits.div_ceil(64)
}

/// Index of the word that holds bit `i`.
#[inline]
pub fn word_of(i: usize) -> usize {
    i >> 6
}

/// The mask of bit `i` inside its word ([`word_of`]).
#[inline]
pub fn mask(i: usize) -> u64 {
    1 << (i & 63)
}

/// The bits of word `w` that lie inside a row of `bits` bits: all ones except in
/// the last word of a row whose length is not a multiple of 64, and none beyond the row.
#[inline]
pub fn valid_mask(w: usize, bits: usize) -> u64 {
    if (w + 1) * 64 <= bits {
        u64::MAX
    } else if w * 64 >= bits {
        0
    } else {
        mask(bits) - 1
    }
}

/// Test bit `i`.
#[inline]
pub fn get(row: &[u64], i: usize) -> bool {
    row.get(word_of(i)).is_some_and(|w| w >> (i & 63) & 1 != 0)
}

/// Set bit `i` (ignored when out of range).
#[inline]
pub fn set(row: &mut [u64], i: usize) {
    if let Some(w) = row.get_mut(word_of(i)) {
        *w |= mask(i);
    }
}

/// Clear bit `i` (ignored when out of range).
#[inline]
pub fn clear(row: &mut [u64], i: usize) {
    if let Some(w) = row.get_mut(word_of(i)) {
        *w &= !mask(i);
    }
}

/// Number of set bits.
#[inline]
pub fn count(row: &[u64]) -> u64 {
    row.iter().map(|w| u64::from(w.count_ones())).sum()
}

/// Row indices of the set bits of `word`, word `w` of its row, in increasing order.
#[inline]
pub fn word_ones(w: usize, word: u64) -> impl Iterator<Item = usize> {
    let mut word = word;
    std::iter::from_fn(move || {
        if word == 0 {
            return None;
        }
        let b = word.trailing_zeros() as usize;
        word &= word - 1;
        Some(w * 64 + b)
    })
}

/// Indices of the set bits, in increasing order.
pub fn ones(row: &[u64]) -> impl Iterator<Item = usize> + '_ {
    row.iter().enumerate().flat_map(|(w, &word)| word_ones(w, word))
}

/// Replaces `out` with the first `len` bytes of `row` as a byte row (see the module docs);
/// missing bytes are zero.
pub fn to_bytes(row: &[u64], len: usize, out: &mut Vec<u8>) {
    out.clear();
    for word in row {
        out.extend_from_slice(&word.to_le_bytes());
    }
    out.resize(len, 0);
}

/// Byte rows: Quake's uncompressed PVS layout, bit `i` is byte `i / 8`, bit `i % 8`.
pub mod bytes {
    /// Bytes needed for `bits` bits.
    #[inline]
    pub fn len(bits: usize) -> usize {
        bits.div_ceil(8)
    }

    /// Test bit `i` (`false` beyond the row).
    #[inline]
    pub fn get(row: &[u8], i: usize) -> bool {
        row.get(i >> 3).is_some_and(|b| b >> (i & 7) & 1 != 0)
    }

    /// Set bit `i` (ignored beyond the row).
    #[inline]
    pub fn set(row: &mut [u8], i: usize) {
        if let Some(b) = row.get_mut(i >> 3) {
            *b |= 1 << (i & 7);
        }
    }

    /// Sets the first `bits` bits of `row` and clears the rest.
    pub fn fill_prefix(row: &mut [u8], bits: usize) {
        for (i, byte) in row.iter_mut().enumerate() {
            let n = bits.saturating_sub(i * 8).min(8);
            *byte = if n == 8 { 0xff } else { (1u16 << n).wrapping_sub(1) as u8 };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_get_count_ones() {
        let mut r = vec![0u64; words(130)];
        assert_eq!(r.len(), 3);
        for i in [0, 63, 64, 129] {
            set(&mut r, i);
        }
        set(&mut r, 1000);
        assert!(get(&r, 63) && get(&r, 129) && !get(&r, 1) && !get(&r, 1000));
        assert_eq!(count(&r), 4);
        assert_eq!(ones(&r).collect::<Vec<_>>(), vec![0, 63, 64, 129]);
        assert_eq!(word_ones(2, r[2]).collect::<Vec<_>>(), vec![129]);
        assert_eq!((word_of(129), mask(129)), (2, 2));
        clear(&mut r, 63);
        assert_eq!(count(&r), 3);
    }

    #[test]
    fn valid_mask_covers_the_row() {
        assert_eq!(valid_mask(0, 64), u64::MAX);
        assert_eq!(valid_mask(1, 130), u64::MAX);
        assert_eq!(valid_mask(2, 130), 0b11);
        assert_eq!(valid_mask(0, 5), 0b1_1111);
        assert_eq!(valid_mask(3, 130), 0, "beyond the row");
        assert_eq!(valid_mask(2, 128), 0);
    }

    #[test]
    fn byte_rows_match_word_rows() {
        let mut w = vec![0u64; words(70)];
        let mut b = vec![0u8; bytes::len(70)];
        for i in [0, 7, 8, 63, 64, 69] {
            set(&mut w, i);
            bytes::set(&mut b, i);
        }
        bytes::set(&mut b, 1000);
        let mut conv = Vec::new();
        to_bytes(&w, bytes::len(70), &mut conv);
        assert_eq!(conv, b);
        assert!((0..80).all(|i| bytes::get(&b, i) == get(&w, i)));
        let mut row = [0u8; 3];
        bytes::fill_prefix(&mut row, 10);
        assert_eq!(row, [0xff, 0x03, 0]);
        bytes::fill_prefix(&mut row, 24);
        assert_eq!(row, [0xff; 3]);
    }
}
