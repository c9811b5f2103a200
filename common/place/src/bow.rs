//! Bag-of-words vectors, their similarity, and feature vectors (features grouped by
//! vocabulary node) for matching two images' descriptors.

use serde::{Deserialize, Serialize};

/// Index of a word (a leaf of the vocabulary tree).
pub type WordId = u32;

/// Index of a node of the vocabulary tree (0 = root).
pub type NodeId = u32;

/// A sparse tf-idf vector: `(word, weight)` sorted by word, weights L1-normalised (they
/// sum to 1; an image with no known word gives the empty vector).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BowVector {
    entries: Vec<(WordId, f64)>,
}

impl BowVector {
    /// A vector from `(word, weight)` pairs in any order, repeated words summed,
    /// L1-normalised; non-positive sums give an empty vector.
    pub fn from_weights(mut entries: Vec<(WordId, f64)>) -> Self {
        entries.sort_unstable_by_key(|e| e.0);
        entries.dedup_by(|next, kept| {
            let same = next.0 == kept.0;
            if same {
                kept.1 += next.1;
            }
            same
        });
        entries.retain(|e| e.1 > 0.0);
        let sum: f64 = entries.iter().map(|e| e.1).sum();
        if sum > 0.0 {
            for e in &mut entries {
                e.1 /= sum;
            }
        }
        Self { entries }
    }

    /// The `(word, weight)` entries, sorted by word.
    pub fn entries(&self) -> &[(WordId, f64)] {
        &self.entries
    }

    /// Number of distinct words.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// True when no word was seen.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

/// Contribution of one common word to the L1 score: `|a| + |b| - |a - b|`.
#[inline]
pub(crate) fn l1_term(a: f64, b: f64) -> f64 {
    a.abs() + b.abs() - (a - b).abs()
}

/// Similarity of two L1-normalised vectors, `1 - |a - b|_1 / 2` in `[0, 1]` (DBoW2's
/// L1 score; Nister and Stewenius 2006): 1 for equal vectors, 0 for disjoint words.
/// Computed over the common words alone, as `sum (|a| + |b| - |a - b|) / 2`.
pub fn score(a: &BowVector, b: &BowVector) -> f64 {
    let (a, b) = (&a.entries, &b.entries);
    let (mut i, mut j, mut sum) = (0, 0, 0.0);
    while i < a.len() && j < b.len() {
        match a[i].0.cmp(&b[j].0) {
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => j += 1,
            std::cmp::Ordering::Equal => {
                sum += l1_term(a[i].1, b[j].1);
                i += 1;
                j += 1;
            }
        }
    }
    (0.5 * sum).clamp(0.0, 1.0)
}

/// The features of an image grouped by the vocabulary node they pass through at one
/// level: two images' descriptors need only be compared within a shared node (the
/// speed-up of ORB-SLAM2's `SearchByBoW`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FeatureVector {
    /// `(node, feature indices)` sorted by node; indices ascending.
    groups: Vec<(NodeId, Vec<u32>)>,
}

impl FeatureVector {
    /// Builds from `(node, feature index)` pairs in any order, a pair given twice kept
    /// once (a feature may sit under several nodes: a map point seen by several
    /// keyframes, each with its own descriptor).
    pub fn from_pairs(mut pairs: Vec<(NodeId, u32)>) -> Self {
        pairs.sort_unstable();
        pairs.dedup();
        let mut groups: Vec<(NodeId, Vec<u32>)> = Vec::new();
        for (node, feature) in pairs {
            match groups.last_mut() {
                Some((last, list)) if *last == node => list.push(feature),
                _ => groups.push((node, vec![feature])),
            }
        }
        Self { groups }
    }

    /// The `(node, feature indices)` groups, sorted by node.
    pub fn groups(&self) -> &[(NodeId, Vec<u32>)] {
        &self.groups
    }

    /// The pairs of feature lists of `self` and `other` under the same node: compare
    /// descriptors only within each pair.
    pub fn common<'a>(
        &'a self,
        other: &'a FeatureVector,
    ) -> impl Iterator<Item = (&'a [u32], &'a [u32])> + 'a {
        let (a, b) = (&self.groups, &other.groups);
        let (mut i, mut j) = (0, 0);
        std::iter::from_fn(move || {
            while i < a.len() && j < b.len() {
                match a[i].0.cmp(&b[j].0) {
                    std::cmp::Ordering::Less => i += 1,
                    std::cmp::Ordering::Greater => j += 1,
                    std::cmp::Ordering::Equal => {
                        let pair = (a[i].1.as_slice(), b[j].1.as_slice());
                        i += 1;
                        j += 1;
                        return Some(pair);
                    }
                }
            }
            None
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vectors_are_merged_sorted_and_normalised() {
        let v = BowVector::from_weights(vec![(5, 1.0), (2, 2.0), (5, 1.0), (9, 0.0)]);
        assert_eq!(v.entries(), &[(2, 0.5), (5, 0.5)]);
        assert!(BowVector::from_weights(vec![(1, 0.0)]).is_empty());
    }

    #[test]
    fn score_is_one_for_equal_and_zero_for_disjoint_vectors() {
        let a = BowVector::from_weights(vec![(1, 1.0), (2, 3.0)]);
        let b = BowVector::from_weights(vec![(3, 1.0)]);
        let c = BowVector::from_weights(vec![(1, 1.0), (3, 1.0)]);
        assert!((score(&a, &a) - 1.0).abs() < 1e-12);
        assert_eq!(score(&a, &b), 0.0);
        // a = (0.25, 0.75, 0), c = (0.5, 0, 0.5): |a - c|_1 = 1.5, score 0.25.
        assert!((score(&a, &c) - 0.25).abs() < 1e-12);
        assert_eq!(score(&a, &c), score(&c, &a));
    }

    #[test]
    fn feature_vectors_pair_features_under_shared_nodes() {
        let a = FeatureVector::from_pairs(vec![(7, 0), (3, 1), (7, 2), (9, 3), (7, 0)]);
        let b = FeatureVector::from_pairs(vec![(3, 0), (8, 1), (7, 2)]);
        assert_eq!(a.groups()[1], (7, vec![0, 2]));
        let common: Vec<_> = a.common(&b).collect();
        assert_eq!(
            common,
            vec![(&[1u32][..], &[0u32][..]), (&[0, 2][..], &[2][..])]
        );
    }
}
