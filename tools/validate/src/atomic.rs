//! A square bit matrix that many threads set bits in at once. Setting bits is an OR, so the final
//! matrix does not depend on which thread set what or when.

use std::sync::atomic::{AtomicU64, Ordering};

use sightline_formats::bits;

use super::pvs::BitMatrix;

/// `n × n` bits, row-major, shared between threads.
#[derive(Debug)]
pub struct AtomicBitMatrix {
    n: usize,
    words: usize,
    bits: Vec<AtomicU64>,
}

impl AtomicBitMatrix {
    /// All clear.
    pub fn new(n: usize) -> Self {
        let words = bits::words(n);
        Self { n, words, bits: (0..words * n).map(|_| AtomicU64::new(0)).collect() }
    }

    /// Set bit `(a, b)`; ignored out of range.
    #[inline]
    pub fn set(&self, a: usize, b: usize) {
        if a >= self.n || b >= self.n {
            return;
        }
        let w = &self.bits[a * self.words + bits::word_of(b)];
        let mask = bits::mask(b);
        if w.load(Ordering::Relaxed) & mask == 0 {
            w.fetch_or(mask, Ordering::Relaxed);
        }
    }

    /// A plain copy (call once the writers have finished).
    pub fn snapshot(&self) -> BitMatrix {
        let mut m = BitMatrix::new(self.n);
        for a in 0..self.n {
            for wi in 0..self.words {
                for b in bits::word_ones(wi, self.bits[a * self.words + wi].load(Ordering::Relaxed)) {
                    m.set(a, b);
                }
            }
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parallel_sets_give_the_union() {
        use rayon::prelude::*;
        let m = AtomicBitMatrix::new(100);
        (0..100usize).into_par_iter().for_each(|i| {
            m.set(i, (i * 7) % 100);
            m.set(i, 99);
        });
        let s = m.snapshot();
        assert_eq!(s.count(), 199);
        assert!(s.get(3, 21) && s.get(3, 99) && !s.get(3, 20));
    }
}
