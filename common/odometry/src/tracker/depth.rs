//! The depth term of tracking (`[tracking] use_depth_alignment`): the frame's depth
//! aligned with the last frame's, point to plane, inside the pose optimisation; and the
//! frame's status from what the combined constraints determine.

use super::{TrackedFrame, Tracker};
use crate::map::Map;
use crate::status::TrackingStatus;
use gfs_optim::analyse_constraint;

/// Share of the associated depth pairs that must stay inliers for a frame tracked on
/// depth alone: below it the prediction was too far off for the association.
const MIN_DEPTH_INLIER_SHARE: f64 = 0.5;

impl Tracker {
    /// Re-optimises a frame tracked on features with the depth pairs added, in the
    /// coarse-to-fine passes of `[tracking.depth] max_distance_m`; skipped when the
    /// features alone constrain every direction within `weak_sigma_m`. False when the
    /// depth could not be used (no depth, no last frame).
    pub(super) fn refine_with_depth(&mut self, map: &Map, frame: &mut TrackedFrame) -> bool {
        let depth = &self.config.depth;
        if depth.weak_sigma_m > 0.0
            && analyse_constraint(
                self.solver.information(),
                depth.lever_arm_m,
                depth.weak_sigma_m,
            )
            .is_determined()
        {
            return false;
        }
        self.align_depth(map, frame)
    }

    /// Tracks a frame the features lost on its depth alone, from its current (predicted)
    /// pose and no matches; true when enough depth pairs held and they determine the
    /// pose (a direction they leave free would drift where the optimiser let it).
    pub(super) fn track_on_depth(&mut self, map: &Map, frame: &mut TrackedFrame) -> bool {
        if !self.align_depth(map, frame) {
            return false;
        }
        frame.inliers.depth > 0
            && frame.inliers.depth as f64 >= MIN_DEPTH_INLIER_SHARE * self.depth_pairs as f64
            && self.status_from_information() == TrackingStatus::Tracked
    }

    /// The coarse-to-fine association and optimisation passes.
    fn align_depth(&mut self, map: &Map, frame: &mut TrackedFrame) -> bool {
        let Some(last) = self.last.as_ref() else {
            return false;
        };
        if last.features.depth.is_empty() || frame.features.depth.is_empty() {
            return false;
        }
        for pass in 0..self.config.depth.max_distance_m.len() {
            let Some(last) = self.last.as_ref() else {
                return false;
            };
            let pairs = self.depth_associator.associate(
                &self.config.depth,
                &self.camera,
                &frame.features.depth,
                &frame.camera_from_world,
                &last.features.depth,
                &last.camera_from_world,
                self.config.depth.max_distance_m[pass],
            );
            self.depth_pairs = pairs.len();
            self.solver.set_depth(pairs);
            self.optimise(map, frame);
        }
        self.solver.set_depth(&[]);
        true
    }

    /// `Degraded` when the last optimisation's information leaves a pose direction
    /// with a standard deviation above `[tracking.depth] max_sigma_m`, else `Tracked`.
    pub(super) fn status_from_information(&self) -> TrackingStatus {
        let depth = &self.config.depth;
        let constraint = analyse_constraint(
            self.solver.information(),
            depth.lever_arm_m,
            depth.max_sigma_m,
        );
        tracing::debug!(
            worst_sigma_m = constraint.worst_sigma_m,
            pairs = self.depth_pairs,
            "pose constraint"
        );
        if constraint.is_determined() {
            TrackingStatus::Tracked
        } else {
            TrackingStatus::Degraded
        }
    }
}
