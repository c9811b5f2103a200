//! Line endpoint-to-line error (paper eq. 7, PL-SLAM): the signed pixel distances of
//! the two projected 3D endpoints to the observed 2D line,
//! `e = [l . (pi(T_cw S_w), 1); l . (pi(T_cw E_w), 1)]` with `l = (a, b, c)`,
//! `a^2 + b^2 = 1` (`gfs_lines::Segment::line_coefficients`).

use super::projection::{point_pose_jacobian, project, projection_jacobian};
use gfs_core::camera::PinholeCamera;
use nalgebra::{Isometry3, Matrix2x6, Point3, RowVector2, Vector2, Vector3};

/// One observed 2D line of a map line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineReprojection {
    /// Normalised coefficients `(a, b, c)`, `a^2 + b^2 = 1`: `a u + b v + c` is the signed
    /// distance of pixel (u, v) to the observed line, pixels.
    pub coeffs: Vector3<f64>,
}

/// Error and Jacobians of a [`LineReprojection`] at one estimate.
#[derive(Clone, Copy, Debug)]
pub struct LineLinearization {
    /// Signed distances of the projected start and end point to the observed line, pixels.
    pub error: Vector2<f64>,
    /// d(error)/d(delta) for the left pose perturbation, 2x6.
    pub d_pose: Matrix2x6<f64>,
    /// d(error)/d([S_w; E_w]), 2x6 (row 0 depends on S only, row 1 on E only).
    pub d_line: Matrix2x6<f64>,
}

impl LineReprojection {
    /// Signed distance of one projected world point; `None` behind the camera.
    #[inline]
    fn distance(
        &self,
        camera: &PinholeCamera,
        camera_from_world: &Isometry3<f64>,
        p_w: &Vector3<f64>,
    ) -> Option<f64> {
        let p_c = (camera_from_world * Point3::from(*p_w)).coords;
        let uv = project(camera, &p_c)?;
        Some(self.coeffs.x * uv.x + self.coeffs.y * uv.y + self.coeffs.z)
    }

    /// The error; `None` when an endpoint is not in front of the camera.
    #[inline]
    pub fn error(
        &self,
        camera: &PinholeCamera,
        camera_from_world: &Isometry3<f64>,
        endpoints_in_world: &[Vector3<f64>; 2],
    ) -> Option<Vector2<f64>> {
        Some(Vector2::new(
            self.distance(camera, camera_from_world, &endpoints_in_world[0])?,
            self.distance(camera, camera_from_world, &endpoints_in_world[1])?,
        ))
    }

    /// The error and its Jacobians; `None` when an endpoint is not in front of the camera.
    #[inline]
    pub fn linearize(
        &self,
        camera: &PinholeCamera,
        camera_from_world: &Isometry3<f64>,
        endpoints_in_world: &[Vector3<f64>; 2],
    ) -> Option<LineLinearization> {
        let rotation = camera_from_world.rotation.to_rotation_matrix();
        let ab = RowVector2::new(self.coeffs.x, self.coeffs.y);
        let mut lin = LineLinearization {
            error: Vector2::zeros(),
            d_pose: Matrix2x6::zeros(),
            d_line: Matrix2x6::zeros(),
        };
        for (k, p_w) in endpoints_in_world.iter().enumerate() {
            let p_c = (camera_from_world * Point3::from(*p_w)).coords;
            let uv = project(camera, &p_c)?;
            lin.error[k] = self.coeffs.x * uv.x + self.coeffs.y * uv.y + self.coeffs.z;
            let d_point_c = ab * projection_jacobian(camera, &p_c);
            lin.d_pose
                .row_mut(k)
                .copy_from(&(d_point_c * point_pose_jacobian(&p_c)));
            lin.d_line
                .fixed_view_mut::<1, 3>(k, 3 * k)
                .copy_from(&(d_point_c * rotation.matrix()));
        }
        Some(lin)
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

    fn random_coeffs(rng: &mut SplitMix64) -> Vector3<f64> {
        let angle = rng.uniform(-std::f64::consts::PI, std::f64::consts::PI);
        Vector3::new(angle.cos(), angle.sin(), rng.uniform(-400.0, 400.0))
    }

    #[test]
    fn jacobians_match_central_differences() {
        let mut rng = SplitMix64::new(2);
        for _ in 0..50 {
            let (camera, t_cw) = random_camera_and_pose(&mut rng);
            let line = [
                random_point_in_view(&mut rng, &t_cw),
                random_point_in_view(&mut rng, &t_cw),
            ];
            let r = LineReprojection {
                coeffs: random_coeffs(&mut rng),
            };
            let lin = r.linearize(&camera, &t_cw, &line).expect("in front");
            assert_jacobian(
                |d: &Vector6<f64>| r.error(&camera, &retract(&t_cw, d), &line).expect("front"),
                &lin.d_pose,
                "line d_pose",
            );
            assert_jacobian(
                |d: &Vector6<f64>| {
                    let moved = [
                        line[0] + d.fixed_rows::<3>(0),
                        line[1] + d.fixed_rows::<3>(3),
                    ];
                    r.error(&camera, &t_cw, &moved).expect("front")
                },
                &lin.d_line,
                "line d_line",
            );
        }
    }

    #[test]
    fn error_is_the_signed_pixel_distance() {
        let camera = PinholeCamera::new(500.0, 500.0, 320.0, 240.0, 640, 480);
        // The observed line v = 240 (a = 0, b = 1, c = -240); endpoints project to
        // v = 240 and v = 240 + 500 * 0.1 / 2 = 265.
        let r = LineReprojection {
            coeffs: Vector3::new(0.0, 1.0, -240.0),
        };
        let line = [Vector3::new(-0.5, 0.0, 2.0), Vector3::new(0.5, 0.1, 2.0)];
        let e = r
            .error(&camera, &Isometry3::identity(), &line)
            .expect("front");
        assert!(e[0].abs() < 1e-12 && (e[1] - 25.0).abs() < 1e-9, "{e}");
    }
}
