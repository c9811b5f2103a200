//! A prior on the pose (the motion model's prediction): `E = T_cw P_cw^-1`, the
//! estimate seen from the predicted camera, as `e = [t_E; log(R_E)]`.
//!
//! Under the left perturbation `exp(delta) E`, `t_E` moves by `rho + phi x t_E` and
//! `log(R_E)` by `J_l^-1(log R_E) phi`, so `de/ddelta = [[I, -[t_E]x], [0, J_l^-1]]`:
//! exact, with only the SO(3) Jacobian.

use gfs_core::se3::{left_jacobian_inverse, skew};
use nalgebra::{Isometry3, Matrix3, Matrix6, Vector6};

/// The predicted pose a frame's pose is drawn towards, with the information of the
/// prediction (left perturbation `[rho; phi]` of the camera).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PosePrior {
    /// The predicted `camera_from_world`.
    pub camera_from_world: Isometry3<f64>,
    /// Inverse covariance of the prediction's error, `[rho; phi]`.
    pub information: Matrix6<f64>,
}

/// Error and Jacobian of a [`PosePrior`] at one estimate.
#[derive(Clone, Copy, Debug)]
pub struct PosePriorLinearization {
    /// `[t_E; log(R_E)]`, metres and radians.
    pub error: Vector6<f64>,
    /// d(error)/d(delta) for the left pose perturbation.
    pub d_pose: Matrix6<f64>,
}

impl PosePrior {
    /// A prior whose translation and rotation errors are independent, with standard
    /// deviations `sigma_m` (per axis, metres) and `sigma_rad` (per axis, radians).
    pub fn isotropic(camera_from_world: Isometry3<f64>, sigma_m: f64, sigma_rad: f64) -> Self {
        let t = 1.0 / (sigma_m * sigma_m);
        let r = 1.0 / (sigma_rad * sigma_rad);
        Self {
            camera_from_world,
            information: Matrix6::from_diagonal(&Vector6::new(t, t, t, r, r, r)),
        }
    }

    /// The error at `camera_from_world`.
    pub fn error(&self, camera_from_world: &Isometry3<f64>) -> Vector6<f64> {
        let e = camera_from_world * self.camera_from_world.inverse();
        let t = e.translation.vector;
        let phi = e.rotation.scaled_axis();
        Vector6::new(t.x, t.y, t.z, phi.x, phi.y, phi.z)
    }

    /// The error and its Jacobian.
    pub fn linearize(&self, camera_from_world: &Isometry3<f64>) -> PosePriorLinearization {
        let error = self.error(camera_from_world);
        let t = error.fixed_rows::<3>(0).into_owned();
        let phi = error.fixed_rows::<3>(3).into_owned();
        let mut d_pose = Matrix6::zeros();
        d_pose
            .fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&Matrix3::identity());
        d_pose.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-skew(&t)));
        d_pose
            .fixed_view_mut::<3, 3>(3, 3)
            .copy_from(&left_jacobian_inverse(&phi));
        PosePriorLinearization { error, d_pose }
    }

    /// What the prior adds to the normal matrix at `camera_from_world`, `J^T Omega J`.
    pub fn information_at(&self, camera_from_world: &Isometry3<f64>) -> Matrix6<f64> {
        let j = self.linearize(camera_from_world).d_pose;
        j.transpose() * self.information * j
    }

    /// Whitened squared error `e^T Omega e` at `camera_from_world`.
    pub fn cost(&self, camera_from_world: &Isometry3<f64>) -> f64 {
        let e = self.error(camera_from_world);
        e.dot(&(self.information * e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::residuals::testing::{SplitMix64, assert_jacobian, random_camera_and_pose};
    use gfs_core::se3::{exp, retract};

    #[test]
    fn jacobian_matches_central_differences() {
        let mut rng = SplitMix64::new(11);
        for _ in 0..50 {
            let (_, predicted) = random_camera_and_pose(&mut rng);
            // Estimates up to 0.3 m and 0.6 rad from the prediction.
            let offset = Vector6::new(
                rng.uniform(-0.3, 0.3),
                rng.uniform(-0.3, 0.3),
                rng.uniform(-0.3, 0.3),
                rng.uniform(-0.6, 0.6),
                rng.uniform(-0.6, 0.6),
                rng.uniform(-0.6, 0.6),
            );
            let estimate = exp(&offset) * predicted;
            let prior = PosePrior::isotropic(predicted, 0.002, 0.003);
            let lin = prior.linearize(&estimate);
            assert!((lin.error - prior.error(&estimate)).amax() < 1e-12);
            assert_jacobian(
                |d: &Vector6<f64>| prior.error(&retract(&estimate, d)),
                &lin.d_pose,
                "pose prior d_pose",
            );
        }
    }

    #[test]
    fn the_error_is_zero_at_the_prediction_and_weighs_each_axis_by_its_sigma() {
        let predicted = exp(&Vector6::new(0.3, -0.2, 1.0, 0.1, 0.4, -0.2));
        let prior = PosePrior::isotropic(predicted, 0.002, 0.01);
        assert!(prior.cost(&predicted) < 1e-20);
        // 4 mm along x from the prediction is two sigmas: cost 4.
        let moved = Isometry3::translation(0.004, 0.0, 0.0) * predicted;
        assert!((prior.cost(&moved) - 4.0).abs() < 1e-9);
    }
}
