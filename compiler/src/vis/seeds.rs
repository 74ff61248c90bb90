//! Seeds: per cluster, the clusters a flow from one of its portals may count as seen from the
//! start, as a cluster × cluster bit matrix (`bits::words(clusters)` words per cluster; bit `to`
//! of row `from` set when `from` sees `to`): pairs joined by a certified sight line
//! ([`super::certify`], both ways), and the clusters earlier flows from `from`'s portals counted
//! seen (one way: `from`'s row holds them whether or not they are visible).
//!
//! Flows of a batch read only the pairs of earlier batches ([`Seeds::row`]), so what they find
//! does not depend on timing; the pairs they certify go to a second matrix of atomic words
//! ([`Seeds::record`]), and the batch boundary moves them over ([`Seeds::fold`]). A pair takes
//! one bit however many chains or flows certify it, so the seeds of a batch in flight never take
//! more than that second matrix.

use std::sync::atomic::{AtomicU64, Ordering};

use sightline_formats::bits;

/// The seeds of the batches folded so far, and the pairs certified by the batch in flight.
#[derive(Debug)]
pub struct Seeds {
    /// Words per cluster row.
    cw: usize,
    /// Pairs of the folded batches.
    known: Vec<u64>,
    /// Pairs certified since the last fold and not in `known`.
    pending: Vec<AtomicU64>,
    /// One bit per cluster: its `pending` row may hold a bit.
    dirty: Vec<AtomicU64>,
}

impl Seeds {
    /// No seeds, for `clusters` clusters.
    pub fn new(clusters: usize) -> Self {
        let cw = bits::words(clusters);
        Self {
            cw,
            known: vec![0; clusters * cw],
            pending: (0..clusters * cw).map(|_| AtomicU64::new(0)).collect(),
            dirty: (0..bits::words(clusters)).map(|_| AtomicU64::new(0)).collect(),
        }
    }

    /// The clusters cluster `c` is known to see (folded batches only).
    pub fn row(&self, c: usize) -> &[u64] {
        &self.known[c * self.cw..(c + 1) * self.cw]
    }

    /// The folded pairs, for [`super::state::State::replay`] to rebuild.
    pub fn known_mut(&mut self) -> &mut [u64] {
        &mut self.known
    }

    /// Cluster `from` sees cluster `to` (or counts it seen); visible to flows after the next
    /// [`Seeds::fold`]. Safe from any number of threads.
    pub fn record(&self, from: u32, to: u32) {
        let (from, to) = (from as usize, to as usize);
        if bits::get(self.row(from), to) {
            return;
        }
        let (w, m) = (from * self.cw + bits::word_of(to), bits::mask(to));
        // A plain load first: a pair recorded again (the common case on a chain's clusters) costs
        // no locked write.
        if self.pending[w].load(Ordering::Relaxed) & m != 0 {
            return;
        }
        if self.pending[w].fetch_or(m, Ordering::Relaxed) & m == 0 {
            self.dirty[bits::word_of(from)].fetch_or(bits::mask(from), Ordering::Relaxed);
        }
    }

    /// Make the recorded pairs known; `added` gets each one, in (from, to) order. Work grows with
    /// the rows that received pairs, not with the matrix.
    pub fn fold(&mut self, mut added: impl FnMut(u32, u32)) {
        let cw = self.cw;
        for dw in 0..self.dirty.len() {
            let word = std::mem::take(self.dirty[dw].get_mut());
            for from in bits::word_ones(dw, word) {
                let range = from * cw..(from + 1) * cw;
                for (w, (k, p)) in
                    self.known[range.clone()].iter_mut().zip(&mut self.pending[range]).enumerate()
                {
                    let new = std::mem::take(p.get_mut()) & !*k;
                    *k |= new;
                    for to in bits::word_ones(w, new) {
                        added(from as u32, to as u32);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pairs_become_visible_at_the_fold_once_and_in_order() {
        let mut s = Seeds::new(130);
        s.record(129, 3);
        s.record(2, 100);
        s.record(2, 7);
        s.record(2, 100);
        assert!(!bits::get(s.row(2), 7), "a pair is not known before the fold");
        let mut got = Vec::new();
        s.fold(|a, b| got.push((a, b)));
        assert_eq!(got, [(2, 7), (2, 100), (129, 3)]);
        assert!(bits::get(s.row(2), 7) && bits::get(s.row(2), 100) && bits::get(s.row(129), 3));
        // Known pairs are not recorded again; a second fold adds only what is new.
        s.record(2, 7);
        s.record(0, 0);
        got.clear();
        s.fold(|a, b| got.push((a, b)));
        assert_eq!(got, [(0, 0)]);
    }
}
