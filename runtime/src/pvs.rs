//! PVS rows: a small bitset and decoding of a cluster's Quake-RLE row into it.

use crate::world::World;

/// A fixed-length set of bits, owned by the caller and reused across calls.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Bitset {
    words: Vec<u64>,
    len: usize,
}

impl Bitset {
    /// `len` bits, all clear.
    pub fn new(len: usize) -> Self {
        Self { words: vec![0; len.div_ceil(64)], len }
    }

    /// Number of bits.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True for a zero-length set.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Change the length to `len` bits, all clear (allocates only when growing past capacity).
    pub fn reset(&mut self, len: usize) {
        self.words.clear();
        self.words.resize(len.div_ceil(64), 0);
        self.len = len;
    }

    /// Bit `i` (false when out of range).
    #[inline]
    pub fn get(&self, i: usize) -> bool {
        self.words.get(i >> 6).is_some_and(|w| w >> (i & 63) & 1 != 0)
    }

    /// Set bit `i` (ignored when out of range).
    #[inline]
    pub fn set(&mut self, i: usize) {
        if i < self.len
            && let Some(w) = self.words.get_mut(i >> 6)
        {
            *w |= 1 << (i & 63);
        }
    }

    /// Set every bit.
    pub fn fill(&mut self) {
        self.words.fill(u64::MAX);
        self.trim();
    }

    /// Number of set bits.
    pub fn count_ones(&self) -> usize {
        self.words.iter().map(|w| w.count_ones() as usize).sum()
    }

    /// Indices of set bits, ascending.
    pub fn iter_ones(&self) -> impl Iterator<Item = usize> + '_ {
        self.words.iter().enumerate().flat_map(|(wi, &w)| {
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

    /// The 64-bit words, bit `i` in word `i / 64`, bit `i % 64`.
    pub fn words(&self) -> &[u64] {
        &self.words
    }

    fn trim(&mut self) {
        let extra = self.words.len() * 64 - self.len;
        if extra > 0
            && let Some(last) = self.words.last_mut()
        {
            *last &= u64::MAX >> extra;
        }
    }
}

impl World {
    /// Decode the PVS row of `cluster` into `out` (resized to [`World::num_clusters`] bits; bit `j`
    /// set means cluster `j` is potentially visible). Without vis data, or for a cluster out of
    /// range (the eye in solid), every bit is set, as Quake does.
    pub fn decode_pvs(&self, cluster: u32, out: &mut Bitset) {
        out.reset(self.num_clusters as usize);
        let Some(&offset) = self.pvs_offsets.get(cluster as usize) else {
            out.fill();
            return;
        };
        let data = self.pvs_data.get(offset as usize..).unwrap_or(&[]);
        let mut pos = 0;
        let mut byte = 0;
        while byte < self.row_bytes {
            let Some(&b) = data.get(pos) else { break };
            if b != 0 {
                if let Some(w) = out.words.get_mut(byte >> 3) {
                    *w |= u64::from(b) << ((byte & 7) * 8);
                }
                byte += 1;
                pos += 1;
            } else {
                byte += usize::from(data.get(pos + 1).copied().unwrap_or(u8::MAX));
                pos += 2;
            }
        }
        out.trim();
    }
}
