//! Descriptor matching between two images accelerated by their feature vectors: a
//! feature is compared only with the other image's features under the same vocabulary
//! node (ORB-SLAM2's `SearchByBoW` idea), which skips most pairs that could not match.

use crate::bow::FeatureVector;
use gfs_core::descriptor::{Descriptor, hamming};

/// Thresholds of [`match_by_nodes`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodeMatchConfig {
    /// Largest Hamming distance of a match; default 50 (ORB-SLAM2 `TH_LOW`).
    pub max_distance: u32,
    /// Best distance must be below `ratio` times the second best within the node;
    /// default 0.75 (ORB-SLAM2's `SearchByBoW` for loops).
    pub ratio: f32,
}

impl Default for NodeMatchConfig {
    fn default() -> Self {
        Self {
            max_distance: 50,
            ratio: 0.75,
        }
    }
}

/// Matches the features of image `a` to those of image `b`, comparing only features
/// under a common node of their feature vectors (built at the same level of the same
/// vocabulary). Each feature of `a` takes its nearest feature of `b` in the node when it
/// passes `max_distance` and the ratio test; a feature of `b` claimed twice keeps the
/// closer claim. `out` receives `(index in a, index in b)` sorted by index in `a`;
/// indices beyond the descriptor slices are skipped.
pub fn match_by_nodes(
    features_a: &FeatureVector,
    descriptors_a: &[Descriptor],
    features_b: &FeatureVector,
    descriptors_b: &[Descriptor],
    config: &NodeMatchConfig,
    out: &mut Vec<(u32, u32)>,
) {
    out.clear();
    // Best claim on each feature of b: (distance, feature of a).
    let mut claims: Vec<Option<(u32, u32)>> = vec![None; descriptors_b.len()];
    for (list_a, list_b) in features_a.common(features_b) {
        for &ia in list_a {
            let Some(da) = descriptors_a.get(ia as usize) else {
                continue;
            };
            let (mut best, mut second, mut best_b) = (u32::MAX, u32::MAX, None);
            for &ib in list_b {
                let Some(db) = descriptors_b.get(ib as usize) else {
                    continue;
                };
                let d = hamming(da, db);
                if d < best {
                    (second, best, best_b) = (best, d, Some(ib));
                } else if d < second {
                    second = d;
                }
            }
            let Some(ib) = best_b else { continue };
            let distinct = second == u32::MAX || (best as f32) < config.ratio * second as f32;
            if best > config.max_distance || !distinct {
                continue;
            }
            let claim = &mut claims[ib as usize];
            if claim.is_none_or(|(d, _)| best < d) {
                *claim = Some((best, ia));
            }
        }
    }
    out.extend(
        claims
            .iter()
            .enumerate()
            .filter_map(|(ib, c)| c.map(|(_, ia)| (ia, ib as u32))),
    );
    out.sort_unstable();
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::clustered;
    use crate::train::VocabularyConfig;
    use crate::vocabulary::Vocabulary;
    use gfs_core::rng::SplitMix64;

    #[test]
    fn noisy_copies_are_matched_to_their_originals() {
        let (_, descriptors) = clustered(20, 30, 40, 12);
        let images: Vec<Vec<Descriptor>> = descriptors.chunks(60).map(<[_]>::to_vec).collect();
        let config = VocabularyConfig {
            branching: 5,
            levels: 3,
            seed: 1,
        };
        let v = Vocabulary::train(&images, &config, "").expect("valid");
        // Image a: 100 descriptors; image b: their copies with 6 flipped bits, reversed.
        let a: Vec<Descriptor> = descriptors.iter().step_by(6).copied().collect();
        let mut rng = SplitMix64::new(3);
        let b: Vec<Descriptor> = a
            .iter()
            .rev()
            .map(|d| {
                let mut c = *d;
                for _ in 0..6 {
                    let bit = rng.below(256) as usize;
                    c[bit / 64] ^= 1 << (bit % 64);
                }
                c
            })
            .collect();
        let (_, fa) = v.transform_with_features(&a, 2);
        let (_, fb) = v.transform_with_features(&b, 2);
        let mut matches = Vec::new();
        match_by_nodes(&fa, &a, &fb, &b, &NodeMatchConfig::default(), &mut matches);
        let n = a.len() as u32;
        let right = matches.iter().filter(|&&(ia, ib)| ib == n - 1 - ia).count();
        println!("{} matches, {right} right, of {n}", matches.len());
        assert_eq!(right, matches.len(), "every match is right");
        // A copy that falls under another node than its original, or loses the ratio
        // test to a cluster mate, would be missed; 6 bits of noise leave nearly all.
        assert!(right * 10 >= a.len() * 9, "{right} of {n}");
        // Features never paired twice; out-of-range indices are ignored.
        let mut seen = vec![false; b.len()];
        assert!(
            matches
                .iter()
                .all(|&(_, ib)| !std::mem::replace(&mut seen[ib as usize], true))
        );
        match_by_nodes(
            &fa,
            &a[..10],
            &fb,
            &b,
            &NodeMatchConfig::default(),
            &mut matches,
        );
        assert!(matches.iter().all(|&(ia, _)| ia < 10));
    }
}
