//! Relocalisation against the map when tracking is lost: exhaustive descriptor matching
//! of the frame's keypoints that have depth to the map points, then RANSAC over
//! 3D-3D correspondences (camera-frame points from depth vs. world points) with the
//! Kabsch alignment, scored by reprojection error.

use crate::frame::FrameFeatures;
use crate::map::Map;
use crate::matching::match_descriptors;
use gfs_core::align::rigid_transform;
use gfs_core::camera::PinholeCamera;
use gfs_core::ids::MapPointId;
use nalgebra::{Isometry3, Point3};

/// RANSAC hypotheses tried.
const ITERATIONS: usize = 200;
/// Reprojection error of an inlier, pixels.
const INLIER_PX: f64 = 4.0;
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
    let mut pairs: Vec<(usize, Point3<f64>, Point3<f64>)> = Vec::new();
    for (i, m) in matches.iter().enumerate() {
        let (Some(t), Some(kp)) = (m, frame.keypoints.get(i)) else {
            continue;
        };
        if kp.depth <= 0.0 {
            continue;
        }
        let Some(point) = map.point(ids[*t]) else {
            continue;
        };
        let p_c = camera.back_project(f64::from(kp.u), f64::from(kp.v), f64::from(kp.depth));
        pairs.push((i, p_c, point.position));
    }
    if pairs.len() < min_inliers.max(3) {
        return None;
    }
    let mut rng = SplitMix64(seed);
    let mut best: Option<(usize, Isometry3<f64>)> = None;
    let (mut src, mut dst) = (Vec::with_capacity(3), Vec::with_capacity(3));
    for _ in 0..ITERATIONS {
        src.clear();
        dst.clear();
        for _ in 0..3 {
            let k = (rng.next() % pairs.len() as u64) as usize;
            src.push(pairs[k].2);
            dst.push(pairs[k].1);
        }
        let Some(camera_from_world) = rigid_transform(&src, &dst) else {
            continue;
        };
        let count = count_inliers(&pairs, frame, camera, &camera_from_world, None);
        if best.as_ref().is_none_or(|(n, _)| count > *n) {
            best = Some((count, camera_from_world));
        }
    }
    let (_, hypothesis) = best?;
    let mut inlier_flags = vec![false; pairs.len()];
    count_inliers(&pairs, frame, camera, &hypothesis, Some(&mut inlier_flags));
    src.clear();
    dst.clear();
    for (pair, inlier) in pairs.iter().zip(&inlier_flags) {
        if *inlier {
            src.push(pair.2);
            dst.push(pair.1);
        }
    }
    let refined = rigid_transform(&src, &dst)?;
    count_inliers(&pairs, frame, camera, &refined, Some(&mut inlier_flags));
    let mut point_ids = vec![None; frame.keypoints.len()];
    let mut inliers = 0;
    for (pair, inlier) in pairs.iter().zip(&inlier_flags) {
        if *inlier {
            point_ids[pair.0] = matches[pair.0].map(|t| ids[t]);
            inliers += 1;
        }
    }
    (inliers >= min_inliers).then_some(Relocalisation {
        camera_from_world: refined,
        point_ids,
        inliers,
    })
}

fn count_inliers(
    pairs: &[(usize, Point3<f64>, Point3<f64>)],
    frame: &FrameFeatures,
    camera: &PinholeCamera,
    camera_from_world: &Isometry3<f64>,
    mut flags: Option<&mut Vec<bool>>,
) -> usize {
    let mut count = 0;
    for (k, (i, _, p_w)) in pairs.iter().enumerate() {
        let kp = &frame.keypoints[*i];
        let inlier = camera
            .project(&(camera_from_world * p_w))
            .is_some_and(|uv| (uv.x - f64::from(kp.u)).hypot(uv.y - f64::from(kp.v)) < INLIER_PX);
        if let Some(flags) = flags.as_deref_mut() {
            flags[k] = inlier;
        }
        count += usize::from(inlier);
    }
    count
}

/// A tiny deterministic generator for RANSAC sampling (splitmix64).
struct SplitMix64(u64);

impl SplitMix64 {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
}
