//! 256-bit binary descriptors and their distance. ORB's rBRIEF (points) and binary LBD
//! (lines) share the layout, so one distance serves every matcher.

/// A 256-bit binary descriptor (four little-endian 64-bit words).
pub type Descriptor = [u64; 4];

/// Hamming distance between two descriptors (0..=256).
#[inline]
pub fn hamming(a: &Descriptor, b: &Descriptor) -> u32 {
    (a[0] ^ b[0]).count_ones()
        + (a[1] ^ b[1]).count_ones()
        + (a[2] ^ b[2]).count_ones()
        + (a[3] ^ b[3]).count_ones()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distance_counts_differing_bits() {
        let a = [0u64; 4];
        let b = [u64::MAX, 0, 1, 0b111];
        assert_eq!(hamming(&a, &b), 68);
        assert_eq!(hamming(&b, &b), 0);
        assert_eq!(hamming(&a, &[u64::MAX; 4]), 256);
    }
}
