//! One frame's inertial step: the last frame's state (pose, velocity, biases, with
//! their covariance) and the preintegrated samples since it, joined with the frame's
//! visual pose and the information its measurements give it. The nine-dimensional
//! inertial residual of `gfs_inertial` ties the two states; the biases are shared
//! across the interval (their random walk is added to the covariance after). Solved by
//! Gauss-Newton over both states, the last one's kept marginalised: the frame's pose
//! follows the images where they constrain it and the IMU where they leave a direction
//! free, and its covariance grows there as preintegration says.

use gfs_core::se3;
use gfs_inertial::preintegration::Preintegrated;
use gfs_inertial::residual::{InertialResidual, State, information, log_so3};
use nalgebra::{Isometry3, Matrix6, SMatrix, SVector, Translation3, Vector3};
use std::ops::AddAssign;

/// 15x15 over a state's `(dphi, dp, dv, dbg, dba)`.
pub type Matrix15 = SMatrix<f64, 15, 15>;
type Matrix24 = SMatrix<f64, 24, 24>;
type Vector24 = SVector<f64, 24>;

/// Gauss-Newton steps: the problem is nearly linear around the prediction.
const ITERATIONS: usize = 3;
/// Added to the normal equations' diagonal so that a direction nothing constrains
/// (never the case with a prior) cannot make them singular.
const DAMPING: f64 = 1e-12;

/// The frame's visual pose and what its measurements determine of it (`camera_from_world`
/// perturbed as `exp(delta) * pose`, `delta = [rho; phi]`, the pose solver's convention).
pub struct VisualPose<'a> {
    pub camera_from_world: Isometry3<f64>,
    pub information: &'a Matrix6<f64>,
}

/// What one step joins.
pub struct StepInput<'a> {
    /// The samples since the last frame, integrated with `last.bias`.
    pub preintegrated: &'a Preintegrated,
    pub gravity: &'a Vector3<f64>,
    /// The last frame's state and its covariance.
    pub last: &'a State,
    pub last_covariance: &'a Matrix15,
    /// `None` for a frame the images did not pose.
    pub visual: Option<VisualPose<'a>>,
    pub camera_from_imu: &'a Isometry3<f64>,
}

/// The frame's state after the step.
#[derive(Clone, Debug)]
pub struct StepOutput {
    pub state: State,
    /// Covariance of `state`, the bias walk over the interval included.
    pub covariance: Matrix15,
    /// The covariance of the frame's `camera_from_world` in the pose solver's convention.
    pub camera_covariance: Matrix6<f64>,
}

/// The frame's camera pose from the IMU's pose in the world.
pub fn camera_from_world(state: &State, camera_from_imu: &Isometry3<f64>) -> Isometry3<f64> {
    let world_from_imu = Isometry3::from_parts(
        Translation3::from(state.position),
        gfs_core::se3::rotation_from_matrix(&state.rotation),
    );
    camera_from_imu * world_from_imu.inverse()
}

/// The IMU's pose in the world from the camera's, as `(R_wb, p_wb)`.
pub fn imu_pose(
    camera_from_world: &Isometry3<f64>,
    camera_from_imu: &Isometry3<f64>,
) -> (nalgebra::Matrix3<f64>, Vector3<f64>) {
    let world_from_imu = camera_from_world.inverse() * camera_from_imu;
    (
        world_from_imu.rotation.to_rotation_matrix().into_inner(),
        world_from_imu.translation.vector,
    )
}

/// Jacobian of the camera pose's tangent (`exp(delta) * camera_from_world`) with
/// respect to the IMU's `(dphi, dp)` at `rotation` (`R_wb`): moving the IMU by
/// `T_wb Exp(xi_b)` moves the camera by `exp(-Ad(T_cb) xi_b)`, `xi_b = [R_wb^T dp; dphi]`.
fn camera_jacobian(
    rotation: &nalgebra::Matrix3<f64>,
    camera_from_imu: &Isometry3<f64>,
) -> Matrix6<f64> {
    let ad = se3::adjoint(camera_from_imu);
    let mut j = Matrix6::zeros();
    j.fixed_view_mut::<6, 3>(0, 0)
        .copy_from(&(-ad.fixed_view::<6, 3>(0, 3)));
    j.fixed_view_mut::<6, 3>(0, 3)
        .copy_from(&(-ad.fixed_view::<6, 3>(0, 0) * rotation.transpose()));
    j
}

