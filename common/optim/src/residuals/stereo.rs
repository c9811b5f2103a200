//! RGB-D point error (ORB-SLAM2's RGB-D/stereo edge): the keypoint's measured depth
//! becomes a virtual right-image coordinate `u_r = u - bf / depth`, and
//! `e = [u, v, u_r]_obs - [pi(p_c), pi_u(p_c) - bf / z_c]` with `p_c = T_cw P_w`.
//! It constrains depth, which the 2D reprojection error leaves to the baseline
//! between keyframes (and leaves scale free in a local BA with one fixed pose).

use super::projection::{point_pose_jacobian, project, projection_jacobian};
use gfs_core::camera::PinholeCamera;
use nalgebra::{Isometry3, Matrix3, Matrix3x6, Point3, Vector2, Vector3};

/// A keypoint with a valid depth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StereoPointReprojection {
    /// Observed `(u, v, u_r)`, pixels: the keypoint and its virtual right coordinate
    /// `u - bf / depth` (see [`Self::from_depth`]).
    pub observed: Vector3<f64>,
    /// Virtual stereo baseline times focal length `bf`, metres x pixels (ORB-SLAM2
    /// `Camera.bf`).
    pub bf: f64,
}

/// Error and Jacobians of a [`StereoPointReprojection`] at one estimate.
#[derive(Clone, Copy, Debug)]
pub struct StereoPointLinearization {
    /// `(u, v, u_r)_obs - prediction`, pixels.
    pub error: Vector3<f64>,
    /// d(error)/d(delta) for the left pose perturbation, 3x6.
    pub d_pose: Matrix3x6<f64>,
    /// d(error)/d(P_w), 3x3.
    pub d_point: Matrix3<f64>,
}

impl StereoPointReprojection {
    /// The term of keypoint `uv` measured at `depth` metres (> 0).
    pub fn from_depth(uv: Vector2<f64>, depth: f64, bf: f64) -> Self {
        Self {
            observed: Vector3::new(uv.x, uv.y, uv.x - bf / depth),
            bf,
        }
    }

    fn predict(&self, camera: &PinholeCamera, p_c: &Vector3<f64>) -> Option<Vector3<f64>> {
        let uv = project(camera, p_c)?;
        Some(Vector3::new(uv.x, uv.y, uv.x - self.bf / p_c.z))
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
        Some(self.observed - self.predict(camera, &p_c)?)
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
        d_proj[(2, 0)] = j2[(0, 0)];
        d_proj[(2, 2)] = j2[(0, 2)] + self.bf * inv_z2;
        let d_proj = -d_proj;
        Some(StereoPointLinearization {
            error: self.observed - predicted,
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
            let r = StereoPointReprojection::from_depth(uv, rng.uniform(0.5, 5.0), 40.0);
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
        let r = StereoPointReprojection::from_depth(uv, 2.5, 40.0);
        let e = r.error(&camera, &Isometry3::identity(), &p).expect("front");
        assert!(e.norm() < 1e-12, "{e}");
        // 10 cm deeper moves u_r by bf (1/2.5 - 1/2.6) = 0.615 px.
        let r = StereoPointReprojection::from_depth(uv, 2.6, 40.0);
        let e = r.error(&camera, &Isometry3::identity(), &p).expect("front");
        assert!((e.z - 40.0 * (1.0 / 2.5 - 1.0 / 2.6)).abs() < 1e-9, "{e}");
    }
}
