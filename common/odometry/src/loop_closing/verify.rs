//! Geometric verification of a loop candidate: the current keyframe's keypoints with
//! depth are matched by descriptor to the map points around the candidate (it and its
//! connected keyframes), only between descriptors under the same vocabulary node
//! ([`PlacePoints`]), RANSAC over the 3D-3D pairs finds the rigid pose most of them
//! agree with ([`RigidRansac`]), and the pose optimisation on the inliers
//! ([`PoseSolver`], reprojection + depth) must keep `min_inliers` of them. The pose is
//! the current keyframe's in the frame of the candidate's side of the loop: where the
//! drift-free map says the camera is.

use super::place::PlaceIndex;
use super::place_points::PlacePoints;
use crate::frontend::features::FrameFeatures;
use crate::map::Map;
use crate::tracking::pose_solver::PoseSolver;
use crate::tracking::ransac::{Correspondence, RigidRansac};
use gfs_core::camera::PinholeCamera;
use gfs_core::ids::{KeyFrameId, MapPointId};
use gfs_place::FeatureVector;
use nalgebra::{Isometry3, Matrix6};

/// RANSAC hypotheses tried per candidate.
const ITERATIONS: usize = 200;

/// A verified loop: the current keyframe seen from the candidate's side.
#[derive(Clone, Debug)]
pub struct LoopMatch {
    /// The old keyframe the loop closes on.
    pub candidate: KeyFrameId,
    /// `camera_from_world` of the current keyframe in the candidate side's frame.
    pub camera_from_world: Isometry3<f64>,
    /// For each keypoint of the current keyframe, the candidate side's map point it
    /// matches (inliers of the pose optimisation only).
    pub point_ids: Vec<Option<MapPointId>>,
    /// Number of those matches.
    pub inliers: usize,
    /// The information of the pose from the final matches (`J^T Omega J`, left
    /// perturbation `[rho; phi]`): which directions they determine.
    pub information: Matrix6<f64>,
}

/// Reusable buffers of [`Verifier::verify`].
pub struct Verifier {
    camera: PinholeCamera,
    solver: PoseSolver,
    ransac: RigidRansac,
    place: PlacePoints,
    matches: Vec<Option<usize>>,
}

/// A frame to find in the map: its features, its keypoints grouped by vocabulary node
/// ([`PlaceIndex::describe`]) and the map points it already sees (sorted; not matched
/// again).
#[derive(Clone, Copy)]
pub struct FrameQuery<'a> {
    /// The frame's features.
    pub features: &'a FrameFeatures,
    /// Its keypoints by vocabulary node.
    pub nodes: &'a FeatureVector,
    /// Map points the frame already sees.
    pub seen: &'a [MapPointId],
}

impl Verifier {
    /// A verifier for `camera`, optimising poses with `solver`.
    pub fn new(camera: PinholeCamera, solver: PoseSolver) -> Self {
        Self {
            camera,
            solver,
            ransac: RigidRansac::default(),
            place: PlacePoints::default(),
            matches: Vec::new(),
        }
    }

    /// Verifies the loop between `current` and `candidate` (both in `places`, synced
    /// with `map`); `None` when fewer than `min_inliers` matches survive. `seed` makes
    /// RANSAC reproducible.
    pub fn verify(
        &mut self,
        map: &Map,
        places: &PlaceIndex,
        current: KeyFrameId,
        candidate: KeyFrameId,
        min_inliers: usize,
        seed: u64,
    ) -> Option<LoopMatch> {
        let keyframe = map.keyframe(current)?;
        let nodes = places.nodes(current)?;
        let mut seen: Vec<MapPointId> = keyframe.point_ids.iter().flatten().copied().collect();
        seen.sort_unstable();
        let frame = FrameQuery {
            features: &keyframe.features,
            nodes,
            seen: &seen,
        };
        self.verify_frame(map, places, frame, candidate, min_inliers, seed)
    }

    /// Verifies that a frame of `features` (its keypoints grouped by vocabulary node in
    /// `nodes`, [`PlaceIndex::describe`]) sees the place of `candidate` (the map points
    /// of it and its connected keyframes, but those in `seen`, sorted; `places` synced
    /// with `map`): the frame's pose there, or `None` when fewer than `min_inliers`
    /// matches survive. A keyframe of the map checks a loop ([`Self::verify`]); a lost
    /// frame is relocalised ([`crate::tracking::relocalisation::against_map`]).
    pub fn verify_frame(
        &mut self,
        map: &Map,
        places: &PlaceIndex,
        frame: FrameQuery,
        candidate: KeyFrameId,
        min_inliers: usize,
        seed: u64,
    ) -> Option<LoopMatch> {
        let FrameQuery {
            features,
            nodes,
            seen,
        } = frame;
        self.place.gather(map, places, candidate, seen);
        self.place
            .match_frame(nodes, &features.point_descriptors, &mut self.matches);
        let mut keypoints = Vec::new();
        let mut pairs = Vec::new();
        for (i, m) in self.matches.iter().enumerate() {
            let (Some(id), Some(kp)) =
                (m.and_then(|t| self.place.id(t)), features.keypoints.get(i))
            else {
                continue;
            };
            let pair = map
                .point(id)
                .and_then(|p| Correspondence::new(&self.camera, kp, p.position));
            if let Some(pair) = pair {
                keypoints.push((i, id));
                pairs.push(pair);
            }
        }
        if pairs.len() < min_inliers {
            return None;
        }
        let (mut camera_from_world, ransac_inliers) =
            self.ransac.solve(&pairs, &self.camera, ITERATIONS, seed)?;
        if ransac_inliers < min_inliers {
            return None;
        }
        let mut point_ids = vec![None; features.keypoints.len()];
        for ((i, id), inlier) in keypoints.iter().zip(&self.ransac.inliers) {
            if *inlier {
                point_ids[*i] = Some(*id);
            }
        }
        let mut line_ids = vec![None; features.lines.len()];
        let inliers = self.solver.solve(
            map,
            features,
            &mut camera_from_world,
            &mut point_ids,
            &mut line_ids,
        );
        (inliers.points >= min_inliers).then_some(LoopMatch {
            candidate,
            camera_from_world,
            point_ids,
            inliers: inliers.points,
            information: *self.solver.information(),
        })
    }
}
