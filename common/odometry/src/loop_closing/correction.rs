//! A verified loop's correction as a value ([`LoopCorrection`]), and its application to
//! a map ([`apply_correction`]). Inline, the correction is applied to the map it was
//! computed on; in the pipeline the loop stage computes it on a map the mapper has grown
//! since, so keyframes made after it follow their corrected neighbours.

use super::LoopClosure;
use crate::map::Map;
use gfs_core::ids::{KeyFrameId, MapPointId};
use nalgebra::Isometry3;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// What closing a verified loop does to the map.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LoopCorrection {
    /// The keyframe that came back.
    pub current: KeyFrameId,
    /// The old keyframe it closed on.
    pub candidate: KeyFrameId,
    /// Point inliers of the verification.
    pub inliers: usize,
    /// True when the bag of words proposed the candidate.
    pub by_appearance: bool,
    /// The corrected `world_from_camera` of every keyframe of the graph, in id order.
    pub poses: Vec<(KeyFrameId, Isometry3<f64>)>,
    /// The current keyframe's keypoints (by index) and the old side's points they match.
    pub matches: Vec<(usize, MapPointId)>,
    /// [`Map::corrections`] of the map it was computed on: a correction computed before
    /// another one was applied is stale.
    pub map_corrections: u64,
}

/// Applies `correction` to `map`: the graph's keyframes take their corrected pose, newer
/// keyframes move with their newest corrected neighbour, every landmark with its
/// reference keyframe, and the current keyframe's matches are fused into the old
/// points. Returns the loop closed, or `None` (the map unchanged) when the correction is
/// stale or its current keyframe is gone.
pub fn apply_correction(map: &mut Map, correction: &LoopCorrection) -> Option<LoopClosure> {
    if map.corrections() != correction.map_corrections {
        tracing::warn!(
            keyframe = %correction.current,
            "loop correction dropped: computed before the last correction"
        );
        return None;
    }
    if !correction.poses.iter().all(|(_, pose)| finite(pose)) {
        tracing::warn!(keyframe = %correction.current, "loop correction dropped: a pose is not finite");
        return None;
    }
    let before = map.keyframe(correction.current)?.world_from_camera();
    let mut moved: HashMap<KeyFrameId, Isometry3<f64>> =
        HashMap::with_capacity(correction.poses.len());
    for (kf, new) in &correction.poses {
        if let Some(k) = map.keyframe_mut(*kf) {
            let new_from_old = new * k.world_from_camera().inverse();
            k.camera_from_world = new.inverse();
            k.loop_correction = new_from_old * k.loop_correction;
            moved.insert(*kf, new_from_old);
        }
    }
    follow_newest_neighbours(map, &mut moved);
    map.move_landmarks(|first_kf| moved.get(&first_kf).copied());
    map.count_correction();
    fuse_matches(map, correction);
    let after = map.keyframe(correction.current)?.world_from_camera();
    let closure = LoopClosure {
        current: correction.current,
        candidate: correction.candidate,
        inliers: correction.inliers,
        shift_m: (after.translation.vector - before.translation.vector).norm(),
        by_appearance: correction.by_appearance,
    };
    tracing::info!(
        keyframe = %closure.current,
        candidate = %closure.candidate,
        inliers = closure.inliers,
        shift_m = closure.shift_m,
        by_appearance = closure.by_appearance,
        "loop closed"
    );
    Some(closure)
}

fn finite(pose: &Isometry3<f64>) -> bool {
    let rotation = pose.rotation.coords.iter();
    pose.translation
        .vector
        .iter()
        .chain(rotation)
        .all(|v| v.is_finite())
}

/// Keyframes the correction does not know (made after its map) move as their newest
/// moved neighbour in the covisibility graph did, or as the newest moved keyframe when
/// none is connected (the chain of keyframes is their spanning tree).
fn follow_newest_neighbours(map: &mut Map, moved: &mut HashMap<KeyFrameId, Isometry3<f64>>) {
    for kf in map.keyframe_ids() {
        if moved.contains_key(&kf) {
            continue;
        }
        let neighbour = map
            .connected(kf)
            .into_iter()
            .map(|(k, _)| k)
            .filter(|k| moved.contains_key(k))
            .max()
            .or_else(|| moved.keys().copied().filter(|k| *k < kf).max());
        let Some(t) = neighbour.and_then(|k| moved.get(&k).copied()) else {
            continue;
        };
        if let Some(k) = map.keyframe_mut(kf) {
            k.camera_from_world = (t * k.world_from_camera()).inverse();
            k.loop_correction = t * k.loop_correction;
            moved.insert(kf, t);
        }
    }
}

/// Links the current keyframe's keypoints to the old side's points they matched: a
/// free keypoint gets the observation, one with a point of its own has that point merged
/// into the old one (the old side is the drift-free one).
fn fuse_matches(map: &mut Map, correction: &LoopCorrection) {
    let kf = correction.current;
    for &(i, old) in &correction.matches {
        let own = map
            .keyframe(kf)
            .and_then(|k| k.point_ids.get(i).copied().flatten());
        match own {
            None => {
                map.link(old, kf, i);
            }
            Some(own) if own != old => map.merge(own, old),
            Some(_) => {}
        }
    }
}
