//! SE(3) Lie-group helpers on `nalgebra::Isometry3<f64>`.
//!
//! The one convention of the project (Solà et al., "A micro Lie theory", left form):
//!
//! - a tangent vector is `xi = [rho; phi]` (translation part first, then rotation), 6x1;
//! - `exp(xi) = [exp(phi), V(phi) rho; 0, 1]`, `log` its inverse;
//! - poses are updated on the **left**: `T ⊕ delta = exp(delta) * T`.
//!
//! Optimisers that estimate `camera_from_world` perturb it on the left, so a
//! Jacobian of a point in the camera frame `p_c = T p_w` with respect to `delta` is
//! `[I, -[p_c]x]`.

use nalgebra::{
    Isometry3, Matrix3, Matrix6, Rotation3, Translation3, UnitQuaternion, Vector3, Vector6,
};

/// Below this angle (radians) the series expansions of V and its inverse are used.
const SMALL_ANGLE: f64 = 1e-8;

/// The skew-symmetric matrix `[v]x` such that `[v]x w = v x w`.
#[inline]
pub fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// The left Jacobian V(phi) of SO(3), which maps `rho` to the translation of `exp(xi)`
/// (and `exp(phi + d) ~ exp(V(phi) d) exp(phi)`).
pub fn left_jacobian(phi: &Vector3<f64>) -> Matrix3<f64> {
    let theta = phi.norm();
    let k = skew(phi);
    if theta < SMALL_ANGLE {
        return Matrix3::identity() + 0.5 * k;
    }
    let t2 = theta * theta;
    Matrix3::identity()
        + (1.0 - theta.cos()) / t2 * k
        + (theta - theta.sin()) / (t2 * theta) * k * k
}

/// Inverse of [`left_jacobian`].
pub fn left_jacobian_inverse(phi: &Vector3<f64>) -> Matrix3<f64> {
    let theta = phi.norm();
    let k = skew(phi);
    if theta < SMALL_ANGLE {
        return Matrix3::identity() - 0.5 * k;
    }
    let half = 0.5 * theta;
    let coeff = (1.0 - half * half.cos() / half.sin()) / (theta * theta);
    Matrix3::identity() - 0.5 * k + coeff * k * k
}

/// The exponential map: tangent vector `[rho; phi]` to a rigid transform.
pub fn exp(xi: &Vector6<f64>) -> Isometry3<f64> {
    let rho = xi.fixed_rows::<3>(0).into_owned();
    let phi = xi.fixed_rows::<3>(3).into_owned();
    let rotation = UnitQuaternion::from_scaled_axis(phi);
    Isometry3::from_parts(Translation3::from(left_jacobian(&phi) * rho), rotation)
}

/// The logarithm map: rigid transform to tangent vector `[rho; phi]` (|phi| <= pi).
pub fn log(t: &Isometry3<f64>) -> Vector6<f64> {
    let phi = t.rotation.scaled_axis();
    let rho = left_jacobian_inverse(&phi) * t.translation.vector;
    Vector6::new(rho.x, rho.y, rho.z, phi.x, phi.y, phi.z)
}

/// The adjoint of `t` on tangent vectors `[rho; phi]`: `exp(Ad(t) xi) = t exp(xi)
/// t^-1`, `Ad(t) = [R, [p]x R; 0, R]`. It carries a covariance from one frame's axes to
/// another's: `Ad C Ad^T`.
pub fn adjoint(t: &Isometry3<f64>) -> Matrix6<f64> {
    let r: Matrix3<f64> = t.rotation.to_rotation_matrix().into_inner();
    let mut ad = Matrix6::zeros();
    ad.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
    ad.fixed_view_mut::<3, 3>(0, 3)
        .copy_from(&(skew(&t.translation.vector) * r));
    ad.fixed_view_mut::<3, 3>(3, 3).copy_from(&r);
    ad
}

/// `exp(delta) * t`: the project's pose update.
pub fn retract(t: &Isometry3<f64>, delta: &Vector6<f64>) -> Isometry3<f64> {
    exp(delta) * t
}

/// Rotation angle of `t` in radians, in [0, pi].
pub fn rotation_angle(t: &Isometry3<f64>) -> f64 {
    t.rotation.angle()
}

/// Rotation from a 3x3 matrix that may be slightly off SO(3) (projected onto it).
///
/// nalgebra's `from_matrix` iterates from the identity until convergence, which never
/// comes for a rotation by half a turn (the iteration's step vanishes there: a RANSAC
/// hypothesis turned the tracker into an endless loop) nor for a matrix holding a NaN.
/// So the iteration is bounded, and when it has not settled it starts again from the
/// matrix's own quaternion, next to the answer. A matrix that is not finite gives the
/// identity.
pub fn rotation_from_matrix(m: &Matrix3<f64>) -> UnitQuaternion<f64> {
    if !m.iter().all(|v| v.is_finite()) {
        return UnitQuaternion::identity();
    }
    let project = |guess| Rotation3::from_matrix_eps(m, f64::EPSILON, PROJECTION_ITERATIONS, guess);
    let from_identity = project(Rotation3::identity());
    let settled = Rotation3::from_matrix_eps(m, f64::EPSILON, 1, from_identity) == from_identity;
    if settled {
        return UnitQuaternion::from_rotation_matrix(&from_identity);
    }
    let near = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*m));
    UnitQuaternion::from_rotation_matrix(&project(near.to_rotation_matrix()))
}

