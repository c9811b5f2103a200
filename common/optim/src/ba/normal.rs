//! The blocks of the BA normal equations at one estimate, and the step of every
//! variable.

use super::problem::BaProblem;
use nalgebra::{Matrix3, Matrix6, Matrix6x3, Vector3, Vector6};

/// The blocks of `J^T W J` and `J^T W e` at one estimate.
#[derive(Debug, Default)]
pub(crate) struct Linearization {
    pub(crate) cost: f64,
    pub(crate) h_pose: Vec<Matrix6<f64>>,
    pub(crate) g_pose: Vec<Vector6<f64>>,
    pub(crate) h_point: Vec<Matrix3<f64>>,
    pub(crate) g_point: Vec<Vector3<f64>>,
    pub(crate) h_line: Vec<Matrix6<f64>>,
    pub(crate) g_line: Vec<Vector6<f64>>,
    pub(crate) h_plane: Vec<Matrix3<f64>>,
    pub(crate) g_plane: Vec<Vector3<f64>>,
    /// Pose-plane block `H_pq` of each plane observation (free pose only).
    pub(crate) w_plane_obs: Vec<Matrix6x3<f64>>,
    /// Pose-point block `H_px` of each point observation (free pose only).
    pub(crate) w_point_obs: Vec<Matrix6x3<f64>>,
    /// Pose-line block `H_pl` of each line observation (free pose only).
    pub(crate) w_line_obs: Vec<Matrix6<f64>>,
    /// Line-line block `H_ij` of each parallel pair.
    pub(crate) h_parallel: Vec<Matrix6<f64>>,
    /// Line-line block `H_ij` of each perpendicular pair.
    pub(crate) h_perpendicular: Vec<Matrix6<f64>>,
    /// Plane-plane block `H_ij` of each parallel plane pair.
    pub(crate) h_plane_parallel: Vec<Matrix3<f64>>,
    /// Plane-plane block `H_ij` of each perpendicular plane pair.
    pub(crate) h_plane_perpendicular: Vec<Matrix3<f64>>,
}

impl Linearization {
    pub(crate) fn resize(&mut self, p: &BaProblem) {
        self.h_pose.resize(p.poses.len(), Matrix6::zeros());
        self.g_pose.resize(p.poses.len(), Vector6::zeros());
        self.h_point.resize(p.points.len(), Matrix3::zeros());
        self.g_point.resize(p.points.len(), Vector3::zeros());
        self.h_line.resize(p.lines.len(), Matrix6::zeros());
        self.g_line.resize(p.lines.len(), Vector6::zeros());
        self.h_plane.resize(p.planes.len(), Matrix3::zeros());
        self.g_plane.resize(p.planes.len(), Vector3::zeros());
        self.w_plane_obs
            .resize(p.plane_observations.len(), Matrix6x3::zeros());
        self.w_point_obs
            .resize(p.point_observations.len(), Matrix6x3::zeros());
        self.w_line_obs
            .resize(p.line_observations.len(), Matrix6::zeros());
        self.h_parallel.resize(p.parallel.len(), Matrix6::zeros());
        self.h_perpendicular
            .resize(p.perpendicular.len(), Matrix6::zeros());
        self.h_plane_parallel
            .resize(p.plane_parallel.len(), Matrix3::zeros());
        self.h_plane_perpendicular
            .resize(p.plane_perpendicular.len(), Matrix3::zeros());
    }

    /// Zeroes the sums. The pose-landmark blocks are left as they are: the linearisation
    /// writes one for every active observation of a free pose, the only ones read.
    pub(crate) fn clear(&mut self) {
        self.cost = 0.0;
        self.h_pose.fill(Matrix6::zeros());
        self.g_pose.fill(Vector6::zeros());
        self.h_point.fill(Matrix3::zeros());
        self.g_point.fill(Vector3::zeros());
        self.h_line.fill(Matrix6::zeros());
        self.g_line.fill(Vector6::zeros());
        self.h_plane.fill(Matrix3::zeros());
        self.g_plane.fill(Vector3::zeros());
        self.h_parallel.fill(Matrix6::zeros());
        self.h_perpendicular.fill(Matrix6::zeros());
        self.h_plane_parallel.fill(Matrix3::zeros());
        self.h_plane_perpendicular.fill(Matrix3::zeros());
    }
}

/// The step of every variable (zero for fixed or unconstrained ones).
#[derive(Debug, Default)]
pub(crate) struct Step {
    pub(crate) pose: Vec<Vector6<f64>>,
    pub(crate) point: Vec<Vector3<f64>>,
    pub(crate) line: Vec<Vector6<f64>>,
    pub(crate) plane: Vec<Vector3<f64>>,
}
