//! The place around a keyframe as a verification matches it: the map points of the
//! keyframe and its connected keyframes ([`Map::place_keyframes`]), each under the
//! vocabulary nodes of its keypoints in those keyframes, and a frame's descriptors
//! matched to the points' only under a shared node ([`match_by_nodes`], ORB-SLAM2's
//! `SearchByBoW`). The nodes come from the feature vectors the [`PlaceIndex`] keeps per
//! keyframe: no descriptor is put through the vocabulary again.

use super::place::PlaceIndex;
use crate::map::Map;
use gfs_core::descriptor::Descriptor;
use gfs_core::ids::{KeyFrameId, MapPointId};
use gfs_place::{FeatureVector, NodeMatchConfig, match_by_nodes};

/// Matching thresholds (strict: the pose prior is not used to match): Hamming distance
/// at most 50, best below 0.75 of the second best under the node (ORB-SLAM2's
/// `SearchByBoW` for loops).
const MATCHING: NodeMatchConfig = NodeMatchConfig {
    max_distance: 50,
    ratio: 0.75,
};

/// The points of one place with their descriptors and nodes; the point, descriptor and
/// match buffers are reused from one place to the next.
#[derive(Debug, Default)]
pub struct PlacePoints {
    /// The place's map points, sorted by id.
    ids: Vec<MapPointId>,
    /// Their descriptors, by index in `ids`.
    descriptors: Vec<Descriptor>,
    /// Indices in `ids` grouped by node.
    nodes: FeatureVector,
    /// `(frame feature, place point)` pairs of the last match.
    pairs: Vec<(u32, u32)>,
}

impl PlacePoints {
    /// Takes the place of `candidate`: the points of it and its connected keyframes but
    /// those in `seen` (sorted), each under the node of every keypoint that observes it
    /// in a keyframe `places` holds (call [`PlaceIndex::sync`] first).
    pub fn gather(
        &mut self,
        map: &Map,
        places: &PlaceIndex,
        candidate: KeyFrameId,
        seen: &[MapPointId],
    ) {
        let keyframes = map.place_keyframes(candidate);
        self.ids.clear();
        self.descriptors.clear();
        for id in map.points_seen_by(&keyframes) {
            if seen.binary_search(&id).is_ok() {
                continue;
            }
            if let Some(point) = map.point(id) {
                self.ids.push(id);
                self.descriptors.push(point.descriptor);
            }
        }
        let mut pairs = Vec::new();
        for kf in keyframes {
            let (Some(keyframe), Some(nodes)) = (map.keyframe(kf), places.nodes(kf)) else {
                continue;
            };
            for (node, features) in nodes.groups() {
                for &f in features {
                    let Some(Some(id)) = keyframe.point_ids.get(f as usize) else {
                        continue;
                    };
                    if let Ok(i) = self.ids.binary_search(id) {
                        pairs.push((*node, i as u32));
                    }
                }
            }
        }
        self.nodes = FeatureVector::from_pairs(pairs);
    }

    /// The map point of index `i`.
    pub fn id(&self, i: usize) -> Option<MapPointId> {
        self.ids.get(i).copied()
    }

    /// Matches a frame's `descriptors`, grouped by node in `frame_nodes` (at
    /// [`super::place::NODE_LEVEL`]), to the place's points: `out[f]` is the index of the
    /// point feature `f` matches, each point matched at most once.
    pub fn match_frame(
        &mut self,
        frame_nodes: &FeatureVector,
        descriptors: &[Descriptor],
        out: &mut Vec<Option<usize>>,
    ) {
        match_by_nodes(
            frame_nodes,
            descriptors,
            &self.nodes,
            &self.descriptors,
            &MATCHING,
            &mut self.pairs,
        );
        out.clear();
        out.resize(descriptors.len(), None);
        for &(f, p) in &self.pairs {
            if let Some(slot) = out.get_mut(f as usize) {
                *slot = Some(p as usize);
            }
        }
    }
}
