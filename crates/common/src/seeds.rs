//! Named random streams derived from one run seed.
//!
//! Every consumer of randomness (each lidar's noise terms, the odometry, each agent, the
//! scenario generator) gets its own stream, named by a string. The stream's seed is
//! `SplitMix64(run_seed ^ FNV-1a-64(name))`, so adding or removing a stream never shifts the
//! numbers another stream sees, and the mapping is portable (no `Hash` of the standard library,
//! whose output may change between Rust releases).
//!
//! ```
//! use mapkeeper_common::seeds::{stream_rng, stream_seed};
//! assert_eq!(stream_seed(7, "lidar/0"), stream_seed(7, "lidar/0"));
//! assert_ne!(stream_seed(7, "lidar/0"), stream_seed(7, "lidar/1"));
//! assert_ne!(stream_seed(7, "lidar/0"), stream_seed(8, "lidar/0"));
//! let _rng = stream_rng(7, "odometry");
//! ```

use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;

/// 64-bit FNV-1a hash of a byte string (a fingerprint, not a security measure).
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut h = Fnv1a64::new();
    h.write(bytes);
    h.finish()
}

/// 64-bit FNV-1a fed piece by piece: the same value as [`fnv1a64`] of the pieces joined.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fnv1a64(u64);

impl Default for Fnv1a64 {
    fn default() -> Self {
        Self::new()
    }
}

impl Fnv1a64 {
    /// The hash of nothing (the FNV offset basis).
    pub const fn new() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }

    /// Feeds `bytes`.
    pub fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    /// Feeds `x` as its 8 little-endian bytes.
    pub fn write_u64(&mut self, x: u64) {
        self.write(&x.to_le_bytes());
    }

    /// The hash so far.
    pub fn finish(&self) -> u64 {
        self.0
    }
}

/// One SplitMix64 output for state `x` (the finaliser of Steele, Lea and Flood 2014).
pub fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The seed of the stream called `name` in the run seeded with `run_seed`.
pub fn stream_seed(run_seed: u64, name: &str) -> u64 {
    splitmix64(run_seed ^ fnv1a64(name.as_bytes()))
}

/// A ChaCha8 generator for the stream called `name`.
pub fn stream_rng(run_seed: u64, name: &str) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(stream_seed(run_seed, name))
}

/// A named stream of a running simulation ([`stream_rng`]) that can be copied exactly: rand's
/// `ChaCha8Rng` is not `Clone`, so a copy saves and restores the generator's whole state
/// (key, stream, position in the key stream). A copied simulator draws exactly the numbers the
/// original would.
pub struct SimRng(ChaCha8Rng);

impl SimRng {
    /// The stream called `name` in the run seeded with `run_seed` (the numbers of
    /// [`stream_rng`]).
    pub fn stream(run_seed: u64, name: &str) -> Self {
        Self(stream_rng(run_seed, name))
    }
}

impl Clone for SimRng {
    fn clone(&self) -> Self {
        Self(ChaCha8Rng::deserialize_state(&self.0.serialize_state()))
    }
}

impl std::fmt::Debug for SimRng {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("SimRng { .. }")
    }
}

impl rand::TryRng for SimRng {
    type Error = std::convert::Infallible;

    fn try_next_u32(&mut self) -> Result<u32, Self::Error> {
        self.0.try_next_u32()
    }

    fn try_next_u64(&mut self) -> Result<u64, Self::Error> {
        self.0.try_next_u64()
    }

    fn try_fill_bytes(&mut self, dst: &mut [u8]) -> Result<(), Self::Error> {
        self.0.try_fill_bytes(dst)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv1a_reference_values() {
        // Published FNV-1a 64 test vectors.
        assert_eq!(fnv1a64(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a64(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a64(b"foobar"), 0x8594_4171_f739_67e8);
        let mut h = Fnv1a64::new();
        h.write(b"foo");
        h.write(b"bar");
        assert_eq!(h.finish(), fnv1a64(b"foobar"));
        h.write_u64(7);
        let mut joined = b"foobar".to_vec();
        joined.extend(7u64.to_le_bytes());
        assert_eq!(h.finish(), fnv1a64(&joined));
    }

    #[test]
    fn splitmix_reference_value() {
        // SplitMix64 seeded with 0: first output.
        assert_eq!(splitmix64(0), 0xe220_a839_7b1d_cdaf);
    }

    #[test]
    fn streams_are_independent_of_each_other() {
        let a = stream_seed(42, "lidar/0");
        let b = stream_seed(42, "lidar/1");
        let c = stream_seed(42, "agent/person-1");
        assert!(a != b && b != c && a != c);
        // Stable across calls (and, by construction, across platforms).
        assert_eq!(a, stream_seed(42, "lidar/0"));
    }

    #[test]
    fn a_copied_stream_continues_with_the_same_numbers() {
        use rand::RngExt;
        let mut a = SimRng::stream(5, "odometry");
        let mut plain = stream_rng(5, "odometry");
        for _ in 0..37 {
            assert_eq!(a.random::<u64>(), plain.random::<u64>());
        }
        // Mid-block (37 draws of 64 bits is not a multiple of the 16-word block).
        let _: u32 = a.random();
        let mut b = a.clone();
        let xs: Vec<u64> = (0..100).map(|_| a.random()).collect();
        let ys: Vec<u64> = (0..100).map(|_| b.random()).collect();
        assert_eq!(xs, ys);
    }
}
