//! The error of one relative-pose edge and its Jacobians.
//!
//! Nodes are `world_from_camera` poses `T_i`, perturbed on the **left** (the project's
//! convention, `gfs_core::se3`): `T_i ⊕ d_i = exp(d_i) T_i`, `d = [rho; phi]` in the
//! world frame. An edge measures `Z = i_from_j`, the pose of node `j` seen from node
//! `i`; its error is
//!
//! ```text
//! e = log(Z^-1 T_i^-1 T_j)                                  (0 when the edge holds)
//! de/dd_j = Jl^-1(e) Ad(Z^-1 T_i^-1) = J,    de/dd_i = -J
//! ```
//!
//! since `Z^-1 T_i^-1 exp(d) T_j = exp(Ad(Z^-1 T_i^-1) d) E` and
//! `log(exp(x) exp(e)) = e + Jl^-1(e) x + O(x^2)` (Barfoot, "State Estimation for
//! Robotics", sec. 7.1.5: the SE(3) left Jacobian and its `Q` block).

use gfs_core::se3::{left_jacobian_inverse, log, skew};
use nalgebra::{Isometry3, Matrix3, Matrix6, Vector3, Vector6};

/// Below this angle the coefficients of `Q` use their Taylor series (the closed forms
/// lose all precision to cancellation near zero).
const SERIES_ANGLE: f64 = 1e-2;

/// The adjoint of `t` on tangent vectors `[rho; phi]`: `exp(Ad_t x) = t exp(x) t^-1`,
/// `Ad_t = [[R, [p]x R], [0, R]]`.
pub(crate) fn adjoint(t: &Isometry3<f64>) -> Matrix6<f64> {
    let r = t.rotation.to_rotation_matrix().into_inner();
    let tr = skew(&t.translation.vector) * r;
    let mut a = Matrix6::zeros();
    a.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
    a.fixed_view_mut::<3, 3>(0, 3).copy_from(&tr);
    a.fixed_view_mut::<3, 3>(3, 3).copy_from(&r);
    a
}

/// The off-diagonal block `Q(rho, phi)` of the SE(3) left Jacobian
/// `Jl = [[J, Q], [0, J]]` (Barfoot eq. 7.86).
fn q_block(rho: &Vector3<f64>, phi: &Vector3<f64>) -> Matrix3<f64> {
    let theta = phi.norm();
    let t2 = theta * theta;
    let (c1, c2, c3) = if theta < SERIES_ANGLE {
        (
            1.0 / 6.0 - t2 / 120.0,
            1.0 / 24.0 - t2 / 720.0,
            1.0 / 120.0 - t2 / 2520.0,
        )
    } else {
        let (s, c) = theta.sin_cos();
        let t4 = t2 * t2;
        (
            (theta - s) / (t2 * theta),
            (t2 + 2.0 * c - 2.0) / (2.0 * t4),
            (2.0 * theta - 3.0 * s + theta * c) / (2.0 * t4 * theta),
        )
    };
    let p = skew(phi);
    let r = skew(rho);
    let pr = p * r;
    let rp = r * p;
    let prp = pr * p;
    0.5 * r + c1 * (pr + rp + prp) + c2 * (p * pr + rp * p - 3.0 * prp) + c3 * (prp * p + p * prp)
}

/// Inverse of the SE(3) left Jacobian at `xi = [rho; phi]`:
/// `[[J^-1, -J^-1 Q J^-1], [0, J^-1]]`.
pub(crate) fn se3_left_jacobian_inverse(xi: &Vector6<f64>) -> Matrix6<f64> {
    let rho = xi.fixed_rows::<3>(0).into_owned();
    let phi = xi.fixed_rows::<3>(3).into_owned();
    let j_inv = left_jacobian_inverse(&phi);
    let mut m = Matrix6::zeros();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(&j_inv);
    m.fixed_view_mut::<3, 3>(0, 3)
        .copy_from(&(-j_inv * q_block(&rho, &phi) * j_inv));
    m.fixed_view_mut::<3, 3>(3, 3).copy_from(&j_inv);
    m
}

