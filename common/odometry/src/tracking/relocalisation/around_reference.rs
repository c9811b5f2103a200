//! Relocalisation against some of the map's points when tracking is lost (the tracker's
//! own, around its reference keyframe): exhaustive descriptor matching of the frame's
//! keypoints that have depth to the points, then RANSAC over the 3D-3D correspondences
//! ([`crate::tracking::ransac`]). Against the whole map: [`crate::MapRelocaliser`].

use crate::frontend::features::FrameFeatures;
use crate::map::Map;
use crate::tracking::matching::match_descriptors;
use crate::tracking::ransac::{Correspondence, RigidRansac};
use gfs_core::camera::PinholeCamera;
use gfs_core::ids::MapPointId;
use nalgebra::Isometry3;

/// RANSAC hypotheses tried.
const ITERATIONS: usize = 200;
/// Matching thresholds (strict: there is no geometric prior).
const MAX_DISTANCE: u32 = 60;
const RATIO: f32 = 0.75;

/// A relocalisation hypothesis that passed RANSAC.
#[derive(Clone, Debug)]
pub struct Relocalisation {
    /// `camera_from_world` of the frame.
    pub camera_from_world: Isometry3<f64>,
    /// Inlier map point of each keypoint.
    pub point_ids: Vec<Option<MapPointId>>,
    /// Number of inliers.
    pub inliers: usize,
}

/// Finds the frame's pose among the map points `ids` of `map`, or `None` when fewer
/// than `min_inliers` correspondences agree. `seed` makes the sampling reproducible.
pub fn relocalise(
    map: &Map,
    ids: &[MapPointId],
    frame: &FrameFeatures,
    camera: &PinholeCamera,
    min_inliers: usize,
    seed: u64,
) -> Option<Relocalisation> {
    let (ids, descriptors): (Vec<MapPointId>, Vec<_>) = ids
        .iter()
        .filter_map(|id| map.point(*id).map(|p| (*id, p.descriptor)))
        .unzip();
    let mut matches = Vec::new();
    match_descriptors(
        &frame.point_descriptors,
        &descriptors,
        MAX_DISTANCE,
        RATIO,
        &mut matches,
    );
    let mut keypoints = Vec::new();
    let mut pairs = Vec::new();
    for (i, m) in matches.iter().enumerate() {
        let (Some(t), Some(kp)) = (m, frame.keypoints.get(i)) else {
            continue;
        };
        let pair = map
            .point(ids[*t])
            .and_then(|p| Correspondence::new(camera, kp, p.position));
        if let Some(pair) = pair {
            keypoints.push(i);
            pairs.push(pair);
        }
    }
    if pairs.len() < min_inliers.max(3) {
        return None;
    }
    let mut ransac = RigidRansac::default();
    let (camera_from_world, inliers) = ransac.solve(&pairs, camera, ITERATIONS, seed)?;
    let mut point_ids = vec![None; frame.keypoints.len()];
    for (i, inlier) in keypoints.iter().zip(&ransac.inliers) {
        if *inlier {
            point_ids[*i] = matches[*i].map(|t| ids[t]);
        }
    }
    (inliers >= min_inliers).then_some(Relocalisation {
        camera_from_world,
        point_ids,
        inliers,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::OdometryConfig;
    use crate::testing::{Scene, camera, first_keyframe, pose};

    #[test]
    fn a_lost_frame_is_found_in_the_map_by_its_descriptors_alone() {
        let scene = Scene::new(150, 0);
        let (map, _, _) = first_keyframe(&scene, &OdometryConfig::default());
        let truth = pose(0.2, 10f64.to_radians());
        let frame = scene.features(9, &truth);
        let ids: Vec<MapPointId> = map.point_ids().collect();
        let found = relocalise(&map, &ids, &frame, &camera(), 40, 9).expect("relocalised");
        let error = found.camera_from_world * truth.inverse();
        assert!(error.translation.vector.norm() < 1e-6, "{error}");
        let in_view = frame.keypoints.iter().filter(|k| k.depth > 0.0).count();
        assert_eq!(found.inliers, in_view);
        assert_eq!(found.point_ids.iter().flatten().count(), in_view);
        // Asking for more inliers than there are keypoints in view fails.
        assert!(relocalise(&map, &ids, &frame, &camera(), in_view + 1, 9).is_none());
    }
}
