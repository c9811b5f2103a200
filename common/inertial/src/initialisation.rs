//! Gravity, velocities and biases from the first seconds of visual poses.
//!
//! RGB-D poses are metric, so unlike monocular visual-inertial initialisation there is
//! no scale to find, and no standing still is needed: the gyroscope bias is what makes
//! the preintegrated rotations agree with the visual ones (Gauss-Newton on 3
//! unknowns); then the velocities at every pose, gravity and the accelerometer bias
//! follow from the preintegrated velocity and position increments, which are linear
//! in them; gravity's length is then fixed to [`GRAVITY`] by re-solving with its
//! direction on the sphere (two tangent unknowns, relinearised). The accelerometer
//! bias has a weak prior at zero: with little rotation it is confounded with gravity's
//! direction, and a consumer part's bias is a few hundredths of g.

use crate::GRAVITY;
use crate::preintegration::{Bias, Preintegrated};
use gfs_core::se3::{left_jacobian, left_jacobian_inverse};
use nalgebra::{DMatrix, DVector, Matrix3, Rotation3, UnitQuaternion, Vector3};

/// Fewest intervals between poses that initialisation accepts.
pub const MIN_INTERVALS: usize = 5;
/// Gauss-Newton steps of the gyroscope bias, and relinearisations of gravity.
const ITERATIONS: usize = 4;
/// Standard deviation of the accelerometer bias's prior at zero, m/s^2.
const ACCEL_BIAS_PRIOR_SD: f64 = 0.2;

/// What initialisation found.
#[derive(Clone, Debug, PartialEq)]
pub struct InertialInit {
    /// Gravity in the world of the visual poses, length [`GRAVITY`].
    pub gravity: Vector3<f64>,
    /// The IMU's velocity in the world at each pose.
    pub velocities: Vec<Vector3<f64>>,
    /// The biases.
    pub bias: Bias,
    /// RMS of the rotation residuals after the gyroscope bias, radians.
    pub rotation_rms: f64,
}

/// Why initialisation could not be done.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum InitError {
    /// Too few intervals, or the counts of poses and intervals do not match.
    #[error("inertial initialisation needs {needed} intervals between poses, has {had}")]
    TooFew { needed: usize, had: usize },
    /// The linear system had no unique solution.
    #[error("inertial initialisation is degenerate (the motion does not separate gravity)")]
    Degenerate,
}

/// The IMU's poses in the world (`R_wb`, `p_wb`) at consecutive instants, and the
/// samples preintegrated between each pair (with any bias; it is corrected to first
/// order).
pub struct InitInput<'a> {
    /// Poses, one more than intervals.
    pub poses: &'a [(Matrix3<f64>, Vector3<f64>)],
    /// Preintegration between pose `k` and `k + 1`.
    pub intervals: &'a [Preintegrated],
    /// Standard deviation of the visual poses' error: position (m), rotation (rad).
    pub pose_sd: (f64, f64),
}

/// Estimates gravity, velocities and biases from `input`.
pub fn initialise(input: &InitInput) -> Result<InertialInit, InitError> {
    let n = input.intervals.len();
    if n < MIN_INTERVALS || input.poses.len() != n + 1 {
        return Err(InitError::TooFew {
            needed: MIN_INTERVALS,
            had: n.min(input.poses.len().saturating_sub(1)),
        });
    }
    let (gyro, rotation_rms) = gyro_bias(input);
    let mut bias = Bias {
        gyro,
        accel: Vector3::zeros(),
    };
    // Unconstrained gravity first, then on the sphere about the previous estimate.
    let mut solution = solve_linear(input, &bias, None)?;
    for _ in 0..ITERATIONS {
        let direction = solution
            .gravity
            .try_normalize(1e-9)
            .ok_or(InitError::Degenerate)?;
        solution = solve_linear(input, &bias, Some(direction))?;
    }
    bias.accel = solution.accel_bias;
    Ok(InertialInit {
        gravity: solution.gravity.normalize() * GRAVITY,
        velocities: solution.velocities,
        bias,
        rotation_rms,
    })
}

/// The gyroscope bias minimising the rotation residuals, and their RMS after.
fn gyro_bias(input: &InitInput) -> (Vector3<f64>, f64) {
    let mut bias = Bias::default();
    let residuals = |bias: Bias| {
        input.intervals.iter().enumerate().map(move |(k, pre)| {
            let (ri, _) = &input.poses[k];
            let (rj, _) = &input.poses[k + 1];
            let m = pre.delta_rotation(&bias).transpose() * ri.transpose() * rj;
            (pre, Rotation3::from_matrix_unchecked(m).scaled_axis())
        })
    };
    for _ in 0..ITERATIONS {
        let mut h = Matrix3::zeros();
        let mut g = Vector3::zeros();
        for (pre, r) in residuals(bias) {
            let dbg = bias.gyro - pre.bias().gyro;
            let correction = pre.dr_dbg() * dbg;
            let exp_r = UnitQuaternion::from_scaled_axis(r)
                .to_rotation_matrix()
                .into_inner();
            let j = -left_jacobian_inverse(&-r)
                * exp_r.transpose()
                * left_jacobian(&-correction)
                * pre.dr_dbg();
            h += j.transpose() * j;
            g += j.transpose() * r;
        }
        match h.cholesky() {
            Some(c) => bias.gyro -= c.solve(&g),
            None => break,
        }
    }
    let (sum, count) = residuals(bias).fold((0.0, 0usize), |(s, c), (_, r)| {
        (s + r.norm_squared(), c + 1)
    });
    (bias.gyro, (sum / count.max(1) as f64).sqrt())
}