/// The error `log(Z^-1 T_i^-1 T_j)` of an edge whose inverted measurement is
/// `j_from_i = Z^-1`.
#[inline]
pub(crate) fn edge_error(
    j_from_i: &Isometry3<f64>,
    pose_i: &Isometry3<f64>,
    pose_j: &Isometry3<f64>,
) -> Vector6<f64> {
    log(&(j_from_i * pose_i.inverse() * pose_j))
}

/// The error and its Jacobian `J = de/dd_j` (`de/dd_i = -J`) at the current poses.
pub(crate) fn linearize_edge(
    j_from_i: &Isometry3<f64>,
    pose_i: &Isometry3<f64>,
    pose_j: &Isometry3<f64>,
) -> (Vector6<f64>, Matrix6<f64>) {
    let a = j_from_i * pose_i.inverse();
    let e = log(&(a * pose_j));
    (e, se3_left_jacobian_inverse(&e) * adjoint(&a))
}

#[cfg(test)]
mod tests {
    use super::*;
    use gfs_core::se3::{exp, retract};

    fn pose(xi: [f64; 6]) -> Isometry3<f64> {
        exp(&Vector6::from_column_slice(&xi))
    }

    fn numeric(
        f: impl Fn(&Vector6<f64>) -> Vector6<f64>,
        at: &Vector6<f64>,
        h: f64,
    ) -> Matrix6<f64> {
        let mut m = Matrix6::zeros();
        for k in 0..6 {
            let mut d = Vector6::zeros();
            d[k] = h;
            m.set_column(k, &((f(&(at + d)) - f(&(at - d))) / (2.0 * h)));
        }
        m
    }

    #[test]
    fn adjoint_moves_a_perturbation_through_a_pose() {
        let t = pose([0.4, -1.0, 2.0, 0.3, -0.5, 0.9]);
        let x = Vector6::new(0.01, -0.02, 0.03, 0.02, 0.01, -0.03);
        let lhs = t * exp(&x) * t.inverse();
        let rhs = exp(&(adjoint(&t) * x));
        assert!((log(&(lhs.inverse() * rhs))).norm() < 1e-12);
    }

    #[test]
    fn left_jacobian_inverse_matches_numeric_differences() {
        // log(exp(x) exp(e)) = e + Jl^-1(e) x: differentiate at x = 0, for large and
        // tiny rotations (both branches of the Q coefficients).
        for xi in [
            [0.5, -1.2, 0.8, 0.9, -0.4, 1.3],
            [0.3, 0.2, -0.1, 0.004, -0.003, 0.002],
            [1.0, 2.0, 3.0, 0.0, 0.0, 0.0],
        ] {
            let e = Vector6::from_column_slice(&xi);
            let t = exp(&e);
            let f = |x: &Vector6<f64>| log(&(exp(x) * t));
            let num = numeric(f, &Vector6::zeros(), 1e-6);
            let err = (num - se3_left_jacobian_inverse(&e)).abs().max();
            assert!(err < 1e-7, "xi {xi:?}: max difference {err}");
        }
    }

    #[test]
    fn edge_jacobians_match_numeric_differences() {
        let pose_i = pose([1.0, -0.5, 0.3, 0.2, -0.4, 0.7]);
        let pose_j = pose([2.5, 0.4, -0.2, -0.3, 0.5, 1.4]);
        // A measurement off by a sizeable error, so that Jl^-1(e) is far from identity.
        let truth = pose_i.inverse() * pose_j;
        let measured = pose([0.2, -0.1, 0.15, 0.1, 0.2, -0.15]) * truth;
        let j_from_i = measured.inverse();
        let (e, jac) = linearize_edge(&j_from_i, &pose_i, &pose_j);
        assert!((e - edge_error(&j_from_i, &pose_i, &pose_j)).norm() < 1e-15);
        assert!(e.norm() > 0.2);
        let zero = Vector6::zeros();
        let num_j = numeric(
            |d| edge_error(&j_from_i, &pose_i, &retract(&pose_j, d)),
            &zero,
            1e-6,
        );
        let num_i = numeric(
            |d| edge_error(&j_from_i, &retract(&pose_i, d), &pose_j),
            &zero,
            1e-6,
        );
        let err_j = (num_j - jac).abs().max();
        let err_i = (num_i + jac).abs().max();
        assert!(err_j < 1e-7 && err_i < 1e-7, "d/dj {err_j}, d/di {err_i}");
    }
}
