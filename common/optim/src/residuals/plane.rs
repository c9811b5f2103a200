//! Plane-to-plane error: a plane measured in the frame (unit normal `m_c`, offset `o`,
//! `m_c . p + o = 0`) against a map plane in the world (`n_w . p + d_w = 0`).
//!
//! The map plane moved into the camera by `T_cw = (R, t)` is `n_c = R n_w`,
//! `d_c = d_w - n_c . t`; the error is `[n_c - m_c; d_c - o]` (3 + 1 rows: the normal's
//! difference, whose norm is the angle for small angles, and the offset's, metres).
//!
//! Pose, left perturbation `[rho; phi]`: `n_c` turns by `phi` (`dn_c/dphi = -[n_c]x`,
//! no `rho` term) and the plane's distance from the camera centre moves only with `rho`
//! (`dd_c/drho = -n_c^T`; a rotation about the camera centre keeps it).
//!
//! Map plane, minimal: the normal on S2 moves in its tangent plane, `n_w' =
//! normalize(n_w + B alpha)` with `B` an orthonormal basis of the tangent plane
//! ([`tangent_basis`]), plus the offset: 3 parameters `[alpha; d_w]`.

use nalgebra::{Isometry3, Matrix3x2, SMatrix, Vector3, Vector4};

/// A frame's plane observation of a map plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneToPlane {
    /// The measured unit normal, camera frame.
    pub normal_in_camera: Vector3<f64>,
    /// The measured offset, metres (`normal . p + offset = 0`).
    pub offset: f64,
}

/// Error and Jacobians of a [`PlaneToPlane`] at one estimate.
#[derive(Clone, Copy, Debug)]
pub struct PlaneLinearization {
    /// `[n_c - m_c; d_c - o]`.
    pub error: Vector4<f64>,
    /// d(error)/d(delta) for the left pose perturbation, 4x6.
    pub d_pose: SMatrix<f64, 4, 6>,
    /// d(error)/d(alpha, d_w) for the map plane's minimal update, 4x3.
    pub d_plane: SMatrix<f64, 4, 3>,
}

/// An orthonormal basis of the plane orthogonal to the unit vector `n`: the two columns
/// along which a normal on S2 is updated.
pub fn tangent_basis(n: &Vector3<f64>) -> Matrix3x2<f64> {
    // The axis least aligned with n makes a well-conditioned first tangent.
    let helper = if n.x.abs() < 0.6 {
        Vector3::x()
    } else if n.y.abs() < 0.6 {
        Vector3::y()
    } else {
        Vector3::z()
    };
    let b1 = n.cross(&helper).normalize();
    let b2 = n.cross(&b1);
    Matrix3x2::from_columns(&[b1, b2])
}

/// The map plane `(n_w, d_w)` updated by the minimal step `[alpha; delta_d]`.
pub fn plane_plus(
    normal_in_world: &Vector3<f64>,
    offset: f64,
    step: &Vector3<f64>,
) -> (Vector3<f64>, f64) {
    let b = tangent_basis(normal_in_world);
    let n = (normal_in_world + b * step.xy()).normalize();
    (n, offset + step.z)
}

impl PlaneToPlane {
    /// The error of the map plane `(normal_in_world, offset_in_world)` seen from
    /// `camera_from_world`.
    #[inline]
    pub fn error(
        &self,
        camera_from_world: &Isometry3<f64>,
        normal_in_world: &Vector3<f64>,
        offset_in_world: f64,
    ) -> Vector4<f64> {
        let n_c = camera_from_world.rotation * normal_in_world;
        let d_c = offset_in_world - n_c.dot(&camera_from_world.translation.vector);
        let dn = n_c - self.normal_in_camera;
        Vector4::new(dn.x, dn.y, dn.z, d_c - self.offset)
    }

    /// The error and its Jacobians.
    #[inline]
    pub fn linearize(
        &self,
        camera_from_world: &Isometry3<f64>,
        normal_in_world: &Vector3<f64>,
        offset_in_world: f64,
    ) -> PlaneLinearization {
        let rotation = camera_from_world.rotation.to_rotation_matrix();
        let t = camera_from_world.translation.vector;
        let n_c = rotation * normal_in_world;
        let mut d_pose = SMatrix::<f64, 4, 6>::zeros();
        d_pose
            .fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&(-n_c.cross_matrix()));
        d_pose
            .fixed_view_mut::<1, 3>(3, 0)
            .copy_from(&(-n_c.transpose()));
        // d n_w / d alpha = B (the normalisation is second order at alpha = 0).
        let b = tangent_basis(normal_in_world);
        let dn_c = rotation.matrix() * b;
        let mut d_plane = SMatrix::<f64, 4, 3>::zeros();
        d_plane.fixed_view_mut::<3, 2>(0, 0).copy_from(&dn_c);
        d_plane
            .fixed_view_mut::<1, 2>(3, 0)
            .copy_from(&(-(t.transpose() * dn_c)));
        d_plane[(3, 2)] = 1.0;
        PlaneLinearization {
            error: self.error(camera_from_world, normal_in_world, offset_in_world),
            d_pose,
            d_plane,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::residuals::testing::{SplitMix64, assert_jacobian, random_camera_and_pose};
    use gfs_core::se3::retract;
    use nalgebra::{Point3, Vector6};

    #[test]
    fn jacobians_match_central_differences() {
        let mut rng = SplitMix64::new(17);
        for _ in 0..50 {
            let (_, t_cw) = random_camera_and_pose(&mut rng);
            let n_w = rng.vector3(1.0).normalize();
            let d_w = rng.uniform(-3.0, 3.0);
            let r = PlaneToPlane {
                normal_in_camera: (t_cw.rotation * n_w + rng.vector3(0.05)).normalize(),
                offset: rng.uniform(-3.0, 3.0),
            };
            let lin = r.linearize(&t_cw, &n_w, d_w);
            assert!((lin.error - r.error(&t_cw, &n_w, d_w)).norm() < 1e-12);
            assert_jacobian(
                |d: &Vector6<f64>| r.error(&retract(&t_cw, d), &n_w, d_w),
                &lin.d_pose,
                "plane d_pose",
            );
            assert_jacobian(
                |s: &Vector3<f64>| {
                    let (n, d) = plane_plus(&n_w, d_w, s);
                    r.error(&t_cw, &n, d)
                },
                &lin.d_plane,
                "plane d_plane",
            );
        }
    }

    #[test]
    fn a_plane_seen_from_its_true_pose_has_no_error() {
        // The floor y = 1.5 m (normal -y towards a camera above it), seen from a camera
        // 0.4 m to the side and turned 20 degrees about y.
        let n_w = Vector3::new(0.0, -1.0, 0.0);
        let d_w = 1.5;
        let world_from_camera = Isometry3::new(
            Vector3::new(0.4, 0.0, 0.0),
            Vector3::new(0.0, 20f64.to_radians(), 0.0),
        );
        let t_cw = world_from_camera.inverse();
        let on_floor = t_cw * Point3::new(1.0, 1.5, 3.0);
        let n_c = t_cw.rotation * n_w;
        let r = PlaneToPlane {
            normal_in_camera: n_c,
            offset: -n_c.dot(&on_floor.coords),
        };
        assert!(r.error(&t_cw, &n_w, d_w).norm() < 1e-12);
        // 2 cm further from the floor: the offset error is 2 cm.
        let raised = Isometry3::translation(0.0, -0.02, 0.0) * world_from_camera;
        let e = r.error(&raised.inverse(), &n_w, d_w);
        assert!((e[3].abs() - 0.02).abs() < 1e-12, "{e}");
    }
}
