//! The tracker's per-frame result: the pose, how it was obtained, and the landmark
//! each feature was matched to; and what a viewer draws of it ([`FrameMatches`]).

use crate::frontend::features::FrameFeatures;
use crate::tracking::pose_solver::{Inliers, PoseSolver};
use crate::tracking::status::TrackingStatus;
use gfs_core::ids::{MapLineId, MapPlaneId, MapPointId};
use nalgebra::Isometry3;

/// The result of tracking one frame.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct TrackedFrame {
    /// The frame's features.
    pub features: FrameFeatures,
    /// Estimated `camera_from_world`.
    pub camera_from_world: Isometry3<f64>,
    /// How the pose was obtained.
    pub status: TrackingStatus,
    /// Map point matched to each keypoint (inliers only).
    pub point_ids: Vec<Option<MapPointId>>,
    /// Map line matched to each line (inliers only).
    pub line_ids: Vec<Option<MapLineId>>,
    /// Map plane matched to each plane (inliers only).
    #[serde(default)]
    pub plane_ids: Vec<Option<MapPlaneId>>,
    /// Inlier counts of the final optimisation.
    pub inliers: Inliers,
}

impl TrackedFrame {
    /// The frame at `camera_from_world` with no match yet, not tracked.
    pub fn untracked(features: FrameFeatures, camera_from_world: Isometry3<f64>) -> Self {
        Self {
            point_ids: vec![None; features.keypoints.len()],
            line_ids: vec![None; features.lines.len()],
            plane_ids: vec![None; features.planes.len()],
            camera_from_world,
            status: TrackingStatus::Predicted,
            inliers: Inliers::default(),
            features,
        }
    }

    /// Puts the frame back at `camera_from_world` with no matches, for the next try.
    pub fn restart(&mut self, camera_from_world: &Isometry3<f64>) {
        self.camera_from_world = *camera_from_world;
        self.point_ids.iter_mut().for_each(|m| *m = None);
        self.line_ids.iter_mut().for_each(|m| *m = None);
        self.plane_ids.iter_mut().for_each(|m| *m = None);
    }
}

/// The last tracked frame as a viewer draws it: each matched keypoint and line, inlier
/// of the frame's pose or rejected by its last optimisation (an outlier).
#[derive(Clone, Copy, Debug)]
pub struct FrameMatches<'a> {
    /// The frame, with its inlier matches.
    pub frame: &'a TrackedFrame,
    pub(super) solver: &'a PoseSolver,
}

impl FrameMatches<'_> {
    /// `(keypoint index, inlier)` of the matched keypoints: the inliers first.
    pub fn points(&self) -> impl Iterator<Item = (usize, bool)> + '_ {
        let ids = &self.frame.point_ids;
        let inliers = ids.iter().enumerate().filter(|(_, id)| id.is_some());
        let rejected = self.solver.rejected_points(self.frame.features.id);
        inliers.map(|(i, _)| (i, true)).chain(
            rejected
                .filter(|&i| ids.get(i) == Some(&None))
                .map(|i| (i, false)),
        )
    }

    /// `(line index, inlier)` of the matched lines, as [`Self::points`].
    pub fn lines(&self) -> impl Iterator<Item = (usize, bool)> + '_ {
        let ids = &self.frame.line_ids;
        let inliers = ids.iter().enumerate().filter(|(_, id)| id.is_some());
        let rejected = self.solver.rejected_lines(self.frame.features.id);
        inliers.map(|(i, _)| (i, true)).chain(
            rejected
                .filter(|&i| ids.get(i) == Some(&None))
                .map(|i| (i, false)),
        )
    }
}
