//! Appearance-based loop candidates: every keyframe of the map as a bag of words
//! ([`gfs_place::Vocabulary::default_orb`]) in a [`KeyFrameDatabase`]; a query returns
//! the old keyframes that look most like the current one. As in ORB-SLAM2's
//! `DetectLoop`, a candidate must score at least as well as the current keyframe's
//! least similar connected neighbour (a place is at least as like itself as its own
//! neighbourhood is), which adapts the threshold to the scene's texture.
//!
//! Each keyframe also keeps its features grouped by vocabulary node (its
//! [`FeatureVector`], made in the same descent of the tree as its bag of words), so
//! that verifying a candidate compares descriptors only under a shared node
//! ([`super::place_points`]).

use crate::config::LoopClosingConfig;
use crate::map::{IdMap, Map};
use gfs_core::descriptor::Descriptor;
use gfs_core::ids::KeyFrameId;
use gfs_place::{BowVector, FeatureVector, KeyFrameDatabase, Vocabulary, score};

/// Descriptors are compared only under the same vocabulary node at this depth: with the
/// shipped vocabulary, 79 % of the exhaustive matches for 11 % of the comparisons
/// ([`gfs_place::Vocabulary::transform_with_features`]).
pub const NODE_LEVEL: usize = 1;

/// Keyframes described at once from which [`PlaceIndex::sync`] uses every core (below,
/// a thread costs more than it saves: one keyframe takes about half a millisecond).
const DESCRIBED_IN_PARALLEL_FROM: usize = 32;

/// `descriptors` as `vocabulary` describes them.
fn describe_with(vocabulary: &Vocabulary, descriptors: &[Descriptor]) -> Description {
    let (bow, nodes) = vocabulary.transform_with_features(descriptors, NODE_LEVEL);
    Description { bow, nodes }
}

/// An image as the vocabulary describes it.
#[derive(Clone, Debug, Default)]
pub struct Description {
    /// Its bag of words.
    pub bow: BowVector,
    /// Its features grouped by their node at [`NODE_LEVEL`].
    pub nodes: FeatureVector,
}

/// The keyframes of the map as bags of words and feature vectors, kept in step with the
/// map.
pub struct PlaceIndex {
    vocabulary: Vocabulary,
    database: KeyFrameDatabase<KeyFrameId>,
    described: IdMap<KeyFrameId, Description>,
}

impl Default for PlaceIndex {
    fn default() -> Self {
        let vocabulary = Vocabulary::default_orb();
        Self {
            database: KeyFrameDatabase::new(vocabulary.num_words()),
            vocabulary,
            described: IdMap::default(),
        }
    }
}

impl PlaceIndex {
    /// Drops the keyframes that left the map and adds those it does not hold yet
    /// (after a mapper restart, every keyframe of the restored map).
    pub fn sync(&mut self, map: &Map) {
        let gone: Vec<KeyFrameId> = self
            .described
            .keys()
            .copied()
            .filter(|k| map.keyframe(*k).is_none())
            .collect();
        for kf in gone {
            self.database.remove(kf);
            self.described.remove(&kf);
        }
        let missing: Vec<KeyFrameId> = map
            .keyframe_ids()
            .into_iter()
            .filter(|kf| !self.described.contains_key(kf))
            .collect();
        let descriptions = self.describe_keyframes(map, &missing);
        for (kf, description) in missing.into_iter().zip(descriptions) {
            self.database.add(kf, &description.bow);
            self.described.insert(kf, description);
        }
    }

    /// The descriptions of keyframes `kfs` of `map`, in their order. A whole map coming
    /// in at once (loaded from a file, restored) is described on every core: each
    /// keyframe's words depend on its descriptors only.
    fn describe_keyframes(&self, map: &Map, kfs: &[KeyFrameId]) -> Vec<Description> {
        let vocabulary = &self.vocabulary;
        let describe = |kf: &KeyFrameId| {
            let descriptors = map
                .keyframe(*kf)
                .map_or(&[][..], |k| &k.features.point_descriptors);
            describe_with(vocabulary, descriptors)
        };
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
        if kfs.len() < DESCRIBED_IN_PARALLEL_FROM || threads < 2 {
            return kfs.iter().map(describe).collect();
        }
        std::thread::scope(|scope| {
            let parts: Vec<_> = kfs
                .chunks(kfs.len().div_ceil(threads))
                .map(|part| scope.spawn(move || part.iter().map(describe).collect::<Vec<_>>()))
                .collect();
            parts
                .into_iter()
                .flat_map(|part| {
                    part.join()
                        .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
                })
                .collect()
        })
    }

    /// The bag of words and the feature vector of an image's `descriptors`.
    pub fn describe(&self, descriptors: &[Descriptor]) -> Description {
        describe_with(&self.vocabulary, descriptors)
    }

    /// The features of keyframe `kf` grouped by vocabulary node, when it was synced.
    pub fn nodes(&self, kf: KeyFrameId) -> Option<&FeatureVector> {
        self.described.get(&kf).map(|d| &d.nodes)
    }

    /// The old keyframes that look like `current`, best first: not covisible with it,
    /// at least `min_keyframe_gap` keyframes older, scoring at least as well as its
    /// least similar connected neighbour; at most `max_candidates`. Call after
    /// [`Self::sync`].
    pub fn candidates(
        &self,
        map: &Map,
        current: KeyFrameId,
        config: &LoopClosingConfig,
    ) -> Vec<KeyFrameId> {
        let Some(bow) = self.described.get(&current).map(|d| &d.bow) else {
            return Vec::new();
        };
        let covisible: Vec<KeyFrameId> = map
            .covisible(current, 1)
            .into_iter()
            .map(|(k, _)| k)
            .collect();
        let min_score = map
            .connected(current)
            .iter()
            .filter_map(|(k, _)| self.described.get(k))
            .map(|other| score(bow, &other.bow))
            .fold(1.0, f64::min);
        let too_recent = |k: KeyFrameId| k.0 + config.min_keyframe_gap > current.0;
        self.database
            .query(bow, config.max_candidates, |k| {
                too_recent(k) || covisible.contains(&k)
            })
            .into_iter()
            .filter(|(_, s)| *s >= min_score)
            .map(|(k, _)| k)
            .collect()
    }

    /// The keyframes that look most like a frame of bag of words `bow` (not a keyframe
    /// of the map: a lost frame to relocalise, [`Self::describe`]), best first, at most
    /// `max_candidates`, each with at least `min_score`. Call after [`Self::sync`].
    pub fn query(&self, bow: &BowVector, max_candidates: usize, min_score: f64) -> Vec<KeyFrameId> {
        self.database
            .query(bow, max_candidates, |_| false)
            .into_iter()
            .filter(|(_, s)| *s >= min_score)
            .map(|(k, _)| k)
            .collect()
    }
}
