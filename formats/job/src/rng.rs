//! SplitMix64: the one small seeded generator every deterministic sampler, generator and test in
//! Sightline uses, so that a seed means the same sequence everywhere and for any thread count.

/// A SplitMix64 generator (Steele, Lea and Flood 2014): 64 bits of state, statistically good
/// enough for sampling and layouts, not for cryptography.
#[derive(Debug, Clone)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    /// The generator started from `seed`.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// An independent stream for item `index` of a computation seeded with `seed`, so parallel
    /// workers draw the same numbers whatever thread runs them.
    pub fn stream(seed: u64, index: u64) -> Self {
        let mut g = Self(seed ^ index.wrapping_mul(0xD1B5_4A32_D192_ED03));
        g.next_u64();
        g
    }

    /// An independent stream for item `(a, b)` of a computation seeded with `seed` (the
    /// validator's `(leaf, bundle)`): the seed and each key in turn go through a full SplitMix64
    /// step, so neighbouring keys give unrelated streams whatever thread draws them.
    pub fn keyed(seed: u64, a: u64, b: u64) -> Self {
        let mut g = Self::new(seed ^ 0x9E37_79B9_7F4A_7C15);
        let mut g = Self::new(g.next_u64() ^ a.wrapping_mul(0xD1B5_4A32_D192_ED03));
        Self::new(g.next_u64() ^ b.wrapping_mul(0x8CB9_2BA7_2F3D_8DD7))
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `0..n` (multiply-shift, no modulo bias worth naming); `0` when `n == 0`.
    pub fn below(&mut self, n: usize) -> usize {
        ((u128::from(self.next_u64()) * n as u128) >> 64) as usize
    }

    /// Uniform in `[0, 1)` with 53 random bits.
    pub fn unit_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in `[0, 1)` with 24 random bits.
    pub fn unit_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }

    /// Uniform in `[lo, hi)`.
    pub fn range_f64(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit_f64()
    }

    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.unit_f32()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_sequence_and_ranges() {
        // Reference values of SplitMix64 from seed 0.
        let mut g = SplitMix64::new(0);
        assert_eq!(g.next_u64(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(g.next_u64(), 0x6E78_9E6A_A1B9_65F4);
        for _ in 0..1000 {
            let u = g.unit_f64();
            assert!((0.0..1.0).contains(&u));
            let f = g.unit_f32();
            assert!((0.0..1.0).contains(&f));
            assert!(g.below(7) < 7);
        }
        assert_eq!(g.below(0), 0);
        let (mut a, mut b) = (SplitMix64::stream(5, 1), SplitMix64::stream(5, 2));
        assert_ne!(a.next_u64(), b.next_u64());
        assert_eq!(SplitMix64::keyed(1, 2, 3).next_u64(), SplitMix64::keyed(1, 2, 3).next_u64());
        assert_ne!(SplitMix64::keyed(1, 2, 3).next_u64(), SplitMix64::keyed(1, 2, 4).next_u64());
        assert_ne!(SplitMix64::keyed(1, 2, 3).next_u64(), SplitMix64::keyed(1, 3, 3).next_u64());
    }
}
