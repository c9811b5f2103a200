//! Appearance-based loop candidates: every keyframe of the map as a bag of words
//! ([`gfs_place::Vocabulary::default_orb`]) in a [`KeyFrameDatabase`]; a query returns
//! the old keyframes that look most like the current one. As in ORB-SLAM2's
//! `DetectLoop`, a candidate must score at least as well as the current keyframe's
//! least similar connected neighbour (a place is at least as like itself as its own
//! neighbourhood is), which adapts the threshold to the scene's texture.

use crate::config::LoopClosingConfig;
use crate::map::{IdMap, Map};
use gfs_core::ids::KeyFrameId;
use gfs_place::{BowVector, KeyFrameDatabase, Vocabulary, score};

/// The keyframes of the map as bags of words, kept in step with the map.
pub struct PlaceIndex {
    vocabulary: Vocabulary,
    database: KeyFrameDatabase<KeyFrameId>,
    bows: IdMap<KeyFrameId, BowVector>,
}

impl Default for PlaceIndex {
    fn default() -> Self {
        let vocabulary = Vocabulary::default_orb();
        Self {
            database: KeyFrameDatabase::new(vocabulary.num_words()),
            vocabulary,
            bows: IdMap::default(),
        }
    }
}

impl PlaceIndex {
    /// Drops the keyframes that left the map and adds those it does not hold yet
    /// (after a mapper restart, every keyframe of the restored map).
    pub fn sync(&mut self, map: &Map) {
        let gone: Vec<KeyFrameId> = self
            .bows
            .keys()
            .copied()
            .filter(|k| map.keyframe(*k).is_none())
            .collect();
        for kf in gone {
            self.database.remove(kf);
            self.bows.remove(&kf);
        }
        for kf in map.keyframe_ids() {
            if self.bows.contains_key(&kf) {
                continue;
            }
            if let Some(keyframe) = map.keyframe(kf) {
                let bow = self
                    .vocabulary
                    .transform(&keyframe.features.point_descriptors);
                self.database.add(kf, &bow);
                self.bows.insert(kf, bow);
            }
        }
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
        let Some(bow) = self.bows.get(&current) else {
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
            .filter_map(|(k, _)| self.bows.get(k))
            .map(|other| score(bow, other))
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

    /// The vocabulary the keyframes are described with.
    pub fn vocabulary(&self) -> &Vocabulary {
        &self.vocabulary
    }

    /// The keyframes that look most like a frame of `descriptors` (not a keyframe of the
    /// map: a lost frame to relocalise), best first, at most `max_candidates`, each with
    /// at least `min_score`. Call after [`Self::sync`].
    pub fn query(
        &self,
        descriptors: &[gfs_core::descriptor::Descriptor],
        max_candidates: usize,
        min_score: f64,
    ) -> Vec<KeyFrameId> {
        let bow = self.vocabulary.transform(descriptors);
        self.database
            .query(&bow, max_candidates, |_| false)
            .into_iter()
            .filter(|(_, s)| *s >= min_score)
            .map(|(k, _)| k)
            .collect()
    }
}
