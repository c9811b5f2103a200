//! Point reprojection error (paper eq. 6, ORB-SLAM2): `e = uv_obs - pi(T_cw P_w)`.

use super::projection::{point_pose_jacobian, project, projection_jacobian};
use gfs_core::camera::PinholeCamera;
use nalgebra::{Isometry3, Matrix2x3, Matrix2x6, Point3, Vector2, Vector3};

/// One observed keypoint of a map point, undistorted pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointReprojection {
    /// Observed pixel (u, v).
    pub uv: Vector2<f64>,
}

/// Error and Jacobians of a [`PointReprojection`] at one estimate.
#[derive(Clone, Copy, Debug)]
pub struct PointLinearization {
    /// `uv_obs - pi(T_cw P_w)`, pixels.
    pub error: Vector2<f64>,
    /// d(error)/d(delta) for the left pose perturbation, 2x6.
    pub d_pose: Matrix2x6<f64>,
    /// d(error)/d(P_w), 2x3.
    pub d_point: Matrix2x3<f64>,
}

impl PointReprojection {
    /// The error; `None` when the point is not in front of the camera.
    #[inline]
    pub fn error(
        &self,
        camera: &PinholeCamera,
        camera_from_world: &Isometry3<f64>,
        point_in_world: &Vector3<f64>,
    ) -> Option<Vector2<f64>> {
        let p_c = (camera_from_world * Point3::from(*point_in_world)).coords;
        project(camera, &p_c).map(|uv| self.uv - uv)
    }

    /// The error and its Jacobians; `None` when the point is not in front of the camera.
    #[inline]
    pub fn linearize(
        &self,
        camera: &PinholeCamera,
        camera_from_world: &Isometry3<f64>,
        point_in_world: &Vector3<f64>,
    ) -> Option<PointLinearization> {
        let p_c = (camera_from_world * Point3::from(*point_in_world)).coords;
        let uv = project(camera, &p_c)?;
        let d_proj = -projection_jacobian(camera, &p_c);
        Some(PointLinearization {
            error: self.uv - uv,
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
    use nalgebra::{Vector3, Vector6};

    #[test]
    fn jacobians_match_central_differences() {
        let mut rng = SplitMix64::new(1);
        for _ in 0..50 {
            let (camera, t_cw) = random_camera_and_pose(&mut rng);
            let p_w = random_point_in_view(&mut rng, &t_cw);
            let r = PointReprojection {
                uv: Vector2::new(rng.uniform(0.0, 640.0), rng.uniform(0.0, 480.0)),
            };
            let lin = r.linearize(&camera, &t_cw, &p_w).expect("in front");
            assert_jacobian(
                |d: &Vector6<f64>| r.error(&camera, &retract(&t_cw, d), &p_w).expect("front"),
                &lin.d_pose,
                "point d_pose",
            );
            assert_jacobian(
                |d: &Vector3<f64>| r.error(&camera, &t_cw, &(p_w + d)).expect("front"),
                &lin.d_point,
                "point d_point",
            );
        }
    }

    #[test]
    fn error_is_zero_at_the_true_projection_and_none_behind() {
        let camera = PinholeCamera::new(500.0, 500.0, 320.0, 240.0, 640, 480);
        let r = PointReprojection {
            uv: Vector2::new(420.0, 240.0),
        };
        let p = Vector3::new(0.4, 0.0, 2.0);
        let e = r.error(&camera, &Isometry3::identity(), &p).expect("front");
        assert!(e.norm() < 1e-12, "{e}");
        assert!(r.error(&camera, &Isometry3::identity(), &(-p)).is_none());
    }
}
