//! Relocalisation of a lost frame against the whole map, in the mapping half that owns
//! it (the tracker holds only what the mapper sends it, and relocalises there first,
//! [`crate::tracking::relocalisation::around_reference`]). As ORB-SLAM2's `Relocalization`: the keyframes that look like
//! the frame by bag of words ([`PlaceIndex`], every keyframe of the map) are verified
//! one after the other as a loop candidate is ([`Verifier::verify_frame`]: descriptor
//! matching to the points around each, only between descriptors under the same
//! vocabulary node, RANSAC with depth and the pose optimisation); the candidate with the
//! most inliers gives the pose.

use crate::config::OdometryConfig;
use crate::frontend::features::FrameFeatures;
use crate::loop_closing::{FrameQuery, PlaceIndex, Verifier};
use crate::map::Map;
use crate::tracking::matching::ScalePyramid;
use crate::tracking::pose_solver::PoseSolver;
use gfs_core::camera::PinholeCamera;
use gfs_core::ids::{KeyFrameId, MapPointId};
use nalgebra::Isometry3;

/// Keyframes verified per lost frame, the most similar first.
const CANDIDATES: usize = 5;

/// A lost frame found in the map.
#[derive(Clone, Debug)]
pub struct MapRelocalisation {
    /// The keyframe whose place the frame sees.
    pub keyframe: KeyFrameId,
    /// `camera_from_world` of the frame.
    pub camera_from_world: Isometry3<f64>,
    /// The map point of each keypoint (inliers of the pose optimisation only).
    pub point_ids: Vec<Option<MapPointId>>,
    /// Number of those.
    pub inliers: usize,
}

/// The map's keyframes as bags of words and the verification of a lost frame.
pub struct MapRelocaliser {
    places: PlaceIndex,
    verifier: Verifier,
    min_inliers: usize,
}

impl MapRelocaliser {
    /// A relocaliser for `camera` whose keypoints come from the pyramid `scale`; a pose
    /// needs `[tracking] relocalisation_min_inliers` point inliers.
    pub fn new(config: &OdometryConfig, camera: PinholeCamera, scale: ScalePyramid) -> Self {
        let solver = PoseSolver::new(config.tracking.pose.clone(), camera, scale);
        Self {
            places: PlaceIndex::default(),
            verifier: Verifier::new(camera, solver),
            min_inliers: config.tracking.relocalisation_min_inliers,
        }
    }

    /// Takes in the keyframes added to and removed from `map` since the last call (all
    /// of them after a restart or a reset), so that a query costs only the lost frame.
    pub fn sync(&mut self, map: &Map) {
        self.places.sync(map);
    }

    /// Finds the frame of `features` in `map`, or `None` when no candidate keeps
    /// enough inliers. `seed` makes RANSAC reproducible.
    pub fn relocalise(
        &mut self,
        map: &Map,
        features: &FrameFeatures,
        seed: u64,
    ) -> Option<MapRelocalisation> {
        self.sync(map);
        let frame = self.places.describe(&features.point_descriptors);
        let candidates = self.places.query(&frame.bow, CANDIDATES, 0.0);
        let mut best: Option<MapRelocalisation> = None;
        for candidate in candidates {
            let Some(found) = self.verifier.verify_frame(
                map,
                &self.places,
                FrameQuery {
                    features,
                    nodes: &frame.nodes,
                    seen: &[],
                },
                candidate,
                self.min_inliers,
                seed,
            ) else {
                continue;
            };
            if best.as_ref().is_none_or(|b| found.inliers > b.inliers) {
                best = Some(MapRelocalisation {
                    keyframe: found.candidate,
                    camera_from_world: found.camera_from_world,
                    point_ids: found.point_ids,
                    inliers: found.inliers,
                });
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{Scene, camera, first_keyframe, pose, scale};

    #[test]
    fn a_frame_of_a_mapped_place_is_found_and_one_of_another_place_is_not() {
        let config = OdometryConfig::default();
        let scene = Scene::new(300, 0);
        let (map, _, kf) = first_keyframe(&scene, &config);
        let mut relocaliser = MapRelocaliser::new(&config, camera(), scale());
        let truth = pose(0.15, 8f64.to_radians());
        let found = relocaliser
            .relocalise(&map, &scene.features(7, &truth), 7)
            .expect("relocalised");
        assert_eq!(found.keyframe, kf);
        let error = found.camera_from_world * truth.inverse();
        assert!(error.translation.vector.norm() < 1e-6, "{error}");
        assert!(found.inliers >= config.tracking.relocalisation_min_inliers);
        // The same geometry with other descriptors: another place.
        let mut elsewhere = scene.features(8, &truth);
        for d in &mut elsewhere.point_descriptors {
            d[0] = !d[0];
            d[3] = !d[3];
        }
        assert!(relocaliser.relocalise(&map, &elsewhere, 8).is_none());
    }
}