struct LinearSolution {
    gravity: Vector3<f64>,
    velocities: Vec<Vector3<f64>>,
    accel_bias: Vector3<f64>,
}

/// Least squares over `[v_0 .. v_n, gravity unknowns, b_a]`: gravity free (3
/// unknowns) when `direction` is `None`, else `GRAVITY (direction + a e1 + b e2)` with
/// `e1`, `e2` spanning the tangent plane (2 unknowns).
fn solve_linear(
    input: &InitInput,
    bias: &Bias,
    direction: Option<Vector3<f64>>,
) -> Result<LinearSolution, InitError> {
    let n = input.intervals.len();
    let gravity_unknowns = if direction.is_some() { 2 } else { 3 };
    let cols = 3 * (n + 1) + gravity_unknowns + 3;
    let (g0, tangent) = match direction {
        Some(d) => {
            let e1 = d
                .cross(&Vector3::x())
                .try_normalize(1e-6)
                .unwrap_or_else(|| d.cross(&Vector3::y()).normalize());
            let e2 = d.cross(&e1);
            (
                d * GRAVITY,
                Matrix3::from_columns(&[e1 * GRAVITY, e2 * GRAVITY, Vector3::zeros()]),
            )
        }
        None => (Vector3::zeros(), Matrix3::identity()),
    };
    let g_col = 3 * (n + 1);
    let ba_col = g_col + gravity_unknowns;
    let rows = 6 * n + 3;
    let mut a = DMatrix::zeros(rows, cols);
    let mut b = DVector::zeros(rows);
    for (k, pre) in input.intervals.iter().enumerate() {
        let (ri, pi) = &input.poses[k];
        let (_, pj) = &input.poses[k + 1];
        let ri_t = ri.transpose();
        let dt = pre.dt();
        let (_, dv_dba) = pre.dv_db();
        let (_, dp_dba) = pre.dp_db();
        // The increments at the found gyro bias and a zero accel bias: the accel bias
        // enters through its Jacobians as an unknown.
        let at = Bias {
            gyro: bias.gyro,
            accel: Vector3::zeros(),
        };
        let g_tangent = tangent.columns(0, gravity_unknowns);
        // Each equation weighted by its error's standard deviation: the IMU noise over
        // the interval, and the two visual poses' errors (a rotation error turns
        // gravity's share of the velocity increment).
        let covariance = pre.covariance();
        let imu_var = |at: usize| (0..3).map(|d| covariance[(at + d, at + d)]).sum::<f64>() / 3.0;
        let (position_sd, rotation_sd) = input.pose_sd;
        let velocity_sd = (imu_var(3) + 2.0 * (rotation_sd * GRAVITY * dt).powi(2)).sqrt();
        let position_sd = (imu_var(6) + 2.0 * position_sd.powi(2)).sqrt();
        // Velocity: R_i^T (v_j - v_i - g dt) - dv_dba b_a = dv.
        let row = 6 * k;
        let w = 1.0 / velocity_sd.max(1e-9);
        let mut block = |r: usize, c: usize, m: &Matrix3<f64>| {
            a.view_mut((r, c), (3, 3)).copy_from(&(m * w));
        };
        block(row, 3 * (k + 1), &ri_t);
        block(row, 3 * k, &-ri_t);
        block(row, ba_col, &-dv_dba);
        a.view_mut((row, g_col), (3, gravity_unknowns))
            .copy_from(&(-ri_t * dt * g_tangent * w));
        b.rows_mut(row, 3)
            .copy_from(&((pre.delta_velocity(&at) + ri_t * g0 * dt) * w));
        // Position: R_i^T (p_j - p_i - v_i dt - g dt^2 / 2) - dp_dba b_a = dp.
        let row = 6 * k + 3;
        let w = 1.0 / position_sd.max(1e-9);
        a.view_mut((row, 3 * k), (3, 3))
            .copy_from(&(-ri_t * dt * w));
        a.view_mut((row, ba_col), (3, 3)).copy_from(&(-dp_dba * w));
        a.view_mut((row, g_col), (3, gravity_unknowns))
            .copy_from(&(-ri_t * 0.5 * dt * dt * g_tangent * w));
        b.rows_mut(row, 3).copy_from(
            &((pre.delta_position(&at) - ri_t * (pj - pi) + ri_t * g0 * 0.5 * dt * dt) * w),
        );
    }
    // The accelerometer bias's prior at zero.
    let w = 1.0 / ACCEL_BIAS_PRIOR_SD;
    a.view_mut((6 * n, ba_col), (3, 3))
        .copy_from(&(Matrix3::identity() * w));
    let normal = a.transpose() * &a;
    let x = normal
        .cholesky()
        .ok_or(InitError::Degenerate)?
        .solve(&(a.transpose() * b));
    if x.iter().any(|v| !v.is_finite()) {
        return Err(InitError::Degenerate);
    }
    let v3 = |c: usize| Vector3::new(x[c], x[c + 1], x[c + 2]);
    let gravity = match direction {
        Some(_) => g0 + tangent.columns(0, 2) * x.rows(g_col, 2),
        None => v3(g_col),
    };
    Ok(LinearSolution {
        gravity,
        velocities: (0..=n).map(|k| v3(3 * k)).collect(),
        accel_bias: v3(ba_col),
    })
}

#[cfg(test)]
#[path = "initialisation_tests.rs"]
mod tests;
