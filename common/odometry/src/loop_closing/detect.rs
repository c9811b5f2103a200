//! Loop candidates: old keyframes that may show the place the current keyframe shows.
//!
//! A candidate is a keyframe at least `min_keyframe_gap` keyframes older than the current
//! one, not covisible with it (a place left and come back to, not the place being
//! mapped), whose camera is within `search_radius_m` and looks within `search_angle_deg`
//! of the current camera in the drifted estimate. This pose prior is enough while the
//! drift of a loop stays below the radius; appearance-based candidates (bag of words)
//! widen it. Every candidate is verified geometrically before it is believed.

use crate::config::LoopClosingConfig;
use crate::map::Map;
use gfs_core::ids::KeyFrameId;
use nalgebra::Vector3;

/// The candidates of keyframe `current`, nearest first, at most `max_candidates`.
pub fn proximity_candidates(
    map: &Map,
    current: KeyFrameId,
    config: &LoopClosingConfig,
) -> Vec<KeyFrameId> {
    let Some(keyframe) = map.keyframe(current) else {
        return Vec::new();
    };
    let pose = keyframe.world_from_camera();
    let axis = pose.rotation * Vector3::z();
    let covisible: Vec<KeyFrameId> = map
        .covisible(current, 1)
        .into_iter()
        .map(|(k, _)| k)
        .collect();
    let min_cos = config.search_angle_deg.to_radians().cos();
    let mut near: Vec<(f64, KeyFrameId)> = map
        .keyframes()
        .filter(|k| k.id.0 + config.min_keyframe_gap <= current.0 && !covisible.contains(&k.id))
        .filter_map(|k| {
            let other = k.world_from_camera();
            let distance = (other.translation.vector - pose.translation.vector).norm();
            let facing = (other.rotation * Vector3::z()).dot(&axis);
            (distance <= config.search_radius_m && facing >= min_cos).then_some((distance, k.id))
        })
        .collect();
    near.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    near.into_iter()
        .take(config.max_candidates)
        .map(|(_, k)| k)
        .collect()
}
