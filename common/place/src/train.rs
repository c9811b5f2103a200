//! Training a vocabulary: hierarchical k-medians over the training descriptors, then
//! the idf weight of every word over the training images.

use crate::kmedians::cluster;
use crate::vocabulary::Vocabulary;
use gfs_core::descriptor::Descriptor;
use gfs_core::rng::SplitMix64;
use std::collections::VecDeque;

/// Largest branching factor (child counts are stored as bytes).
pub const MAX_BRANCHING: usize = 255;
/// Largest depth.
pub const MAX_LEVELS: usize = 8;

/// Parameters of [`Vocabulary::train`].
#[derive(Clone, Debug, PartialEq)]
pub struct VocabularyConfig {
    /// Branching factor `k`; default 10 (DBoW2's ORB vocabulary).
    pub branching: usize,
    /// Depth `L`; default 4, so up to 10^4 words (the shipped vocabulary's choice, see
    /// `vocabulary/README.md`; ORB-SLAM2's has 6 levels, 10^6 words, 145 MB as text).
    pub levels: usize,
    /// Seed of the k-means++ draws; default 1. Same seed, same data: same vocabulary.
    pub seed: u64,
}

impl Default for VocabularyConfig {
    fn default() -> Self {
        Self {
            branching: 10,
            levels: 4,
            seed: 1,
        }
    }
}

/// Why a vocabulary could not be trained.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum VocabularyTrainError {
    /// `branching` outside `2..=255` or `levels` outside `1..=8`.
    #[error("vocabulary branching {branching} (2..=255) or levels {levels} (1..=8) out of range")]
    Shape {
        /// Requested branching factor.
        branching: usize,
        /// Requested depth.
        levels: usize,
    },
    /// No training descriptor at all.
    #[error("no training descriptors in {images} images")]
    NoDescriptors {
        /// Number of training images given.
        images: usize,
    },
    /// More descriptors than the 32-bit indices hold.
    #[error("{descriptors} training descriptors exceed the 2^32 - 1 supported")]
    TooMany {
        /// Number of training descriptors.
        descriptors: usize,
    },
}

impl Vocabulary {
    /// Trains a vocabulary on the descriptors of `images` (one list per image; the
    /// image grouping gives the idf weights), with `description` saying how the images
    /// were obtained (stored with the vocabulary).
    ///
    /// Each node's members are split by [`cluster`] into at most `k` children, breadth
    /// first, down to `levels`; a node with a single distinct member becomes a leaf
    /// early. The draws of node `n` use the stream `(seed, n)`, so the result depends
    /// on the seed and the data alone. Then `idf(word) = ln(N / n_word)` with `N`
    /// training images and `n_word` of them containing the word (`ln N` for a word none
    /// contains: a centre no training descriptor descends to).
    ///
    /// # Errors
    /// [`VocabularyTrainError`] for a shape out of range, no descriptors, or too many.
    pub fn train(
        images: &[Vec<Descriptor>],
        config: &VocabularyConfig,
        description: &str,
    ) -> Result<Self, VocabularyTrainError> {
        let (k, levels) = (config.branching, config.levels);
        if !(2..=MAX_BRANCHING).contains(&k) || !(1..=MAX_LEVELS).contains(&levels) {
            return Err(VocabularyTrainError::Shape {
                branching: k,
                levels,
            });
        }
        let descriptors: Vec<Descriptor> = images.iter().flatten().copied().collect();
        if descriptors.is_empty() {
            return Err(VocabularyTrainError::NoDescriptors {
                images: images.len(),
            });
        }
        if descriptors.len() >= u32::MAX as usize {
            return Err(VocabularyTrainError::TooMany {
                descriptors: descriptors.len(),
            });
        }
        let mut child_count: Vec<u8> = vec![0];
        let mut centres: Vec<Descriptor> = vec![[0; 4]];
        let mut queue = VecDeque::new();
        queue.push_back((
            0usize,
            0usize,
            (0..descriptors.len() as u32).collect::<Vec<_>>(),
        ));
        while let Some((node, depth, members)) = queue.pop_front() {
            let mut rng = SplitMix64::keyed(config.seed, &[node as u64]);
            let groups = cluster(&descriptors, &members, k, &mut rng);
            if groups.len() < 2 && node != 0 {
                continue;
            }
            child_count[node] = groups.len() as u8;
            for (centre, group) in groups {
                let child = centres.len();
                centres.push(centre);
                child_count.push(0);
                if depth + 1 < levels {
                    queue.push_back((child, depth + 1, group));
                }
            }
        }
        let leaves = child_count.iter().filter(|&&c| c == 0).count();
        let mut vocabulary = Vocabulary::assemble(
            k as u32,
            levels as u32,
            child_count,
            centres,
            vec![0.0; leaves],
            description.to_owned(),
        );
        vocabulary.weights = idf(&vocabulary, images);
        Ok(vocabulary)
    }
}

