//! Bit rows stored as `u64` words: bit `i` is word `i / 64`, bit `i % 64`.

/// Words needed for `bits` bits.
#[inline]
pub fn words(bits: usize) -> usize {
    bits.div_ceil(64)
}

/// Test bit `i`.
#[inline]
pub fn get(row: &[u64], i: usize) -> bool {
    row.get(i >> 6).is_some_and(|w| w >> (i & 63) & 1 != 0)
}

/// Set bit `i` (ignored when out of range).
#[inline]
pub fn set(row: &mut [u64], i: usize) {
    if let Some(w) = row.get_mut(i >> 6) {
        *w |= 1 << (i & 63);
    }
}

/// Clear bit `i` (ignored when out of range).
#[inline]
pub fn clear(row: &mut [u64], i: usize) {
    if let Some(w) = row.get_mut(i >> 6) {
        *w &= !(1 << (i & 63));
    }
}

/// Number of set bits.
#[inline]
pub fn count(row: &[u64]) -> u64 {
    row.iter().map(|w| u64::from(w.count_ones())).sum()
}

/// Indices of the set bits, in increasing order.
pub fn ones(row: &[u64]) -> impl Iterator<Item = usize> + '_ {
    row.iter().enumerate().flat_map(|(wi, &w)| {
        let mut w = w;
        std::iter::from_fn(move || {
            if w == 0 {
                return None;
            }
            let b = w.trailing_zeros() as usize;
            w &= w - 1;
            Some(wi * 64 + b)
        })
    })
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
        clear(&mut r, 63);
        assert_eq!(count(&r), 3);
    }
}
