//! Place recognition for GFS-VO: which earlier keyframe shows the place the camera sees
//! now, with nothing downloaded at run time.
//!
//! # Model
//!
//! A [`Vocabulary`] is a tree of `k`-way splits, `L` levels deep, over 256-bit ORB
//! descriptors, trained by hierarchical k-medians (k-means++ seeding, bitwise-majority
//! centres) on descriptors the project extracts itself from images it renders. Its
//! leaves are the words, each weighted by its inverse document frequency
//! `idf = ln(N / n_word)` over the training images. An image becomes a sparse tf-idf
//! [`BowVector`], L1-normalised, and two images compare by the L1 [`score`]
//! `1 - |a - b|_1 / 2` in `[0, 1]` (Nister and Stewenius 2006; DBoW2, Galvez-Lopez and
//! Tardos 2012). A [`KeyFrameDatabase`] keeps an inverted file from words to keyframes
//! and ranks the keyframes sharing words with a query. A [`FeatureVector`] groups an
//! image's features by their node at one level of the tree, so that matching two
//! keyframes ([`match_by_nodes`]) compares descriptors within a shared node only.
//!
//! The shipped vocabulary ([`Vocabulary::default_orb`], `vocabulary/orb.bin`) is
//! embedded in the binary; `vocabulary/README.md` says how it was made and what it
//! retrieves on real sequences. The file layout is versioned and checksummed
//! ([`Vocabulary::from_bytes`] never panics on bad bytes).
//!
//! # Example
//!
//! ```
//! use gfs_core::rng::SplitMix64;
//! use gfs_place::{KeyFrameDatabase, Vocabulary, score};
//!
//! let vocabulary = Vocabulary::default_orb();
//! // Descriptors of two "images" (random here; ORB descriptors in practice).
//! let mut rng = SplitMix64::new(7);
//! let mut image = |n: usize| -> Vec<[u64; 4]> {
//!     (0..n).map(|_| std::array::from_fn(|_| rng.next_u64())).collect()
//! };
//! let (image_a, image_b) = (image(300), image(300));
//! let (bow_a, bow_b) = (vocabulary.transform(&image_a), vocabulary.transform(&image_b));
//! assert!((score(&bow_a, &bow_a) - 1.0).abs() < 1e-9);
//!
//! let mut database = KeyFrameDatabase::new(vocabulary.num_words());
//! database.add(1u64, &bow_a);
//! database.add(2u64, &bow_b);
//! let best = database.query(&bow_a, 1, |_| false);
//! assert_eq!(best[0].0, 1);
//! ```
#![warn(missing_docs)]

mod bow;
mod database;
mod error;
mod format;
mod kmedians;
mod matching;
#[cfg(test)]
mod testing;
mod train;
mod vocabulary;

pub use bow::{BowVector, FeatureVector, NodeId, WordId, score};
pub use database::KeyFrameDatabase;
pub use error::{VocabularyFileError, VocabularyFormatError};
pub use format::FORMAT_VERSION;
pub use matching::{NodeMatchConfig, match_by_nodes};
pub use train::{MAX_BRANCHING, MAX_LEVELS, VocabularyConfig, VocabularyTrainError};
pub use vocabulary::Vocabulary;

/// The shipped ORB vocabulary's bytes (`vocabulary/orb.bin`).
const DEFAULT_ORB: &[u8] = include_bytes!("../vocabulary/orb.bin");

impl Vocabulary {
    /// The ORB vocabulary shipped with the project, trained on rendered synthetic
    /// scenes (see `vocabulary/README.md`).
    ///
    /// # Panics
    /// Never for a build of the repository: the embedded file is checked by a test.
    pub fn default_orb() -> Self {
        match Self::from_bytes(DEFAULT_ORB) {
            Ok(v) => v,
            Err(e) => panic!("the embedded vocabulary/orb.bin is broken: {e}"),
        }
    }
}
