//! Which directions of a pose the data leave free: the eigen-analysis of the 6x6
//! information matrix `J^T Omega J` (see [`crate::PoseResult::information`]).
//!
//! Rotation and translation are made comparable by a lever arm `L`: a rotation `phi`
//! moves the scene at `L` metres by `L phi`, so the analysis is made on
//! `S H S`, `S = diag(1, 1, 1, 1/L, 1/L, 1/L)`, whose eigenvalues are 1/m^2. An
//! eigenvector's standard deviation `1 / sqrt(lambda)` is how far (metres at the lever
//! arm) the pose may slide along it at one sigma.

use nalgebra::{Matrix6, SymmetricEigen, Vector6};

/// The directions of a pose whose standard deviation exceeds a bound.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PoseConstraint {
    /// Unit directions `[rho; phi L]` (translation metres, rotation scaled by the lever
    /// arm) left unconstrained, weakest first.
    pub unconstrained: Vec<Vector6<f64>>,
    /// The largest standard deviation over all directions, metres at the lever arm
    /// (infinite when a direction has no information at all).
    pub worst_sigma_m: f64,
}

impl PoseConstraint {
    /// True when every direction is constrained.
    pub fn is_determined(&self) -> bool {
        self.unconstrained.is_empty()
    }
}

/// The symmetric part of `information` with each eigenvalue `l` replaced by `f(l)` (its
/// eigenvectors kept): clamping the directions an estimate took below zero, or a
/// covariance that leaves the directions without information unknown.
pub fn map_eigenvalues(information: &Matrix6<f64>, f: impl Fn(f64) -> f64) -> Matrix6<f64> {
    let eigen = ((information + information.transpose()) * 0.5).symmetric_eigen();
    let mapped = eigen.eigenvalues.map(f);
    eigen.eigenvectors * Matrix6::from_diagonal(&mapped) * eigen.eigenvectors.transpose()
}

/// The directions of `information` whose standard deviation exceeds `max_sigma_m`, with
/// rotations weighed by `lever_arm_m`.
pub fn analyse_constraint(
    information: &Matrix6<f64>,
    lever_arm_m: f64,
    max_sigma_m: f64,
) -> PoseConstraint {
    let inv_l = 1.0 / lever_arm_m.max(f64::MIN_POSITIVE);
    let s = Vector6::new(1.0, 1.0, 1.0, inv_l, inv_l, inv_l);
    let scaled = Matrix6::from_fn(|r, c| information[(r, c)] * s[r] * s[c]);
    if !scaled.iter().all(|v| v.is_finite()) {
        return PoseConstraint {
            unconstrained: (0..6).map(|k| Vector6::ith(k, 1.0)).collect(),
            worst_sigma_m: f64::INFINITY,
        };
    }
    let eigen = SymmetricEigen::new(scaled);
    let min_information = 1.0 / (max_sigma_m * max_sigma_m);
    let mut order: Vec<usize> = (0..6).collect();
    order.sort_by(|&a, &b| eigen.eigenvalues[a].total_cmp(&eigen.eigenvalues[b]));
    let weakest = eigen.eigenvalues[order[0]];
    PoseConstraint {
        unconstrained: order
            .iter()
            .filter(|&&k| eigen.eigenvalues[k] < min_information)
            .map(|&k| eigen.eigenvectors.column(k).into_owned())
            .collect(),
        worst_sigma_m: if weakest > 0.0 {
            1.0 / weakest.sqrt()
        } else {
            f64::INFINITY
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::residuals::PointToPlane;
    use nalgebra::{Isometry3, Vector3};

    /// Information of point-to-plane distances (1 mm sigma) on the planes `x = +-1`
    /// (a corridor's two walls), seen from the identity pose.
    fn two_walls() -> Matrix6<f64> {
        let mut h = Matrix6::zeros();
        for side in [-1.0, 1.0] {
            let normal = Vector3::new(-side, 0.0, 0.0);
            for i in 0..10 {
                for j in 0..10 {
                    let q = Vector3::new(side, -0.5 + 0.1 * i as f64, 1.0 + 0.3 * j as f64);
                    let l = PointToPlane { point_in_camera: q }.linearize(
                        &Isometry3::identity(),
                        &q,
                        &normal,
                    );
                    h += l.d_pose.transpose() * l.d_pose * 1e6;
                }
            }
        }
        h
    }

    #[test]
    fn two_parallel_walls_leave_the_corridor_axes_and_its_roll_free() {
        let c = analyse_constraint(&two_walls(), 2.0, 0.01);
        assert_eq!(c.unconstrained.len(), 3, "{:?}", c.unconstrained);
        assert!(c.worst_sigma_m.is_infinite() || c.worst_sigma_m > 1e3);
        // The free directions span translation along y and z and rotation about x.
        for d in &c.unconstrained {
            let outside = d[0].powi(2) + d[4].powi(2) + d[5].powi(2);
            assert!(outside < 1e-12, "{d}");
        }
        // Adding the floor (y = 1) leaves only the corridor's axis, z, free.
        let mut h = two_walls();
        let floor_normal = Vector3::new(0.0, -1.0, 0.0);
        for i in 0..10 {
            for j in 0..10 {
                let q = Vector3::new(-0.5 + 0.1 * i as f64, 1.0, 1.0 + 0.3 * j as f64);
                let l = PointToPlane { point_in_camera: q }.linearize(
                    &Isometry3::identity(),
                    &q,
                    &floor_normal,
                );
                h += l.d_pose.transpose() * l.d_pose * 1e6;
            }
        }
        let c = analyse_constraint(&h, 2.0, 0.01);
        assert_eq!(c.unconstrained.len(), 1, "{:?}", c.unconstrained);
        assert!((c.unconstrained[0][2].abs() - 1.0).abs() < 1e-9);
    }

    #[test]
    fn a_well_seen_pose_is_determined_and_no_information_is_not() {
        let c = analyse_constraint(&(Matrix6::identity() * 1e6), 1.0, 0.01);
        assert!(c.is_determined());
        assert!((c.worst_sigma_m - 1e-3).abs() < 1e-9);
        let c = analyse_constraint(&Matrix6::zeros(), 2.0, 0.01);
        assert_eq!((c.unconstrained.len(), c.worst_sigma_m), (6, f64::INFINITY));
    }
}
