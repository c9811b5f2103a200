//! RGB-D point error: the keypoint's measured depth becomes a virtual disparity
//! `d = bf / depth`, and `e = [u, v, d]_obs - [pi(p_c), bf / z_c]` with `p_c = T_cw P_w`.
//! It constrains depth, which the 2D reprojection error leaves to the baseline
//! between keyframes (and leaves scale free in a local BA with one fixed pose).
//!
//! ORB-SLAM2's edge uses the virtual right coordinate `u_r = u - d` instead, whose error
//! carries the keypoint's `u` error too: weighing depth by its own (small) sigma then
//! amplifies the pixel noise. The disparity alone keeps the two independent, so the
//! local BA can weigh depth as the sensor measures it; with depth as weak as a pixel
//! (`u_r` at one pixel sigma), points slid along their rays by 5-20 cm at 4 m to absorb
//! keyframe pose errors, and a synthetic fast sequence drifted 8 cm in 20 frames.

use super::projection::{point_pose_jacobian, project, projection_jacobian};
use gfs_core::camera::PinholeCamera;
use nalgebra::{Isometry3, Matrix3, Matrix3x6, Point3, Vector2, Vector3};

/// A keypoint with a valid depth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StereoPointReprojection {
    /// Observed `(u, v, d)`, pixels: the keypoint and its virtual disparity
    /// `bf / depth` (see [`Self::from_depth`]).
    pub observed: Vector3<f64>,
    /// Virtual stereo baseline times focal length `bf`, metres x pixels (ORB-SLAM2
    /// `Camera.bf`).
    pub bf: f64,
    /// Factor on the disparity component of the error and its Jacobian row (see
    /// [`Self::disparity_scale`]); 1 weighs it as the keypoint's pixel coordinates.
    pub disparity_scale: f64,
}

/// Error and Jacobians of a [`StereoPointReprojection`] at one estimate.
#[derive(Clone, Copy, Debug)]
pub struct StereoPointLinearization {
    /// `(u, v, d)_obs - prediction`, pixels (the disparity part scaled).
    pub error: Vector3<f64>,
    /// d(error)/d(delta) for the left pose perturbation, 3x6.
    pub d_pose: Matrix3x6<f64>,
    /// d(error)/d(P_w), 3x3.
    pub d_point: Matrix3<f64>,
}

impl StereoPointReprojection {
    /// The term of keypoint `uv` measured at `depth` metres (> 0), with
    /// `disparity_scale` on the disparity error.
    pub fn from_depth(uv: Vector2<f64>, depth: f64, bf: f64, disparity_scale: f64) -> Self {
        Self {
            observed: Vector3::new(uv.x, uv.y, bf / depth),
            bf,
            disparity_scale,
        }
    }

    /// The disparity factor that gives a keypoint of information `inv_sigma2` (1/px^2)
    /// an inverse-depth sigma of `inverse_depth_sigma` (1/m): the disparity's sigma is
    /// then `bf * inverse_depth_sigma` at every pyramid level. A structured-light sensor
    /// measures disparity, so its `1/z` noise is about constant (Kinect v1:
    /// `sigma_z = 1.4e-3..2.9e-3 z^2`, Khoshelham and Elberink 2012). A non-positive
    /// `inverse_depth_sigma` gives 1.
    pub fn disparity_scale(inv_sigma2: f64, bf: f64, inverse_depth_sigma: f64) -> f64 {
        if inverse_depth_sigma > 0.0 && inv_sigma2 > 0.0 && bf > 0.0 {
            1.0 / (bf * inverse_depth_sigma * inv_sigma2.sqrt())
        } else {
            1.0
        }
    }

    fn weighted(&self, mut e: Vector3<f64>) -> Vector3<f64> {
        e.z *= self.disparity_scale;
        e
    }

    fn predict(&self, camera: &PinholeCamera, p_c: &Vector3<f64>) -> Option<Vector3<f64>> {
        let uv = project(camera, p_c)?;
        Some(Vector3::new(uv.x, uv.y, self.bf / p_c.z))
    }

    /// The error; `None` when the point is not in front of the camera.
    #[inline]
    pub fn error(
        &self,
        camera: &PinholeCamera,
        camera_from_world: &Isometry3<f64>,
        point_in_world: &Vector3<f64>,
    ) -> Option<Vector3<f64>> {
        let p_c = (camera_from_world * Point3::from(*point_in_world)).coords;
        Some(self.weighted(self.observed - self.predict(camera, &p_c)?))
    }

