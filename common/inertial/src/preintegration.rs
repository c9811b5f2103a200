//! Preintegration: the motion between two frames from the IMU samples between them,
//! independent of the states at either end, so an optimiser that moves the states
//! never integrates again; a change of the bias estimate is applied to first order
//! through the stored bias Jacobians (Forster et al. 2017, sections V-VI).
//!
//! With `w~`, `a~` the measurements held over `dt` and `b` the bias the integration
//! was made with:
//!
//! ```text
//! dR_k+1 = dR_k Exp((w~ - b_g) dt)
//! dv_k+1 = dv_k + dR_k (a~ - b_a) dt
//! dp_k+1 = dp_k + dv_k dt + 1/2 dR_k (a~ - b_a) dt^2
//! ```
//!
//! The covariance is propagated over the error `(dphi, dv, dp)` in that order.

use crate::noise::ImuNoise;
use crate::sample::ImuSample;
use gfs_core::se3::{left_jacobian, skew};
use gfs_core::stamp::Stamp;
use nalgebra::{Matrix3, SMatrix, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// 9x9 matrix over `(dphi, dv, dp)`.
pub type Matrix9 = SMatrix<f64, 9, 9>;

/// Gyroscope and accelerometer biases.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Bias {
    /// Gyroscope bias, rad/s.
    pub gyro: Vector3<f64>,
    /// Accelerometer bias, m/s^2.
    pub accel: Vector3<f64>,
}

/// Why the samples cannot be integrated over an interval.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CoverageError {
    /// No sample at or before the interval's start (within the allowed gap).
    #[error("no IMU sample within {gap_s} s before {at}")]
    Start { at: Stamp, gap_s: f64 },
    /// No sample at or after the interval's end (within the allowed gap).
    #[error("no IMU sample within {gap_s} s after {at}")]
    End { at: Stamp, gap_s: f64 },
    /// Two consecutive samples inside the interval are further apart than allowed.
    #[error("a gap of {gap_s:.3} s between IMU samples at {after}")]
    Gap { after: Stamp, gap_s: f64 },
    /// The interval ends before it starts.
    #[error("the interval {from} .. {to} runs backwards")]
    Backwards { from: Stamp, to: Stamp },
}

/// The preintegrated motion between two instants.
#[derive(Clone, Debug, PartialEq)]
pub struct Preintegrated {
    bias: Bias,
    noise: ImuNoise,
    dt: f64,
    delta_r: Matrix3<f64>,
    delta_v: Vector3<f64>,
    delta_p: Vector3<f64>,
    covariance: Matrix9,
    dr_dbg: Matrix3<f64>,
    dv_dbg: Matrix3<f64>,
    dv_dba: Matrix3<f64>,
    dp_dbg: Matrix3<f64>,
    dp_dba: Matrix3<f64>,
}

impl Preintegrated {
    /// Nothing integrated yet, with `bias` as the linearisation point.
    pub fn new(bias: Bias, noise: ImuNoise) -> Self {
        Self {
            bias,
            noise,
            dt: 0.0,
            delta_r: Matrix3::identity(),
            delta_v: Vector3::zeros(),
            delta_p: Vector3::zeros(),
            covariance: Matrix9::zeros(),
            dr_dbg: Matrix3::zeros(),
            dv_dbg: Matrix3::zeros(),
            dv_dba: Matrix3::zeros(),
            dp_dbg: Matrix3::zeros(),
            dp_dba: Matrix3::zeros(),
        }
    }

    /// Integrates `samples` (ordered by stamp) over `from .. to`: each stretch between
    /// two samples uses their mean measured at its middle (linear interpolation), the
    /// ends hold the nearest sample for up to `max_gap_s`.
    pub fn between(
        samples: &[ImuSample],
        from: Stamp,
        to: Stamp,
        bias: Bias,
        noise: ImuNoise,
        max_gap_s: f64,
    ) -> Result<Self, CoverageError> {
        if to < from {
            return Err(CoverageError::Backwards { from, to });
        }
        let mut pre = Self::new(bias, noise);
        let first = samples.partition_point(|s| s.stamp <= from);
        let last = samples.partition_point(|s| s.stamp < to);
        let before = first.checked_sub(1).map(|i| &samples[i]);
        let after = samples.get(last);
        let start = before
            .or_else(|| samples.get(first))
            .filter(|s| s.stamp.secs_since(from).abs() <= max_gap_s)
            .ok_or(CoverageError::Start {
                at: from,
                gap_s: max_gap_s,
            })?;
        let end = after
            .or_else(|| last.checked_sub(1).map(|i| &samples[i]))
            .filter(|s| s.stamp.secs_since(to).abs() <= max_gap_s)
            .ok_or(CoverageError::End {
                at: to,
                gap_s: max_gap_s,
            })?;
        // The knots of the piecewise-linear measurement over [from, to].
        let mut knots: Vec<(Stamp, Vector3<f64>, Vector3<f64>)> = Vec::new();
        knots.push((from, start.gyro, start.accel));
        for s in &samples[first..last] {
            knots.push((s.stamp, s.gyro, s.accel));
        }
        knots.push((to, end.gyro, end.accel));
        for pair in knots.windows(2) {
            let ((t0, g0, a0), (t1, g1, a1)) = (pair[0], pair[1]);
            let dt = t1.secs_since(t0);
            if dt > max_gap_s {
                return Err(CoverageError::Gap {
                    after: t0,
                    gap_s: dt,
                });
            }
            if dt > 0.0 {
                pre.integrate(&(0.5 * (g0 + g1)), &(0.5 * (a0 + a1)), dt);
            }
        }
        Ok(pre)
    }

