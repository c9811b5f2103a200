//! The vocabulary tree: descriptors to words, images to bag-of-words vectors.

use crate::bow::{BowVector, FeatureVector, NodeId, WordId};
use crate::kmedians::nearest;
use gfs_core::descriptor::{Descriptor, hamming};

/// Marks a node that is not a leaf.
pub(crate) const NOT_A_WORD: WordId = WordId::MAX;

/// A hierarchical k-medians tree over 256-bit ORB descriptors with an idf weight per
/// leaf word (Nister and Stewenius 2006; Galvez-Lopez and Tardos 2012, DBoW2).
///
/// Nodes are stored breadth first: node 0 is the root, the children of a node are
/// contiguous, and the leaves, numbered in node order, are the words. A descriptor's
/// word is the leaf reached by descending from the root to the nearest child (Hamming
/// distance) at every level.
#[derive(Clone, Debug, PartialEq)]
pub struct Vocabulary {
    pub(crate) branching: u32,
    pub(crate) levels: u32,
    /// Number of children of each node (0 for a leaf).
    pub(crate) child_count: Vec<u8>,
    /// Index of the first child of each node (meaningless for a leaf).
    pub(crate) first_child: Vec<u32>,
    /// Centre of each node (the root's is unused and zero).
    pub(crate) centres: Vec<Descriptor>,
    /// Word of each node, [`NOT_A_WORD`] for an inner node.
    pub(crate) word_of_node: Vec<WordId>,
    /// Node of each word.
    pub(crate) node_of_word: Vec<NodeId>,
    /// idf weight of each word, `ln(N / n_i)` over the training images.
    pub(crate) weights: Vec<f32>,
    /// How the vocabulary was made (command, images, seed), free text.
    pub(crate) description: String,
}

impl Vocabulary {
    /// Builds the derived indices from the stored parts (breadth-first child counts,
    /// centres and word weights). The caller has checked that the counts describe a
    /// breadth-first tree of `centres.len()` nodes whose leaves match `weights`.
    pub(crate) fn assemble(
        branching: u32,
        levels: u32,
        child_count: Vec<u8>,
        centres: Vec<Descriptor>,
        weights: Vec<f32>,
        description: String,
    ) -> Self {
        let mut first_child = Vec::with_capacity(child_count.len());
        let mut next = 1u32;
        let mut word_of_node = Vec::with_capacity(child_count.len());
        let mut node_of_word = Vec::with_capacity(weights.len());
        for (node, &count) in child_count.iter().enumerate() {
            first_child.push(next);
            next += u32::from(count);
            if count == 0 {
                word_of_node.push(node_of_word.len() as WordId);
                node_of_word.push(node as NodeId);
            } else {
                word_of_node.push(NOT_A_WORD);
            }
        }
        Self {
            branching,
            levels,
            child_count,
            first_child,
            centres,
            word_of_node,
            node_of_word,
            weights,
            description,
        }
    }

    /// Branching factor `k` it was trained with.
    pub fn branching(&self) -> usize {
        self.branching as usize
    }

    /// Depth `L` of the tree (levels below the root).
    pub fn levels(&self) -> usize {
        self.levels as usize
    }

    /// Number of words (leaves).
    pub fn num_words(&self) -> usize {
        self.node_of_word.len()
    }

    /// Number of nodes, the root included.
    pub fn num_nodes(&self) -> usize {
        self.child_count.len()
    }

    /// idf weight of `word`; 0 for an unknown word.
    pub fn weight(&self, word: WordId) -> f64 {
        self.weights
            .get(word as usize)
            .map_or(0.0, |&w| f64::from(w))
    }

    /// How the vocabulary was made.
    pub fn description(&self) -> &str {
        &self.description
    }

