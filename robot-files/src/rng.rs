//! The simulator's deterministic random numbers: xoshiro256++ seeded by SplitMix64
//! ([`rand_xoshiro::Xoshiro256PlusPlus`]), uniform draws from its 53 high bits, normal
//! draws by `rand_distr`'s ziggurat ([`rand_distr::StandardNormal`]).
//!
//! Contract: the same seed gives the same stream on every machine and build, so the same
//! scenario and seed give the same run; each Monte-Carlo run gets its own stream (a seed
//! of its own). [`Rng::next_u64`] is the plain xoshiro256++ stream of the SplitMix64
//! expansion of the seed, and [`Rng::uniform`] is `(next_u64 >> 11) · 2⁻⁵³`, one draw per
//! value. A normal draw takes one `next_u64` most of the time and more in the
//! ziggurat's rare slow paths. This is not a cryptographic generator and does not need to
//! be.

use rand_distr::{Distribution, StandardNormal, StandardUniform};
use rand_xoshiro::rand_core::{Rng as _, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

/// xoshiro256++ (Blackman & Vigna, 2019): 256-bit state, period 2²⁵⁶ − 1.
#[derive(Clone, Debug)]
pub struct Rng {
    inner: Xoshiro256PlusPlus,
}

impl Rng {
    /// A generator whose whole stream is determined by `seed` (expanded to the 256-bit
    /// state by SplitMix64).
    pub fn new(seed: u64) -> Self {
        Self {
            inner: Xoshiro256PlusPlus::seed_from_u64(seed),
        }
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.inner.next_u64()
    }

    /// Uniform in [0, 1), with 53 random bits (one [`Rng::next_u64`]).
    pub fn uniform(&mut self) -> f64 {
        StandardUniform.sample(&mut self.inner)
    }

    /// Uniform in [`lo`, `hi`): `lo + (hi − lo) · u` for one [`Rng::uniform`] u.
    pub fn uniform_in(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }

    /// Uniform in [−`half_width`, `half_width`).
    pub fn symmetric(&mut self, half_width: f64) -> f64 {
        self.uniform_in(-half_width, half_width)
    }

    /// Standard normal N(0, 1) ([`StandardNormal`], the ziggurat method).
    pub fn normal(&mut self) -> f64 {
        StandardNormal.sample(&mut self.inner)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_stream_is_xoshiro256_plus_plus_seeded_by_splitmix64() {
        // The reference algorithm (Blackman & Vigna's xoshiro256++ and SplitMix64), by
        // hand: the stream the crate must give for the same seed.
        fn reference(seed: u64, n: usize) -> Vec<u64> {
            let mut sm = seed;
            let mut splitmix = || {
                sm = sm.wrapping_add(0x9E37_79B9_7F4A_7C15);
                let mut z = sm;
                z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
                z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
                z ^ (z >> 31)
            };
            let mut s = [splitmix(), splitmix(), splitmix(), splitmix()];
            (0..n)
                .map(|_| {
                    let result = s[0].wrapping_add(s[3]).rotate_left(23).wrapping_add(s[0]);
                    let t = s[1] << 17;
                    s[2] ^= s[0];
                    s[3] ^= s[1];
                    s[1] ^= s[2];
                    s[0] ^= s[3];
                    s[2] ^= t;
                    s[3] = s[3].rotate_left(45);
                    result
                })
                .collect()
        }
        for seed in [0, 1, 7, 0xDEAD_BEEF, u64::MAX] {
            let mut rng = Rng::new(seed);
            let stream: Vec<u64> = (0..1000).map(|_| rng.next_u64()).collect();
            assert_eq!(stream, reference(seed, 1000), "seed {seed}");
        }
        let mut rng = Rng::new(0);
        assert_eq!(rng.next_u64(), 0x5317_5d61_490b_23df);
        let mut a = Rng::new(7);
        let mut b = Rng::new(7);
        for _ in 0..100 {
            let bits = b.next_u64();
            assert_eq!(
                a.uniform(),
                (bits >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
            );
        }
    }

    #[test]
    fn same_seed_same_stream_and_sane_moments() {
        let mut a = Rng::new(7);
        let mut b = Rng::new(7);
        assert_eq!(a.next_u64(), b.next_u64());
        assert_eq!(a.normal().to_bits(), b.normal().to_bits());
        let n = 20_000;
        let (mut sum, mut sum2) = (0.0, 0.0);
        for _ in 0..n {
            let x = a.normal();
            sum += x;
            sum2 += x * x;
        }
        let mean = sum / n as f64;
        let var = sum2 / n as f64 - mean * mean;
        assert!(mean.abs() < 0.03, "{mean}");
        assert!((var - 1.0).abs() < 0.05, "{var}");
        let u = a.uniform();
        assert!((0.0..1.0).contains(&u));
        let x = a.uniform_in(2.0, 3.0);
        assert!((2.0..3.0).contains(&x));
    }
}
