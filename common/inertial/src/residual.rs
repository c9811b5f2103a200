//! The inertial residual between two states (Forster et al. 2017, eq. 45), with its
//! analytic Jacobians, for the tracker's and the local BA's optimisation.
//!
//! Residual `(r_R, r_v, r_p)`, in the order of the preintegration's covariance:
//!
//! ```text
//! r_R = Log(dR(b_i)^T R_i^T R_j)
//! r_v = R_i^T (v_j - v_i - g dt) - dv(b_i)
//! r_p = R_i^T (p_j - p_i - v_i dt - 1/2 g dt^2) - dp(b_i)
//! ```
//!
//! State perturbation order `(dphi, dp, dv, dbg, dba)`: `R <- R Exp(dphi)`,
//! `p <- p + dp`, `v <- v + dv`, `b <- b + db`. The biases of state `j` do not enter
//! the 9 residuals; they are tied to state `i`'s by the random walk
//! ([`bias_walk_information`]).

use crate::preintegration::{Bias, Matrix9, Preintegrated, orthonormalised};
use gfs_core::se3::{left_jacobian, left_jacobian_inverse, skew};
use nalgebra::{Matrix3, Rotation3, SMatrix, SVector, UnitQuaternion, Vector3};

/// 9-vector `(r_R, r_v, r_p)`.
pub type Vector9 = SVector<f64, 9>;

/// The IMU's state at an instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct State {
    /// Orientation of the IMU in the world, `R_wb`.
    pub rotation: Matrix3<f64>,
    /// Position of the IMU in the world, m.
    pub position: Vector3<f64>,
    /// Velocity in the world, m/s.
    pub velocity: Vector3<f64>,
    /// Biases.
    pub bias: Bias,
}

impl State {
    /// The state moved by `delta = (dphi, dp, dv, dbg, dba)`.
    pub fn perturbed(&self, delta: &SVector<f64, 15>) -> State {
        let v3 = |k: usize| Vector3::new(delta[k], delta[k + 1], delta[k + 2]);
        let step = UnitQuaternion::from_scaled_axis(v3(0)).to_rotation_matrix();
        State {
            rotation: orthonormalised(&(self.rotation * step.into_inner())),
            position: self.position + v3(3),
            velocity: self.velocity + v3(6),
            bias: Bias {
                gyro: self.bias.gyro + v3(9),
                accel: self.bias.accel + v3(12),
            },
        }
    }

    /// The state at the end of `pre` from this one, under `gravity`, biases kept.
    pub fn predicted(&self, pre: &Preintegrated, gravity: &Vector3<f64>) -> State {
        let dt = pre.dt();
        State {
            rotation: orthonormalised(&(self.rotation * pre.delta_rotation(&self.bias))),
            position: self.position
                + self.velocity * dt
                + 0.5 * gravity * dt * dt
                + self.rotation * pre.delta_position(&self.bias),
            velocity: self.velocity + gravity * dt + self.rotation * pre.delta_velocity(&self.bias),
            bias: self.bias,
        }
    }
}

/// The residual and its Jacobians at two states.
#[derive(Clone, Debug, PartialEq)]
pub struct InertialResidual {
    /// `(r_R, r_v, r_p)`.
    pub residual: Vector9,
    /// With respect to state `i`: `(dphi, dp, dv, dbg, dba)`.
    pub jacobian_i: SMatrix<f64, 9, 15>,
    /// With respect to state `j`: `(dphi, dp, dv)`.
    pub jacobian_j: SMatrix<f64, 9, 9>,
}

/// Rotation logarithm (axis times angle), through the nearest unit quaternion: a
/// product of rotations that rounds to a trace just above 3 has no angle by `acos`.
pub fn log_so3(m: &Matrix3<f64>) -> Vector3<f64> {
    UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*m)).scaled_axis()
}

