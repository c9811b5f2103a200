//! Pose-only optimisation for tracking (paper eq. 6-9): the camera pose that minimises
//! the Huber-robustified point reprojection and line endpoint-to-line errors against
//! fixed map points and lines, by Levenberg-Marquardt on SE(3) (6x6 normal equations),
//! in several rounds with chi-square outlier rejection (ORB-SLAM2
//! `PoseOptimization`: 4 rounds x 10 iterations, every observation re-classified at the
//! end of each round, the kernel dropped after the second round).
//!
//! The rounds live here; the LM loop (`lm`) sees only normal equations and costs;
//! each term kind (points, lines, depth pairs, planes, photometric, the prior) is one
//! block in `blocks` with its cost, linearisation and classification together, and
//! `problem` runs them in a fixed order so that the sums, and the results, do not
//! depend on how the code is split.

mod blocks;
mod config;
mod correlation;
mod lm;
mod observations;
mod problem;
mod result;

pub use config::PoseOptimizerConfig;
pub use observations::{
    DepthObservation, LineObservation, PhotometricObservation, PhotometricScratch, PhotometricTerm,
    PlaneObservation, PointObservation, SurfaceObservations,
};
pub use result::PoseResult;

use blocks::Gate;
use gfs_core::camera::PinholeCamera;
use nalgebra::Isometry3;
use problem::PoseProblem;

/// Optimises the pose of a frame against fixed map points and lines.
///
/// Starts from `initial_camera_from_world`, writes the pose, the inlier flags and the
/// statistics into `result` (its vectors are reused). Never fails: observations behind
/// the camera or with non-finite values are outliers, and with no usable observation the
/// initial pose comes back with `converged == false`.
pub fn optimize_pose(
    camera: &PinholeCamera,
    initial_camera_from_world: &Isometry3<f64>,
    points: &[PointObservation],
    lines: &[LineObservation],
    config: &PoseOptimizerConfig,
    result: &mut PoseResult,
) {
    optimize_pose_with_depth(
        camera,
        initial_camera_from_world,
        points,
        lines,
        SurfaceObservations::default(),
        config,
        result,
    );
}

/// [`optimize_pose`] with depth point-to-plane and plane-to-plane observations as
/// further residual blocks, robustified and outlier-rejected like the others
/// (`depth_chi2`, `plane_chi2`). When every observation ends an outlier, the pose is the
/// initial one.
pub fn optimize_pose_with_depth(
    camera: &PinholeCamera,
    initial_camera_from_world: &Isometry3<f64>,
    points: &[PointObservation],
    lines: &[LineObservation],
    surfaces: SurfaceObservations<'_>,
    config: &PoseOptimizerConfig,
    result: &mut PoseResult,
) {
    let problem = PoseProblem::new(camera, points, lines, surfaces, config);
    let mut pose = *initial_camera_from_world;
    problem.reset(result);
    result.iterations = 0;
    result.converged = false;
    // Every observation that can be evaluated starts as an inlier (ORB-SLAM2).
    problem.classify(&pose, Gate::Open, result);
    for round in 0..config.rounds {
        if result.inlier_count() == 0 {
            break;
        }
        let robust = round < config.robust_rounds;
        let inliers: &PoseResult = result;
        let run = lm::minimize(
            pose,
            config.iterations_per_round,
            |pose| problem.linearize(pose, inliers, robust),
            |pose| problem.cost(pose, inliers, robust),
        );
        pose = run.pose;
        result.iterations += run.iterations;
        result.converged = run.converged;
        problem.classify(&pose, Gate::ChiSquare, result);
    }
    // Every observation that moved the pose was rejected: a lone plane pair that the
    // prior made fail its test would otherwise leave its pull in the pose.
    if result.inlier_count() == 0 {
        pose = *initial_camera_from_world;
    }
    result.converged &= result.inlier_count() > 0;
    result.camera_from_world = pose;
    let posterior = problem.linearize(&pose, result, false).h;
    result.correlated_excess = problem.correlated_excess(&pose, result, config.correlation_tile_px);
    result.information = posterior - problem.prior_information(&pose) - result.correlated_excess;
    result.rms_error_px = problem.inlier_rms(&pose, result);
    result.covariance = if result.converged {
        posterior.cholesky().map(|c| c.inverse())
    } else {
        None
    };
}
