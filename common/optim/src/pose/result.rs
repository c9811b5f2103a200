//! The output of the pose optimiser, reused across frames so that its inlier flags keep
//! their buffers.

use nalgebra::{Isometry3, Matrix6, Vector6};

#[cfg(doc)]
use super::PoseOptimizerConfig;

#[cfg(doc)]
use super::optimize_pose;

/// Output of [`optimize_pose`]; reuse one value across frames to keep its buffers.
#[derive(Clone, Debug, Default)]
pub struct PoseResult {
    /// The estimated `camera_from_world` (the last estimate when not converged, the
    /// initial one when every observation ended an outlier).
    pub camera_from_world: Isometry3<f64>,
    /// Per point observation (same order as the input): inlier at the final pose.
    pub point_inliers: Vec<bool>,
    /// Per line observation (same order as the input): inlier at the final pose.
    pub line_inliers: Vec<bool>,
    /// Number of `true` in `point_inliers`.
    pub num_point_inliers: usize,
    /// Number of `true` in `line_inliers`.
    pub num_line_inliers: usize,
    /// Per depth observation (same order as the input): inlier at the final pose.
    pub depth_inliers: Vec<bool>,
    /// Number of `true` in `depth_inliers`.
    pub num_depth_inliers: usize,
    /// Per plane observation (same order as the input): inlier at the final pose.
    pub plane_inliers: Vec<bool>,
    /// Number of `true` in `plane_inliers`.
    pub num_plane_inliers: usize,
    /// Per photometric observation (same order as the input): inlier at the final pose.
    pub photometric_inliers: Vec<bool>,
    /// Number of `true` in `photometric_inliers`.
    pub num_photometric_inliers: usize,
    /// Information matrix `J^T Omega J` of the inliers at the final pose (no kernel,
    /// no prior), in the left perturbation `[rho; phi]`: which directions the data
    /// constrain; less [`Self::correlated_excess`].
    pub information: Matrix6<f64>,
    /// What the dense terms (photometric, depth pairs) would lend beyond what the
    /// spread of their scores over image tiles supports, their errors being correlated
    /// across the image (see [`PoseOptimizerConfig::correlation_tile_px`]); already
    /// taken out of [`Self::information`].
    pub correlated_excess: Matrix6<f64>,
    /// The tiles' scores of the last term whose excess was measured (reused buffer).
    pub(crate) tile_scores: Vec<Vector6<f64>>,
    /// RMS of the inliers' residual components (point u / v / disparity errors, line
    /// endpoint distances), pixels, unweighted; 0 without inliers.
    pub rms_error_px: f64,
    /// LM iterations run over all rounds.
    pub iterations: usize,
    /// True when the last round's LM converged (small relative cost decrease or no
    /// further decrease possible) with at least one inlier; false otherwise, with
    /// the last estimate still in `camera_from_world` (the tracker may mark the frame
    /// degraded).
    pub converged: bool,
    /// Covariance of the converged pose: the inverse of the information `J^T W J` of
    /// the final inliers at the solution (no robust weights) and the prior, over the left
    /// perturbation `exp(delta) * camera_from_world`, `delta` = (translation, rotation)
    /// in the camera frame. `None` when not converged or the information is singular.
    pub covariance: Option<Matrix6<f64>>,
}

impl PoseResult {
    /// Inliers of every kind.
    pub fn inlier_count(&self) -> usize {
        self.num_point_inliers
            + self.num_line_inliers
            + self.num_depth_inliers
            + self.num_plane_inliers
            + self.num_photometric_inliers
    }
}
