//! Pinhole projection and its Jacobian, shared by the point and line residuals.

use gfs_core::camera::PinholeCamera;
use gfs_core::se3::skew;
use nalgebra::{Matrix2x3, Matrix3x6, Point3, Vector2, Vector3};

/// Projects `p_in_camera`; `None` when it is not in front of the camera (the
/// camera's own minimum depth).
#[inline]
pub(crate) fn project(camera: &PinholeCamera, p_in_camera: &Vector3<f64>) -> Option<Vector2<f64>> {
    camera
        .project(&Point3::from(*p_in_camera))
        .map(|uv| uv.coords)
}

/// d(pi)/d(p_c) for the pinhole model, 2x3.
#[inline]
pub(crate) fn projection_jacobian(camera: &PinholeCamera, p: &Vector3<f64>) -> Matrix2x3<f64> {
    let inv_z = 1.0 / p.z;
    let inv_z2 = inv_z * inv_z;
    Matrix2x3::new(
        camera.fx * inv_z,
        0.0,
        -camera.fx * p.x * inv_z2,
        0.0,
        camera.fy * inv_z,
        -camera.fy * p.y * inv_z2,
    )
}

/// d(p_c)/d(delta) = [I, -[p_c]x] for the left perturbation of T_cw.
#[inline]
pub(crate) fn point_pose_jacobian(p_in_camera: &Vector3<f64>) -> Matrix3x6<f64> {
    let mut j = Matrix3x6::zeros();
    j.fixed_view_mut::<3, 3>(0, 0).fill_with_identity();
    j.fixed_view_mut::<3, 3>(0, 3)
        .copy_from(&(-skew(p_in_camera)));
    j
}
