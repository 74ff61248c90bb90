//! The validator's random streams: the project's SplitMix64 keyed by `(seed, leaf, bundle)`
//! ([`SplitMix64::keyed`]), so results never depend on which thread ran what, plus the one draw
//! only the validator needs, a direction uniform on the sphere.

use glam::DVec3;
use sightline_job::rng::SplitMix64;

/// The validator's random stream: the project's SplitMix64, keyed by `(seed, a, b)`.
#[derive(Debug, Clone)]
pub struct Rng(SplitMix64);

impl Rng {
    /// The stream for one `(seed, a, b)` triple ([`SplitMix64::keyed`]).
    pub fn for_key(seed: u64, a: u64, b: u64) -> Self {
        Rng(SplitMix64::keyed(seed, a, b))
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0.next_u64()
    }

    /// Uniform in `[0, 1)`.
    pub fn unit(&mut self) -> f64 {
        self.0.unit_f64()
    }

    /// A direction uniform on the unit sphere.
    pub fn direction(&mut self) -> DVec3 {
        let z = 2.0 * self.unit() - 1.0;
        let phi = std::f64::consts::TAU * self.unit();
        let r = (1.0 - z * z).max(0.0).sqrt();
        DVec3::new(r * phi.cos(), r * phi.sin(), z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_repeat_and_differ() {
        let a: Vec<u64> = (0..4).map(|_| Rng::for_key(1, 2, 3).next_u64()).collect();
        assert!(a.iter().all(|&x| x == a[0]));
        assert_ne!(Rng::for_key(1, 2, 3).next_u64(), Rng::for_key(1, 2, 4).next_u64());
        assert_ne!(Rng::for_key(1, 2, 3).next_u64(), Rng::for_key(1, 3, 3).next_u64());
        // Pinned: validation reports depend on these exact streams.
        let mut r = Rng::for_key(1, 2, 3);
        assert_eq!((r.next_u64(), r.next_u64()), (0x23EB_A552_CAC3_557D, 0x75E9_6EDC_48E6_D2C1));
    }

    #[test]
    fn directions_are_unit_and_balanced() {
        let mut r = Rng::for_key(7, 0, 0);
        let mut sum = DVec3::ZERO;
        for _ in 0..20_000 {
            let d = r.direction();
            assert!((d.length() - 1.0).abs() < 1e-12);
            sum += d;
        }
        assert!(sum.length() / 20_000.0 < 0.02, "mean direction {sum:?}");
    }
}