/// Joins the last state, the samples and the frame's visual pose.
pub fn step(input: &StepInput) -> StepOutput {
    let pre = input.preintegrated;
    let inertial_information = information(pre.covariance());
    let prior_information = scaled_inverse(input.last_covariance).unwrap_or_else(Matrix15::zeros);
    let mut last = *input.last;
    let mut current = last.predicted(pre, input.gravity);
    let mut hessian = Matrix24::zeros();
    for _ in 0..ITERATIONS {
        hessian = Matrix24::identity() * DAMPING;
        let mut gradient = Vector24::zeros();

        let inertial = InertialResidual::evaluate(pre, &last, &current, input.gravity);
        let mut j = SMatrix::<f64, 9, 24>::zeros();
        j.fixed_view_mut::<9, 15>(0, 0)
            .copy_from(&inertial.jacobian_i);
        j.fixed_view_mut::<9, 9>(0, 15)
            .copy_from(&inertial.jacobian_j);
        let jt_w = j.transpose() * inertial_information;
        hessian += jt_w * j;
        gradient += jt_w * inertial.residual;

        let prior = prior_residual(input.last, &last);
        hessian
            .fixed_view_mut::<15, 15>(0, 0)
            .add_assign(&prior_information);
        let g = prior_information * prior;
        gradient.fixed_rows_mut::<15>(0).add_assign(&g);

        if let Some(visual) = &input.visual {
            let error = se3::log(
                &(camera_from_world(&current, input.camera_from_imu)
                    * visual.camera_from_world.inverse()),
            );
            let jv = camera_jacobian(&current.rotation, input.camera_from_imu);
            let jt_w = jv.transpose() * visual.information;
            hessian
                .fixed_view_mut::<6, 6>(15, 15)
                .add_assign(&(jt_w * jv));
            gradient.fixed_rows_mut::<6>(15).add_assign(&(jt_w * error));
        }

        let Some(inverse) = scaled_inverse(&hessian) else {
            break;
        };
        let delta = -(inverse * gradient);
        last = last.perturbed(&delta.fixed_rows::<15>(0).into_owned());
        let mut delta_j = SVector::<f64, 15>::zeros();
        delta_j
            .fixed_rows_mut::<9>(0)
            .copy_from(&delta.fixed_rows::<9>(15));
        current = current.perturbed(&delta_j);
        current.bias = last.bias;
    }
    let joint = scaled_inverse(&hessian).unwrap_or_else(|| Matrix24::identity() / DAMPING);
    // The frame's (dphi, dp, dv) then the shared biases.
    let order: [usize; 15] = [15, 16, 17, 18, 19, 20, 21, 22, 23, 9, 10, 11, 12, 13, 14];
    let mut covariance = Matrix15::from_fn(|r, c| joint[(order[r], order[c])]);
    let dt = pre.dt();
    let noise = pre.noise();
    for k in 0..3 {
        covariance[(9 + k, 9 + k)] += noise.gyro_walk.powi(2) * dt;
        covariance[(12 + k, 12 + k)] += noise.accel_walk.powi(2) * dt;
    }
    let jc = camera_jacobian(&current.rotation, input.camera_from_imu);
    let camera_covariance = jc * covariance.fixed_view::<6, 6>(0, 0) * jc.transpose();
    StepOutput {
        state: current,
        covariance,
        camera_covariance,
    }
}

/// The inverse of the normal equations `h`, scaled to a unit diagonal first: the
/// preintegrated position of a frame interval is known to a micrometre and a turn to a
/// few hundredths of a degree, so the unscaled matrix spans more than f64's precision.
fn scaled_inverse<const N: usize>(h: &SMatrix<f64, N, N>) -> Option<SMatrix<f64, N, N>> {
    let scale = SVector::<f64, N>::from_fn(|k, _| 1.0 / h[(k, k)].max(f64::MIN_POSITIVE).sqrt());
    // Symmetrised: the covariances carried from frame to frame pick up rounding.
    let scaled =
        SMatrix::<f64, N, N>::from_fn(|r, c| 0.5 * (h[(r, c)] + h[(c, r)]) * scale[r] * scale[c]);
    let inverse = scaled.cholesky()?.inverse();
    Some(SMatrix::<f64, N, N>::from_fn(|r, c| {
        inverse[(r, c)] * scale[r] * scale[c]
    }))
}

/// `state` less the prior's centre `at`, over `(dphi, dp, dv, dbg, dba)`.
fn prior_residual(at: &State, state: &State) -> SVector<f64, 15> {
    let rotation = log_so3(&(at.rotation.transpose() * state.rotation));
    let mut r = SVector::<f64, 15>::zeros();
    r.fixed_rows_mut::<3>(0).copy_from(&rotation);
    r.fixed_rows_mut::<3>(3)
        .copy_from(&(state.position - at.position));
    r.fixed_rows_mut::<3>(6)
        .copy_from(&(state.velocity - at.velocity));
    r.fixed_rows_mut::<3>(9)
        .copy_from(&(state.bias.gyro - at.bias.gyro));
    r.fixed_rows_mut::<3>(12)
        .copy_from(&(state.bias.accel - at.bias.accel));
    r
}

#[cfg(test)]
#[path = "fusion_tests.rs"]
mod tests;