    /// The error and its Jacobians; `None` when the point is not in front of the camera.
    #[inline]
    pub fn linearize(
        &self,
        camera: &PinholeCamera,
        camera_from_world: &Isometry3<f64>,
        point_in_world: &Vector3<f64>,
    ) -> Option<StereoPointLinearization> {
        let p_c = (camera_from_world * Point3::from(*point_in_world)).coords;
        let predicted = self.predict(camera, &p_c)?;
        let j2 = projection_jacobian(camera, &p_c);
        let inv_z2 = 1.0 / (p_c.z * p_c.z);
        let mut d_proj = Matrix3::zeros();
        d_proj.fixed_view_mut::<2, 3>(0, 0).copy_from(&j2);
        d_proj[(2, 2)] = -self.bf * inv_z2;
        let mut d_proj = -d_proj;
        for c in 0..3 {
            d_proj[(2, c)] *= self.disparity_scale;
        }
        Some(StereoPointLinearization {
            error: self.weighted(self.observed - predicted),
            d_pose: d_proj * point_pose_jacobian(&p_c),
            d_point: d_proj * camera_from_world.rotation.to_rotation_matrix().matrix(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::residuals::testing::{
        SplitMix64, assert_jacobian, random_camera_and_pose, random_point_in_view,
    };
    use gfs_core::se3::retract;
    use nalgebra::Vector6;

    #[test]
    fn jacobians_match_central_differences() {
        let mut rng = SplitMix64::new(6);
        for _ in 0..50 {
            let (camera, t_cw) = random_camera_and_pose(&mut rng);
            let p_w = random_point_in_view(&mut rng, &t_cw);
            let uv = Vector2::new(rng.uniform(0.0, 640.0), rng.uniform(0.0, 480.0));
            let r = StereoPointReprojection::from_depth(uv, rng.uniform(0.5, 5.0), 40.0, 3.0);
            let lin = r.linearize(&camera, &t_cw, &p_w).expect("in front");
            assert_jacobian(
                |d: &Vector6<f64>| r.error(&camera, &retract(&t_cw, d), &p_w).expect("front"),
                &lin.d_pose,
                "stereo d_pose",
            );
            assert_jacobian(
                |d: &Vector3<f64>| r.error(&camera, &t_cw, &(p_w + d)).expect("front"),
                &lin.d_point,
                "stereo d_point",
            );
        }
    }

    #[test]
    fn error_is_zero_at_the_true_point_and_depth() {
        let camera = PinholeCamera::new(500.0, 500.0, 320.0, 240.0, 640, 480);
        let p = Vector3::new(0.4, -0.2, 2.5);
        let uv = camera.project(&Point3::from(p)).expect("front").coords;
        let r = StereoPointReprojection::from_depth(uv, 2.5, 40.0, 1.0);
        let e = r.error(&camera, &Isometry3::identity(), &p).expect("front");
        assert!(e.norm() < 1e-12, "{e}");
        // 10 cm deeper changes the disparity by bf (1/2.5 - 1/2.6) = 0.615 px.
        let r = StereoPointReprojection::from_depth(uv, 2.6, 40.0, 1.0);
        let e = r.error(&camera, &Isometry3::identity(), &p).expect("front");
        assert!((e.z - 40.0 * (1.0 / 2.6 - 1.0 / 2.5)).abs() < 1e-9, "{e}");
    }

    #[test]
    fn the_disparity_error_ignores_the_pixel_error_and_has_its_own_sigma() {
        let camera = PinholeCamera::new(500.0, 500.0, 320.0, 240.0, 640, 480);
        let p = Vector3::new(0.4, -0.2, 2.5);
        let uv = camera.project(&Point3::from(p)).expect("front").coords;
        // A keypoint 2 px off in u, at level 2 (sigma 1.44 px), with exact depth.
        let inv_sigma2 = 1.2f64.powi(-4);
        let scale = StereoPointReprojection::disparity_scale(inv_sigma2, 40.0, 0.01);
        let r = StereoPointReprojection::from_depth(uv + Vector2::new(2.0, 0.0), 2.5, 40.0, scale);
        let e = r.error(&camera, &Isometry3::identity(), &p).expect("front");
        assert!((e.x - 2.0).abs() < 1e-9 && e.z.abs() < 1e-12, "{e}");
        // 10 cm deeper, weighted: 0.615 px of disparity at a sigma of bf x 0.01 = 0.4 px
        // is 1.54 sigma, whatever the level.
        let r = StereoPointReprojection::from_depth(uv, 2.6, 40.0, scale);
        let e = r.error(&camera, &Isometry3::identity(), &p).expect("front");
        let sigmas = e.z * inv_sigma2.sqrt();
        assert!((sigmas.abs() - 0.615 / 0.4).abs() < 1e-3, "{sigmas}");
    }
}