    /// The word of `descriptor` and the node it passed through at depth `level` (the
    /// leaf itself when the branch is shallower; the root at level 0).
    pub fn word_and_node(&self, descriptor: &Descriptor, level: usize) -> (WordId, NodeId) {
        let mut node = 0usize;
        let mut at_level = 0usize;
        let mut depth = 0usize;
        while self.child_count[node] > 0 {
            let first = self.first_child[node] as usize;
            let children = &self.centres[first..first + usize::from(self.child_count[node])];
            node = first + nearest(children, descriptor);
            depth += 1;
            if depth <= level {
                at_level = node;
            }
        }
        (self.word_of_node[node], at_level as NodeId)
    }

    /// The word of `descriptor`.
    pub fn word(&self, descriptor: &Descriptor) -> WordId {
        self.word_and_node(descriptor, 0).0
    }

    /// The tf-idf bag of words of an image's descriptors (each occurrence adds its
    /// word's idf weight; the vector is then L1-normalised).
    pub fn transform(&self, descriptors: &[Descriptor]) -> BowVector {
        let weights = descriptors
            .iter()
            .map(|d| {
                let w = self.word(d);
                (w, self.weight(w))
            })
            .collect();
        BowVector::from_weights(weights)
    }

    /// [`Self::transform`] plus the features grouped by their node at depth `level`
    /// (DBoW2's "direct index"; ORB-SLAM2 uses 4 levels up from the leaves of a
    /// 6-level tree). With the shipped vocabulary, between two rendered views 6 frames
    /// apart, [`crate::match_by_nodes`] finds 79 % of the exhaustive matches while
    /// comparing 11 % of the pairs at level 1, and 51 % comparing 1.4 % at level 2
    /// (test `node_matching_finds_most_exhaustive_matches_between_two_views`).
    pub fn transform_with_features(
        &self,
        descriptors: &[Descriptor],
        level: usize,
    ) -> (BowVector, FeatureVector) {
        let mut weights = Vec::with_capacity(descriptors.len());
        let mut pairs = Vec::with_capacity(descriptors.len());
        for (i, d) in descriptors.iter().enumerate() {
            let (word, node) = self.word_and_node(d, level);
            weights.push((word, self.weight(word)));
            pairs.push((node, i as u32));
        }
        (
            BowVector::from_weights(weights),
            FeatureVector::from_pairs(pairs),
        )
    }

    /// Hamming distance from `descriptor` to the centre of its word (how well the
    /// vocabulary fits a descriptor; small for the data it was trained on).
    pub fn distance_to_word(&self, descriptor: &Descriptor) -> u32 {
        let word = self.word(descriptor);
        hamming(
            &self.centres[self.node_of_word[word as usize] as usize],
            descriptor,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::clustered;
    use crate::train::VocabularyConfig;

    #[test]
    fn feature_vectors_group_every_feature_under_its_ancestor() {
        let (_, descriptors) = clustered(40, 25, 30, 6);
        let images: Vec<Vec<Descriptor>> = descriptors.chunks(100).map(<[_]>::to_vec).collect();
        let config = VocabularyConfig {
            branching: 4,
            levels: 3,
            seed: 5,
        };
        let v = Vocabulary::train(&images, &config, "").expect("valid");
        let query = &descriptors[..300];
        let (bow, features) = v.transform_with_features(query, 1);
        assert_eq!(bow, v.transform(query));
        let groups = features.groups();
        assert!(groups.len() <= 4, "{}", groups.len());
        let mut seen = vec![false; query.len()];
        for (node, list) in groups {
            // Level-1 nodes are the root's children.
            assert!((1..=4).contains(node), "{node}");
            for &f in list {
                assert!(!seen[f as usize]);
                seen[f as usize] = true;
                assert_eq!(v.word_and_node(&query[f as usize], 1).1, *node);
            }
        }
        assert!(seen.iter().all(|&s| s));
        // Level 0 puts everything under the root; the leaf level gives words' nodes.
        let (_, root) = v.transform_with_features(query, 0);
        assert_eq!(root.groups().len(), 1);
        let (word, leaf) = v.word_and_node(&query[0], 3);
        assert_eq!(v.node_of_word[word as usize], leaf);
        assert!(v.distance_to_word(&query[0]) < 60);
    }
}
