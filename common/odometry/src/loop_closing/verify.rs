//! Geometric verification of a loop candidate: the current keyframe's keypoints with
//! depth are matched by descriptor to the map points around the candidate (it and its
//! covisible keyframes), RANSAC over the 3D-3D pairs finds the rigid pose most of them
//! agree with ([`RigidRansac`]), and the pose optimisation on the inliers
//! ([`PoseSolver`], reprojection + depth) must keep `min_inliers` of them. The pose is
//! the current keyframe's in the frame of the candidate's side of the loop: where the
//! drift-free map says the camera is.

use crate::frame::FrameFeatures;
use crate::map::Map;
use crate::matching::match_descriptors;
use crate::pose_solver::PoseSolver;
use crate::ransac::{Correspondence, RigidRansac};
use gfs_core::camera::PinholeCamera;
use gfs_core::descriptor::Descriptor;
use gfs_core::ids::{KeyFrameId, MapPointId};
use nalgebra::Isometry3;

/// RANSAC hypotheses tried per candidate.
const ITERATIONS: usize = 200;
/// Descriptor matching thresholds (strict: the pose prior is not used to match).
const MAX_DISTANCE: u32 = 50;
const RATIO: f32 = 0.75;

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
}

/// Matches a frame's descriptors (first) to a place's (second): for each of the frame's,
/// the index of the place's it matches.
pub type DescriptorMatcher<'a> = dyn Fn(&[Descriptor], &[Descriptor], &mut Vec<Option<usize>>) + 'a;

/// Reusable buffers of [`Verifier::verify`].
pub struct Verifier {
    camera: PinholeCamera,
    solver: PoseSolver,
    ransac: RigidRansac,
    matches: Vec<Option<usize>>,
}

impl Verifier {
    /// A verifier for `camera`, optimising poses with `solver`.
    pub fn new(camera: PinholeCamera, solver: PoseSolver) -> Self {
        Self {
            camera,
            solver,
            ransac: RigidRansac::default(),
            matches: Vec::new(),
        }
    }

    /// Verifies the loop between `current` and `candidate`; `None` when fewer than
    /// `min_inliers` matches survive. `seed` makes RANSAC reproducible.
    pub fn verify(
        &mut self,
        map: &Map,
        current: KeyFrameId,
        candidate: KeyFrameId,
        min_inliers: usize,
        seed: u64,
    ) -> Option<LoopMatch> {
        let keyframe = map.keyframe(current)?;
        let mut seen: Vec<MapPointId> = keyframe.point_ids.iter().flatten().copied().collect();
        seen.sort_unstable();
        let exhaustive = |frame: &[Descriptor], place: &[Descriptor], out: &mut Vec<_>| {
            match_descriptors(frame, place, MAX_DISTANCE, RATIO, out);
        };
        self.verify_frame(
            map,
            &keyframe.features,
            &seen,
            candidate,
            &exhaustive,
            min_inliers,
            seed,
        )
    }

    /// Verifies that a frame of `features` sees the place of `candidate` (the map
    /// points of it and its connected keyframes, but those in `seen`, sorted): the
    /// frame's pose there, or `None` when fewer than `min_inliers` matches survive.
    /// `matcher` matches the frame's descriptors to the place's (the place point of
    /// each keypoint, by index).
    /// A keyframe of the map checks a loop ([`Self::verify`]); a lost frame is
    /// relocalised ([`crate::map_relocalisation`]).
    #[expect(
        clippy::too_many_arguments,
        reason = "the frame, the place and how to match them, the acceptance and the seed"
    )]
    pub fn verify_frame(
        &mut self,
        map: &Map,
        features: &FrameFeatures,
        seen: &[MapPointId],
        candidate: KeyFrameId,
        matcher: &DescriptorMatcher<'_>,
        min_inliers: usize,
        seed: u64,
    ) -> Option<LoopMatch> {
        // Ids and descriptors side by side, so that a match's index names its point.
        let (ids, descriptors): (Vec<MapPointId>, Vec<_>) = place_points(map, candidate, seen)
            .into_iter()
            .filter_map(|id| map.point(id).map(|p| (id, p.descriptor)))
            .unzip();
        matcher(&features.point_descriptors, &descriptors, &mut self.matches);
        let mut keypoints = Vec::new();
        let mut pairs = Vec::new();
        for (i, m) in self.matches.iter().enumerate() {
            let (Some(t), Some(kp)) = (m, features.keypoints.get(i)) else {
                continue;
            };
            let pair = map
                .point(ids[*t])
                .and_then(|p| Correspondence::new(&self.camera, kp, p.position));
            if let Some(pair) = pair {
                keypoints.push((i, ids[*t]));
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
        })
    }
}

/// The map points of `candidate` and its connected keyframes but those in `seen`
/// (sorted), in increasing id order.
fn place_points(map: &Map, candidate: KeyFrameId, seen: &[MapPointId]) -> Vec<MapPointId> {
    let mut ids = map.place_points(candidate);
    ids.retain(|id| seen.binary_search(id).is_err());
    ids
}