/// Bound on the iterations projecting a matrix onto SO(3); a matrix within rounding of
/// a rotation, from a start not half a turn away, settles in a handful.
pub const PROJECTION_ITERATIONS: usize = 100;

#[cfg(test)]
mod tests {
    #[test]
    fn a_half_turn_is_found_where_the_iteration_from_the_identity_never_settles() {
        // A RANSAC hypothesis of a synthetic low-texture walk: half a turn about an
        // axis in the x-y plane, det 1 to rounding.
        let m = Matrix3::new(
            -0.7742626708187337,
            -0.6328643745516427,
            0.0,
            -0.6328643745516422,
            0.7742626708187337,
            0.0,
            0.0,
            -0.0,
            -1.0,
        );
        let r = rotation_from_matrix(&m).to_rotation_matrix().into_inner();
        assert!((r - m).norm() < 1e-12, "{}", (r - m).norm());
    }

    #[test]
    fn a_matrix_off_so3_is_projected_and_one_with_a_nan_gives_the_identity() {
        let truth = UnitQuaternion::from_euler_angles(0.3, -1.2, 2.9);
        let m = truth.to_rotation_matrix().into_inner() * 1.001 + Matrix3::repeat(1e-4);
        let r = rotation_from_matrix(&m);
        assert!(r.angle_to(&truth) < 1e-3, "{}", r.angle_to(&truth));
        let mut bad = truth.to_rotation_matrix().into_inner();
        bad[(1, 2)] = f64::NAN;
        assert_eq!(rotation_from_matrix(&bad), UnitQuaternion::identity());
        bad[(1, 2)] = f64::INFINITY;
        assert_eq!(rotation_from_matrix(&bad), UnitQuaternion::identity());
    }
    use super::*;

    fn sample() -> Vec<Vector6<f64>> {
        vec![
            Vector6::zeros(),
            Vector6::new(0.1, -0.2, 0.3, 1e-10, 0.0, -1e-10),
            Vector6::new(1.0, 2.0, -0.5, 0.3, -0.7, 0.2),
            Vector6::new(-0.4, 0.1, 0.9, 2.5, 0.4, -1.1),
        ]
    }

    #[test]
    fn exp_log_round_trip() {
        for xi in sample() {
            let back = log(&exp(&xi));
            assert!((back - xi).norm() < 1e-9, "{xi} -> {back}");
        }
    }

    #[test]
    fn exp_of_a_pure_rotation_and_a_pure_translation() {
        let t = exp(&Vector6::new(1.0, 2.0, 3.0, 0.0, 0.0, 0.0));
        assert!((t.translation.vector - Vector3::new(1.0, 2.0, 3.0)).norm() < 1e-12);
        let r = exp(&Vector6::new(
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
            std::f64::consts::FRAC_PI_2,
        ));
        let x = r * nalgebra::Point3::new(1.0, 0.0, 0.0);
        assert!((x.coords - Vector3::new(0.0, 1.0, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn left_perturbation_jacobian_of_a_transformed_point_matches_numeric() {
        let t = exp(&Vector6::new(0.3, -0.1, 0.2, 0.4, 0.2, -0.3));
        let p_w = nalgebra::Point3::new(0.5, -1.0, 3.0);
        let p_c = t * p_w;
        let mut analytic = nalgebra::Matrix3x6::zeros();
        analytic
            .fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&Matrix3::identity());
        analytic
            .fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&(-skew(&p_c.coords)));
        let h = 1e-6;
        for k in 0..6 {
            let mut d = Vector6::zeros();
            d[k] = h;
            let plus = retract(&t, &d) * p_w;
            d[k] = -h;
            let minus = retract(&t, &d) * p_w;
            let col = (plus - minus) / (2.0 * h);
            assert!((col - analytic.column(k)).norm() < 1e-6, "column {k}");
        }
    }

    #[test]
    fn adjoint_moves_a_tangent_vector_through_a_pose() {
        let t = exp(&Vector6::new(0.3, -0.1, 0.2, 0.4, 0.2, -0.3));
        let xi = Vector6::new(0.01, -0.02, 0.015, 0.005, -0.01, 0.02);
        let conjugated = t * exp(&xi) * t.inverse();
        let moved = exp(&(adjoint(&t) * xi));
        assert!((log(&(moved.inverse() * conjugated))).norm() < 1e-12);
    }
}
