//! Tightening portal rows by the symmetry of sight.
//!
//! One-way portals come in pairs `2k`, `2k + 1` that are each other's reverse (`p ^ 1`). A straight
//! line that passes portal `r` and then portal `s` passes `s ^ 1` and then `r ^ 1` when followed
//! backwards. Every row (a `mightsee` or a finished flow row) is a superset of the portals truly
//! visible through its portal, so when row `s ^ 1` lacks `r ^ 1`, no line goes from `r` to `s` and
//! `s` may be cleared from row `r`. Clearing only removes portals no line reaches: rows stay
//! conservative, and the flow prunes more.

use sightline_formats::bits;

/// Bit `s` of row `r`, where rows are `words` words each.
#[inline]
fn has(test: &[u64], words: usize, r: usize, s: usize) -> bool {
    bits::get(&test[r * words..(r + 1) * words], s)
}

#[inline]
fn clear(test: &mut [u64], words: usize, r: usize, s: usize) {
    bits::clear(&mut test[r * words..(r + 1) * words], s);
}

/// Make every pair of the `n` rows consistent: `s` in row `r` only when `r ^ 1` is in row `s ^ 1`.
pub fn tighten_all(test: &mut [u64], words: usize, n: usize) {
    for r in 0..n {
        tighten_row(test, words, n, r);
    }
}

/// Clear from row `r` every `s` whose reverse row lacks `r ^ 1`.
fn tighten_row(test: &mut [u64], words: usize, n: usize, r: usize) {
    for w in 0..words {
        for s in bits::word_ones(w, test[r * words + w]) {
            if s < n && !has(test, words, s ^ 1, r ^ 1) {
                clear(test, words, r, s);
            }
        }
    }
}

/// Replace row `f` by `row` (a flow result), keeping every pair consistent, given that they
/// were consistent before: the new row is also cut to the current one (other rows may have been
/// tightened since the flow read it), and for each portal `b` that leaves row `f`, `f ^ 1` leaves
/// row `b ^ 1`. Costs the row's words plus the bits that change, not a scan of every row.
pub fn replace_row(test: &mut [u64], words: usize, f: usize, row: &[u64]) {
    for w in 0..words {
        let current = test[f * words + w];
        let new = current & row[w];
        test[f * words + w] = new;
        for b in bits::word_ones(w, current & !new) {
            clear(test, words, b ^ 1, f ^ 1);
        }
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    proptest! {
        /// Tightening only clears bits, leaves every pair consistent, and keeps every bit whose
        /// reverse was set to begin with.
        #[test]
        fn tightening_is_consistent_and_only_clears(
            n_half in 1usize..40,
            fill in prop::collection::vec(any::<u64>(), 80 * 2),
        ) {
            let n = 2 * n_half;
            let words = bits::words(n);
            let mask = |w: usize| bits::valid_mask(w, n);
            let original: Vec<u64> = (0..n * words).map(|i| fill[i % fill.len()] & mask(i % words)).collect();
            let mut all = original.clone();
            tighten_all(&mut all, words, n);
            for r in 0..n {
                for s in 0..n {
                    let was = has(&original, words, r, s);
                    let now = has(&all, words, r, s);
                    prop_assert!(!now || was, "set a bit");
                    prop_assert!(!now || has(&all, words, s ^ 1, r ^ 1), "inconsistent pair");
                    prop_assert_eq!(now, was && has(&original, words, s ^ 1, r ^ 1));
                }
            }
            // Replacing a row keeps every pair consistent and only clears bits.
            let mut one = all.clone();
            let row: Vec<u64> = (0..words).map(|w| fill[(w + 7) % fill.len()] & mask(w)).collect();
            replace_row(&mut one, words, 1, &row);
            for r in 0..n {
                for s in 0..n {
                    let now = has(&one, words, r, s);
                    prop_assert!(!now || has(&all, words, r, s), "set a bit");
                    prop_assert!(!now || has(&one, words, s ^ 1, r ^ 1), "inconsistent after update");
                    if r == 1 {
                        prop_assert_eq!(now, has(&all, words, 1, s) && bits::get(&row, s));
                    }
                }
            }
        }
    }
}