/// `ln(N / n_word)` for every word over the training images.
fn idf(vocabulary: &Vocabulary, images: &[Vec<Descriptor>]) -> Vec<f32> {
    let words = vocabulary.num_words();
    let mut containing = vec![0u32; words];
    let mut last_image = vec![usize::MAX; words];
    for (i, image) in images.iter().enumerate() {
        for d in image {
            let w = vocabulary.word(d) as usize;
            if last_image[w] != i {
                last_image[w] = i;
                containing[w] += 1;
            }
        }
    }
    let n = images.len() as f64;
    containing
        .iter()
        .map(|&c| (n / f64::from(c.max(1))).ln() as f32)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::clustered;
    use gfs_core::descriptor::hamming;

    #[test]
    fn a_one_level_tree_recovers_the_clusters_and_their_idf() {
        // 8 clusters of 40; image i holds clusters i % 8 and (i + 1) % 8 only.
        let (centres, descriptors) = clustered(8, 40, 16, 21);
        let images: Vec<Vec<Descriptor>> = (0..8)
            .map(|i| {
                let a = &descriptors[40 * i..40 * i + 40];
                let j = (i + 1) % 8;
                a.iter()
                    .chain(&descriptors[40 * j..40 * j + 40])
                    .copied()
                    .collect()
            })
            .collect();
        let config = VocabularyConfig {
            branching: 8,
            levels: 1,
            seed: 3,
        };
        let v = Vocabulary::train(&images, &config, "test").expect("valid");
        assert_eq!((v.num_words(), v.num_nodes()), (8, 9));
        let mut found = [false; 8];
        for (c, centre) in centres.iter().enumerate() {
            let w = v.word(centre);
            let node = v.node_of_word[w as usize] as usize;
            assert!(hamming(&v.centres[node], centre) <= 2);
            assert!(!found[w as usize], "two clusters share word {w}");
            found[w as usize] = true;
            // Every member of cluster c gets c's word.
            assert!(
                descriptors[40 * c..40 * c + 40]
                    .iter()
                    .all(|d| v.word(d) == w)
            );
            // Each cluster is in 2 of the 8 images: idf ln 4.
            assert!((v.weight(w) - 4f64.ln()).abs() < 1e-6, "{}", v.weight(w));
        }
    }

    #[test]
    fn a_deeper_tree_is_deterministic_and_bounded() {
        let (_, descriptors) = clustered(30, 30, 40, 5);
        let images: Vec<Vec<Descriptor>> = descriptors.chunks(90).map(<[_]>::to_vec).collect();
        let config = VocabularyConfig {
            branching: 4,
            levels: 3,
            seed: 8,
        };
        let a = Vocabulary::train(&images, &config, "a").expect("valid");
        let b = Vocabulary::train(&images, &config, "a").expect("valid");
        assert_eq!(a, b);
        assert!(
            a.num_words() <= 64 && a.num_words() >= 40,
            "{}",
            a.num_words()
        );
        let other = Vocabulary::train(&images, &VocabularyConfig { seed: 9, ..config }, "a");
        assert_ne!(Some(&a), other.as_ref().ok());
        // The same image scores 1 with itself.
        let bow = a.transform(&images[0]);
        assert!((crate::score(&bow, &bow) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn bad_shapes_and_empty_data_are_errors() {
        let (_, d) = clustered(2, 2, 1, 1);
        let bad = VocabularyConfig {
            branching: 1,
            ..VocabularyConfig::default()
        };
        assert!(matches!(
            Vocabulary::train(&[d], &bad, ""),
            Err(VocabularyTrainError::Shape { .. })
        ));
        assert_eq!(
            Vocabulary::train(&[vec![]], &VocabularyConfig::default(), ""),
            Err(VocabularyTrainError::NoDescriptors { images: 1 })
        );
    }
}
