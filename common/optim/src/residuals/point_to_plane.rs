//! Point-to-plane depth error (projective ICP): a point measured by the frame's depth,
//! in its camera, against the tangent plane of a reference surface point, in the world:
//! `e = n_w . (T_cw^-1 q_c - s_w)`, metres along the normal.
//!
//! Evaluated in the camera, `e = n_c . (q_c - s_c)` with `n_c = R_cw n_w` and
//! `s_c = T_cw s_w`; under the left perturbation both move by `exp(delta)`, so
//! `de/drho = -n_c^T` and `de/dphi = (n_c x q_c)^T` (the terms of `s_c` cancel).
//!
//! The offset of the point along the plane, `t = (I - n_c n_c^T)(q_c - s_c)`, is no
//! error, but a normal tilted by noise turns part of it into one (see
//! [`crate::DepthObservation::normal_tilt_variance`]).

use nalgebra::{Isometry3, Matrix1x6, Point3, Vector3, Vector6};

/// One depth point of the frame associated with a reference surface element.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointToPlane {
    /// The frame's back-projected depth point, camera frame, metres.
    pub point_in_camera: Vector3<f64>,
}

/// Error and Jacobian of a [`PointToPlane`] at one estimate.
#[derive(Clone, Copy, Debug)]
pub struct PointToPlaneLinearization {
    /// Signed distance of the point to the plane, metres.
    pub error: f64,
    /// d(error)/d(delta) for the left pose perturbation, 1x6.
    pub d_pose: Matrix1x6<f64>,
    /// `J^T t`, the gradient of `|t|^2 / 2` for the offset `t` along the plane, over
    /// the left perturbation. `q_c - s_c` moves by `[-I, [s_c]x]` and the normal by
    /// `[0, -[n_c]x]`; with `n_c . t = 0` the product is `(-t; t x s_c - e n_c x t)`.
    pub offset_gradient: Vector6<f64>,
}

impl PointToPlane {
    /// The error for the plane through `surface_in_world` with unit normal
    /// `normal_in_world`.
    #[inline]
    pub fn error(
        &self,
        camera_from_world: &Isometry3<f64>,
        surface_in_world: &Vector3<f64>,
        normal_in_world: &Vector3<f64>,
    ) -> f64 {
        let (s_c, n_c) = plane_in_camera(camera_from_world, surface_in_world, normal_in_world);
        n_c.dot(&(self.point_in_camera - s_c))
    }

    /// The error, its Jacobian and the gradient of the offset along the plane.
    #[inline]
    pub fn linearize(
        &self,
        camera_from_world: &Isometry3<f64>,
        surface_in_world: &Vector3<f64>,
        normal_in_world: &Vector3<f64>,
    ) -> PointToPlaneLinearization {
        let (s_c, n_c) = plane_in_camera(camera_from_world, surface_in_world, normal_in_world);
        let r = n_c.cross(&self.point_in_camera);
        let (e, t) = self.distance_and_offset(&s_c, &n_c);
        let turn = t.cross(&s_c) - n_c.cross(&t) * e;
        PointToPlaneLinearization {
            error: e,
            d_pose: Matrix1x6::new(-n_c.x, -n_c.y, -n_c.z, r.x, r.y, r.z),
            offset_gradient: Vector6::new(-t.x, -t.y, -t.z, turn.x, turn.y, turn.z),
        }
    }

    /// The distance along the normal and the offset along the plane,
    /// `t = (I - n_c n_c^T)(q_c - s_c)`, camera frame, metres.
    #[inline]
    pub fn error_and_offset(
        &self,
        camera_from_world: &Isometry3<f64>,
        surface_in_world: &Vector3<f64>,
        normal_in_world: &Vector3<f64>,
    ) -> (f64, Vector3<f64>) {
        let (s_c, n_c) = plane_in_camera(camera_from_world, surface_in_world, normal_in_world);
        self.distance_and_offset(&s_c, &n_c)
    }

    /// [`Self::error_and_offset`] for the plane through `s_c` with normal `n_c`, both in
    /// the camera frame.
    #[inline]
    fn distance_and_offset(&self, s_c: &Vector3<f64>, n_c: &Vector3<f64>) -> (f64, Vector3<f64>) {
        let d = self.point_in_camera - s_c;
        let e = n_c.dot(&d);
        (e, d - n_c * e)
    }
}

/// The reference surface point and its normal in the camera frame.
#[inline]
fn plane_in_camera(
    camera_from_world: &Isometry3<f64>,
    surface_in_world: &Vector3<f64>,
    normal_in_world: &Vector3<f64>,
) -> (Vector3<f64>, Vector3<f64>) {
    (
        (camera_from_world * Point3::from(*surface_in_world)).coords,
        camera_from_world.rotation * normal_in_world,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::residuals::testing::{
        SplitMix64, assert_jacobian, random_camera_and_pose, random_point_in_view,
    };
    use gfs_core::se3::retract;
    use nalgebra::{Vector1, Vector6};

    #[test]
    fn jacobian_matches_central_differences() {
        let mut rng = SplitMix64::new(7);
        for _ in 0..50 {
            let (_, t_cw) = random_camera_and_pose(&mut rng);
            let s_w = random_point_in_view(&mut rng, &t_cw);
            let n_w = rng.vector3(1.0).normalize();
            let q_c = (t_cw * Point3::from(s_w)).coords + rng.vector3(0.05);
            let r = PointToPlane {
                point_in_camera: q_c,
            };
            let lin = r.linearize(&t_cw, &s_w, &n_w);
            assert!((lin.error - r.error(&t_cw, &s_w, &n_w)).abs() < 1e-12);
            assert_jacobian(
                |d: &Vector6<f64>| Vector1::new(r.error(&retract(&t_cw, d), &s_w, &n_w)),
                &lin.d_pose,
                "point-to-plane d_pose",
            );
        }
    }

    #[test]
    fn offset_gradient_matches_central_differences() {
        let mut rng = SplitMix64::new(11);
        for _ in 0..50 {
            let (_, t_cw) = random_camera_and_pose(&mut rng);
            let s_w = random_point_in_view(&mut rng, &t_cw);
            let n_w = rng.vector3(1.0).normalize();
            let r = PointToPlane {
                point_in_camera: (t_cw * Point3::from(s_w)).coords + rng.vector3(0.05),
            };
            let gradient = r.linearize(&t_cw, &s_w, &n_w).offset_gradient;
            let (e, t) = r.error_and_offset(&t_cw, &s_w, &n_w);
            assert!((e - r.error(&t_cw, &s_w, &n_w)).abs() < 1e-12);
            assert!(t.dot(&(t_cw.rotation * n_w)).abs() < 1e-12);
            assert_jacobian(
                |d: &Vector6<f64>| {
                    let t = r.error_and_offset(&retract(&t_cw, d), &s_w, &n_w).1;
                    Vector1::new(0.5 * t.norm_squared())
                },
                &gradient.transpose(),
                "tangential offset gradient",
            );
        }
    }

    #[test]
    fn error_is_the_distance_along_the_normal_only() {
        // The plane z = 2 in front of an identity camera: a point 3 cm behind it and
        // 40 cm aside is 3 cm off.
        let r = PointToPlane {
            point_in_camera: Vector3::new(0.4, -0.1, 2.03),
        };
        let e = r.error(
            &Isometry3::identity(),
            &Vector3::new(0.0, 0.0, 2.0),
            &Vector3::new(0.0, 0.0, -1.0),
        );
        assert!((e + 0.03).abs() < 1e-12, "{e}");
    }
}