    /// Adds one measurement held over `dt` seconds.
    pub fn integrate(&mut self, gyro: &Vector3<f64>, accel: &Vector3<f64>, dt: f64) {
        let omega = gyro - self.bias.gyro;
        let acc = accel - self.bias.accel;
        let step = UnitQuaternion::from_scaled_axis(omega * dt)
            .to_rotation_matrix()
            .into_inner();
        // Right Jacobian of the step: Jr(x) = Jl(-x).
        let jr = left_jacobian(&(-omega * dt));
        let acc_hat = skew(&acc);
        let r = self.delta_r;
        let dt2 = dt * dt;

        // Error propagation over (dphi, dv, dp).
        let mut a = Matrix9::identity();
        a.fixed_view_mut::<3, 3>(0, 0).copy_from(&step.transpose());
        a.fixed_view_mut::<3, 3>(3, 0)
            .copy_from(&(-r * acc_hat * dt));
        a.fixed_view_mut::<3, 3>(6, 0)
            .copy_from(&(-0.5 * r * acc_hat * dt2));
        a.fixed_view_mut::<3, 3>(6, 3)
            .copy_from(&(Matrix3::identity() * dt));
        let gyro_var = self.noise.gyro_noise.powi(2) / dt;
        let accel_var = self.noise.accel_noise.powi(2) / dt;
        let mut q = Matrix9::zeros();
        q.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(jr * jr.transpose() * (gyro_var * dt2)));
        let b_v = r * dt;
        let b_p = 0.5 * r * dt2;
        q.fixed_view_mut::<3, 3>(3, 3)
            .copy_from(&(b_v * b_v.transpose() * accel_var));
        q.fixed_view_mut::<3, 3>(3, 6)
            .copy_from(&(b_v * b_p.transpose() * accel_var));
        q.fixed_view_mut::<3, 3>(6, 3)
            .copy_from(&(b_p * b_v.transpose() * accel_var));
        q.fixed_view_mut::<3, 3>(6, 6)
            .copy_from(&(b_p * b_p.transpose() * accel_var));
        self.covariance = a * self.covariance * a.transpose() + q;

        // Bias Jacobians: position first (it reads the velocity's), then velocity,
        // then rotation, all from the values before this step.
        self.dp_dba += self.dv_dba * dt - 0.5 * r * dt2;
        self.dp_dbg += self.dv_dbg * dt - 0.5 * r * acc_hat * self.dr_dbg * dt2;
        self.dv_dba -= r * dt;
        self.dv_dbg -= r * acc_hat * self.dr_dbg * dt;
        self.dr_dbg = step.transpose() * self.dr_dbg - jr * dt;

        self.delta_p += self.delta_v * dt + 0.5 * r * acc * dt2;
        self.delta_v += r * acc * dt;
        self.delta_r = orthonormalised(&(r * step));
        self.dt += dt;
    }

    /// Seconds integrated.
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// The bias the samples were integrated with.
    pub fn bias(&self) -> &Bias {
        &self.bias
    }

    /// The noise the covariance was propagated with.
    pub fn noise(&self) -> &ImuNoise {
        &self.noise
    }

    /// Covariance of `(dphi, dv, dp)` from the white noise.
    pub fn covariance(&self) -> &Matrix9 {
        &self.covariance
    }

    /// The change of bias from the linearisation point.
    fn bias_change(&self, bias: &Bias) -> (Vector3<f64>, Vector3<f64>) {
        (bias.gyro - self.bias.gyro, bias.accel - self.bias.accel)
    }

    /// The rotation increment for `bias`, to first order in its change.
    pub fn delta_rotation(&self, bias: &Bias) -> Matrix3<f64> {
        let (dbg, _) = self.bias_change(bias);
        let correction = UnitQuaternion::from_scaled_axis(self.dr_dbg * dbg);
        self.delta_r * correction.to_rotation_matrix().into_inner()
    }

    /// The velocity increment for `bias`, to first order in its change.
    pub fn delta_velocity(&self, bias: &Bias) -> Vector3<f64> {
        let (dbg, dba) = self.bias_change(bias);
        self.delta_v + self.dv_dbg * dbg + self.dv_dba * dba
    }

    /// The position increment for `bias`, to first order in its change.
    pub fn delta_position(&self, bias: &Bias) -> Vector3<f64> {
        let (dbg, dba) = self.bias_change(bias);
        self.delta_p + self.dp_dbg * dbg + self.dp_dba * dba
    }

    /// Jacobian of the rotation increment's tangent with respect to the gyro bias.
    pub fn dr_dbg(&self) -> &Matrix3<f64> {
        &self.dr_dbg
    }

    /// Jacobians of the velocity increment with respect to the gyro and accel biases.
    pub fn dv_db(&self) -> (&Matrix3<f64>, &Matrix3<f64>) {
        (&self.dv_dbg, &self.dv_dba)
    }

    /// Jacobians of the position increment with respect to the gyro and accel biases.
    pub fn dp_db(&self) -> (&Matrix3<f64>, &Matrix3<f64>) {
        (&self.dp_dbg, &self.dp_dba)
    }
}

/// The rotation nearest to `m` (rounding accumulates over hundreds of products).
pub(crate) fn orthonormalised(m: &Matrix3<f64>) -> Matrix3<f64> {
    gfs_core::se3::rotation_from_matrix(m)
        .to_rotation_matrix()
        .into_inner()
}

#[cfg(test)]
#[path = "preintegration_tests.rs"]
mod tests;
