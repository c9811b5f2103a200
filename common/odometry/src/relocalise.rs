//! Relocalisation against the map when tracking is lost: exhaustive descriptor matching
//! of the frame's keypoints that have depth to the map points, then RANSAC over the
//! 3D-3D correspondences ([`crate::ransac`]).

use crate::frame::FrameFeatures;
use crate::map::Map;
use crate::matching::match_descriptors;
use crate::ransac::{Correspondence, RigidRansac};
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

/// Finds the frame's pose in `map`, or `None` when fewer than `min_inliers`
/// correspondences agree. `seed` makes the sampling reproducible.
pub fn relocalise(
    map: &Map,
    frame: &FrameFeatures,
    camera: &PinholeCamera,
    min_inliers: usize,
    seed: u64,
) -> Option<Relocalisation> {
    let ids: Vec<MapPointId> = map.point_ids().collect();
    let descriptors: Vec<_> = ids
        .iter()
        .filter_map(|id| map.point(*id).map(|p| p.descriptor))
        .collect();
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