impl InertialResidual {
    /// The residual of `pre` between `i` and `j` under `gravity`, with `i`'s biases.
    pub fn evaluate(pre: &Preintegrated, i: &State, j: &State, gravity: &Vector3<f64>) -> Self {
        let dt = pre.dt();
        let ri_t = i.rotation.transpose();
        let (dbg, _) = (
            i.bias.gyro - pre.bias().gyro,
            i.bias.accel - pre.bias().accel,
        );

        let r_r = log_so3(&(pre.delta_rotation(&i.bias).transpose() * ri_t * j.rotation));
        let dv_world = j.velocity - i.velocity - gravity * dt;
        let dp_world = j.position - i.position - i.velocity * dt - 0.5 * gravity * dt * dt;
        let r_v = ri_t * dv_world - pre.delta_velocity(&i.bias);
        let r_p = ri_t * dp_world - pre.delta_position(&i.bias);

        let mut residual = Vector9::zeros();
        residual.fixed_rows_mut::<3>(0).copy_from(&r_r);
        residual.fixed_rows_mut::<3>(3).copy_from(&r_v);
        residual.fixed_rows_mut::<3>(6).copy_from(&r_p);

        // Right Jacobians from the left ones: Jr(x) = Jl(-x).
        let jr_inv = left_jacobian_inverse(&-r_r);
        let correction = pre.dr_dbg() * dbg;
        let exp_r = UnitQuaternion::from_scaled_axis(r_r)
            .to_rotation_matrix()
            .into_inner();
        let (dv_dbg, dv_dba) = pre.dv_db();
        let (dp_dbg, dp_dba) = pre.dp_db();

        let mut ji = SMatrix::<f64, 9, 15>::zeros();
        ji.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(-jr_inv * j.rotation.transpose() * i.rotation));
        ji.fixed_view_mut::<3, 3>(0, 9)
            .copy_from(&(-jr_inv * exp_r.transpose() * left_jacobian(&-correction) * pre.dr_dbg()));
        ji.fixed_view_mut::<3, 3>(3, 0)
            .copy_from(&skew(&(ri_t * dv_world)));
        ji.fixed_view_mut::<3, 3>(3, 6).copy_from(&-ri_t);
        ji.fixed_view_mut::<3, 3>(3, 9).copy_from(&-dv_dbg);
        ji.fixed_view_mut::<3, 3>(3, 12).copy_from(&-dv_dba);
        ji.fixed_view_mut::<3, 3>(6, 0)
            .copy_from(&skew(&(ri_t * dp_world)));
        ji.fixed_view_mut::<3, 3>(6, 3).copy_from(&-ri_t);
        ji.fixed_view_mut::<3, 3>(6, 6).copy_from(&(-ri_t * dt));
        ji.fixed_view_mut::<3, 3>(6, 9).copy_from(&-dp_dbg);
        ji.fixed_view_mut::<3, 3>(6, 12).copy_from(&-dp_dba);

        let mut jj = SMatrix::<f64, 9, 9>::zeros();
        jj.fixed_view_mut::<3, 3>(0, 0).copy_from(&jr_inv);
        jj.fixed_view_mut::<3, 3>(3, 6).copy_from(&ri_t);
        jj.fixed_view_mut::<3, 3>(6, 3).copy_from(&ri_t);

        InertialResidual {
            residual,
            jacobian_i: ji,
            jacobian_j: jj,
        }
    }

    /// `r^T Sigma^-1 r` under the preintegration's covariance.
    pub fn chi2(&self, pre: &Preintegrated) -> f64 {
        let info = information(pre.covariance());
        (self.residual.transpose() * info * self.residual)[(0, 0)]
    }
}

/// The inverse of a preintegration covariance, with a floor on its diagonal so that an
/// interval of a few samples (covariance near zero) does not outweigh everything.
pub fn information(covariance: &Matrix9) -> Matrix9 {
    /// 1e-12 rad^2, (m/s)^2, m^2: far below any real interval's noise.
    const FLOOR: f64 = 1e-12;
    let floored = covariance + Matrix9::identity() * FLOOR;
    floored
        .cholesky()
        .map_or_else(|| Matrix9::identity() / FLOOR, |c| c.inverse())
}

/// Information of the bias change over `dt` seconds, `(dbg, dba)` order: the
/// inverse of the random walk's variance `walk^2 dt`.
pub fn bias_walk_information(pre: &Preintegrated) -> SVector<f64, 6> {
    let dt = pre.dt().max(1e-3);
    let g = 1.0 / (pre.noise().gyro_walk.powi(2) * dt);
    let a = 1.0 / (pre.noise().accel_walk.powi(2) * dt);
    SVector::<f64, 6>::new(g, g, g, a, a, a)
}

#[cfg(test)]
#[path = "residual_tests.rs"]
mod tests;
