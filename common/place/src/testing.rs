//! Test fixtures: clustered random descriptors.

use gfs_core::descriptor::Descriptor;
use gfs_core::rng::SplitMix64;

/// `clusters` random centres, `per_cluster` members each flipping `noise_bits`
/// random bits of their centre.
pub(crate) fn clustered(
    clusters: usize,
    per_cluster: usize,
    noise_bits: usize,
    seed: u64,
) -> (Vec<Descriptor>, Vec<Descriptor>) {
    let mut rng = SplitMix64::new(seed);
    let centres: Vec<Descriptor> = (0..clusters)
        .map(|_| std::array::from_fn(|_| rng.next_u64()))
        .collect();
    let mut out = Vec::new();
    for c in &centres {
        for _ in 0..per_cluster {
            let mut d = *c;
            for _ in 0..noise_bits {
                let bit = rng.below(256) as usize;
                d[bit / 64] ^= 1 << (bit % 64);
            }
            out.push(d);
        }
    }
    (centres, out)
}
