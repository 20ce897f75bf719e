//! The one seeded random generator of a match (SplitMix64).
//!
//! Written here rather than taken from a crate because its output is part of the
//! project's reproducibility promise: a seed must give the same map and the same match in
//! every future version, which general-purpose RNG crates do not guarantee.

/// SplitMix64: small, fast, and with a fixed, documented output sequence.
#[derive(Clone, Debug)]
pub struct SeededRng {
    state: u64,
}

impl SeededRng {
    /// A generator whose whole output is determined by `seed`.
    pub fn new(seed: u64) -> Self {
        Self { state: seed }
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// A uniform integer in `0..n` (`n > 0`), without modulo bias.
    pub fn below(&mut self, n: u64) -> u64 {
        debug_assert!(n > 0, "below(0) has no values");
        let zone = u64::MAX - u64::MAX % n;
        loop {
            let x = self.next_u64();
            if x < zone {
                return x % n;
            }
        }
    }

    /// A uniform index into a slice of length `len` (`len > 0`).
    pub fn index(&mut self, len: usize) -> usize {
        self.below(len as u64) as usize
    }

    /// A uniform `f32` in `[lo, hi)`; `lo` when the range is empty.
    pub fn range_f32(&mut self, lo: f32, hi: f32) -> f32 {
        // 24 random bits give every representable step of an f32 mantissa in [0, 1).
        let unit = (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32;
        if hi > lo { lo + (hi - lo) * unit } else { lo }
    }
}

/// FNV-1a, 64 bits: a fixed, documented hash for seeds and identities that must stay the
/// same in every future version (which `std`'s hashers do not promise).
pub fn fnv1a(bytes: impl IntoIterator<Item = u8>) -> u64 {
    bytes
        .into_iter()
        .fold(0xcbf2_9ce4_8422_2325, |hash, byte| (hash ^ u64::from(byte)).wrapping_mul(0x0100_0000_01b3))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn output_is_pinned() {
        // The reference SplitMix64 sequence for seed 0; a change here breaks every seed.
        let mut rng = SeededRng::new(0);
        assert_eq!(rng.next_u64(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(rng.next_u64(), 0x6E78_9E6A_A1B9_65F4);
    }

    #[test]
    fn fnv1a_is_pinned() {
        // The published FNV-1a 64 test vectors.
        assert_eq!(fnv1a(*b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a(*b"a"), 0xaf63_dc4c_8601_ec8c);
    }

    #[test]
    fn below_and_range_stay_in_bounds() {
        let mut rng = SeededRng::new(42);
        for n in 1..50u64 {
            assert!(rng.below(n) < n);
        }
        for _ in 0..1000 {
            let x = rng.range_f32(2.0, 3.5);
            assert!((2.0..3.5).contains(&x), "{x}");
        }
        assert_eq!(rng.range_f32(1.0, 1.0), 1.0);
    }
}
