//! Tightening portal rows by the symmetry of sight.
//!
//! One-way portals come in pairs `2k`, `2k + 1` that are each other's reverse (`p ^ 1`). A straight
//! line that passes portal `r` and then portal `s` passes `s ^ 1` and then `r ^ 1` when followed
//! backwards. Every row (a `mightsee` or a finished flow row) is a superset of the portals truly
//! visible through its portal, so when row `s ^ 1` lacks `r ^ 1`, no line goes from `r` to `s` and
//! `s` may be cleared from row `r`. Clearing only removes portals no line reaches: rows stay
//! conservative, and the flow prunes more.

use sightline_formats::bits;

#[inline]
fn clear(test: &mut [u64], words: usize, r: usize, s: usize) {
    bits::clear(&mut test[r * words..(r + 1) * words], s);
}

/// Make every pair of the `n` rows consistent: `s` in row `r` only when `r ^ 1` is in row `s ^ 1`.
///
/// Each bit and the one it needs (bit `r ^ 1` of row `s ^ 1`, which needs it back) form a pair
/// that is kept whole or cleared whole whatever the order, so the result is `M ∧ M'` with
/// `M'[r][s] = M[s ^ 1][r ^ 1]`: row `r` of the transpose of `M`, rows and columns taken in
/// swapped pairs. The transpose is built 64 rows at a time (a stripe: 64 rows of `n` bits of
/// scratch) from 64 × 64 bit blocks, skipping blocks without a bit, in place of a look-up per set
/// bit (on the generated 4 × 4 × 2 rooms 1.3 % of vis's instructions, on dm1 1.6 %). Bits at or
/// beyond `n` in a row are left as they are.
pub fn tighten_all(test: &mut [u64], words: usize, n: usize) {
    debug_assert!(n.is_multiple_of(2), "one-way portals come in pairs");
    // Words of a row that hold portals (rows may be longer).
    let nw = bits::words(n).min(words);
    let mut stripe = vec![0u64; 64 * nw];
    for s in 0..nw {
        // Rows `64 s ..` of the transpose: bit `i` of word `w` of its row `j` is bit `64 s + j`
        // of row `64 w + i`.
        for w in 0..nw {
            let mut block = [0u64; 64];
            for (i, b) in block.iter_mut().enumerate() {
                if let Some(&x) = test.get((64 * w + i) * words + s).filter(|_| 64 * w + i < n) {
                    *b = x;
                }
            }
            if block.iter().all(|&b| b == 0) {
                for j in 0..64 {
                    stripe[j * nw + w] = 0;
                }
                continue;
            }
            transpose(&mut block);
            for (j, &b) in block.iter().enumerate() {
                stripe[j * nw + w] = b;
            }
        }
        // A stripe's rows pair with rows of the same stripe (`r ^ 1` flips the lowest bit).
        for r in 64 * s..(64 * s + 64).min(n) {
            let need = &stripe[((r ^ 1) - 64 * s) * nw..][..nw];
            for (w, (x, &m)) in test[r * words..r * words + nw].iter_mut().zip(need).enumerate() {
                *x &= swap_pairs(m) | !bits::valid_mask(w, n);
            }
        }
    }
}

/// Bits `2k` and `2k + 1` of `x` exchanged: a row of one-way portals read as their reverses.
#[inline]
fn swap_pairs(x: u64) -> u64 {
    const EVEN: u64 = 0x5555_5555_5555_5555;
    ((x & EVEN) << 1) | ((x >> 1) & EVEN)
}

/// Transpose a 64 × 64 bit matrix: bit `j` of word `i` becomes bit `i` of word `j`.
fn transpose(a: &mut [u64; 64]) {
    let mut width = 32;
    let mut mask: u64 = 0x0000_0000_FFFF_FFFF;
    while width != 0 {
        let mut k = 0;
        while k < 64 {
            // Exchange the high `width` bits of each `width`-bit group of word `k` with the low
            // ones of word `k + width`.
            let t = ((a[k] >> width) ^ a[k + width]) & mask;
            a[k] ^= t << width;
            a[k + width] ^= t;
            k = (k + width + 1) & !width;
        }
        width >>= 1;
        mask ^= mask << width;
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

    /// Bit `s` of row `r`, where rows are `words` words each.
    fn has(test: &[u64], words: usize, r: usize, s: usize) -> bool {
        bits::get(&test[r * words..(r + 1) * words], s)
    }

    #[test]
    fn transposing_moves_bit_j_of_word_i_to_bit_i_of_word_j() {
        let mut rng = 0x9e37_79b9_7f4a_7c15u64;
        let mut a = [0u64; 64];
        for w in &mut a {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            *w = rng;
        }
        let mut t = a;
        transpose(&mut t);
        for (i, &row) in a.iter().enumerate() {
            for (j, &col) in t.iter().enumerate() {
                assert_eq!(col >> i & 1, row >> j & 1, "bit {j} of word {i}");
            }
        }
        assert_eq!(swap_pairs(0b0110_0001), 0b1001_0010);
    }

    proptest! {
        /// Tightening only clears bits, leaves every pair consistent, and keeps every bit whose
        /// reverse was set to begin with.
        #[test]
        fn tightening_is_consistent_and_only_clears(
            n_half in 1usize..160,
            fill in prop::collection::vec(any::<u64>(), 80 * 2),
            sparse in any::<bool>(),
        ) {
            let n = 2 * n_half;
            let words = bits::words(n);
            let mask = |w: usize| bits::valid_mask(w, n);
            // Dense rows, or rows with a bit in one word of four (whole blocks without a bit).
            let keep = |i: usize| !sparse || (i / words + i % words).is_multiple_of(4);
            let original: Vec<u64> = (0..n * words)
                .map(|i| if keep(i) { fill[i % fill.len()] & mask(i % words) } else { 0 })
                .collect();
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
