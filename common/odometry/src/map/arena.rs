//! Id-keyed storage: the map looks entities up by typed id, never through pointers.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// Ids are dense counters, so they hash to themselves: no need for SipHash on a hot path
/// that looks up thousands of map points per frame.
#[derive(Default)]
pub struct IdHasher(u64);

impl Hasher for IdHasher {
    fn finish(&self) -> u64 {
        // Spread the counter over the high bits that hashbrown uses for its control bytes.
        self.0.wrapping_mul(0x9E37_79B9_7F4A_7C15)
    }

    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 << 8) | b as u64;
        }
    }

    fn write_u64(&mut self, i: u64) {
        self.0 = i;
    }
}

/// A hash map keyed by a typed id.
pub type IdMap<K, V> = HashMap<K, V, BuildHasherDefault<IdHasher>>;
