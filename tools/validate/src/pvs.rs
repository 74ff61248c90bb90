//! Square bit matrices over clusters, and the level's PVS decoded into one.
//!
//! Bit `(a, b)` set means "cluster `a` sees cluster `b`".

use sightline_formats::{Level, bits, rle};

use crate::ValidateError;

/// An `n × n` bit matrix stored row-major in 64-bit words.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BitMatrix {
    n: usize,
    words: usize,
    bits: Vec<u64>,
}

impl BitMatrix {
    /// All clear.
    pub fn new(n: usize) -> Self {
        let words = bits::words(n);
        Self { n, words, bits: vec![0; words * n] }
    }

    /// Side length.
    pub fn len(&self) -> usize {
        self.n
    }

    /// True for a 0 × 0 matrix.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Bit `(a, b)`; false out of range.
    #[inline]
    pub fn get(&self, a: usize, b: usize) -> bool {
        a < self.n && b < self.n && self.bits[a * self.words + bits::word_of(b)] & bits::mask(b) != 0
    }

    /// Set bit `(a, b)` (ignored out of range); true when it was clear.
    #[inline]
    pub fn set(&mut self, a: usize, b: usize) -> bool {
        if a >= self.n || b >= self.n {
            return false;
        }
        let w = &mut self.bits[a * self.words + bits::word_of(b)];
        let mask = bits::mask(b);
        let was = *w & mask != 0;
        *w |= mask;
        !was
    }

    /// Clear bit `(a, b)` (ignored out of range).
    pub fn clear(&mut self, a: usize, b: usize) {
        if a < self.n && b < self.n {
            self.bits[a * self.words + bits::word_of(b)] &= !bits::mask(b);
        }
    }

    /// Set bits in row `a`.
    pub fn row_count(&self, a: usize) -> u64 {
        self.bits
            .get(a * self.words..(a + 1) * self.words)
            .map_or(0, |row| row.iter().map(|w| u64::from(w.count_ones())).sum())
    }

    /// Set bits in the whole matrix.
    pub fn count(&self) -> u64 {
        self.bits.iter().map(|w| u64::from(w.count_ones())).sum()
    }

    /// Set bits of `self` that are clear in `other`.
    pub fn count_not_in(&self, other: &BitMatrix) -> u64 {
        self.bits.iter().zip(&other.bits).map(|(x, y)| u64::from((x & !y).count_ones())).sum()
    }
}

/// The level's PVS as a cluster matrix; a level without vis sees everything.
pub fn level_pvs(level: &Level) -> Result<BitMatrix, ValidateError> {
    let n = level.num_clusters as usize;
    let mut m = BitMatrix::new(n);
    if !level.has_vis() {
        for a in 0..n {
            for b in 0..n {
                m.set(a, b);
            }
        }
        return Ok(m);
    }
    if level.pvs_offsets.len() != n {
        return Err(ValidateError::PvsRowCount { rows: level.pvs_offsets.len(), clusters: n });
    }
    let row_bytes = level.row_bytes();
    for (a, &off) in level.pvs_offsets.iter().enumerate() {
        let data =
            level.pvs_data.get(off as usize..).ok_or(ValidateError::PvsOffset { cluster: a, offset: off })?;
        let row = rle::decode_row_vec(data, row_bytes).map_err(|source| ValidateError::PvsRow {
            cluster: a,
            offset: off,
            source,
        })?;
        for b in 0..n {
            if bits::bytes::get(&row, b) {
                m.set(a, b);
            }
        }
    }
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matrix_sets_and_counts() {
        let mut m = BitMatrix::new(130);
        assert!(m.set(129, 128));
        assert!(!m.set(129, 128));
        assert!(m.set(0, 0));
        assert!(m.get(129, 128) && !m.get(128, 129));
        assert_eq!(m.count(), 2);
        assert_eq!(m.row_count(129), 1);
        let mut other = BitMatrix::new(130);
        other.set(0, 0);
        assert_eq!(m.count_not_in(&other), 1);
        m.clear(0, 0);
        assert_eq!(m.count(), 1);
    }
}
