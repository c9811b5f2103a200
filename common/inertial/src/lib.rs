//! The camera's inertial measurement unit.
//!
//! RGB-D cameras robots carry (RealSense D435i / D455, Azure Kinect, Orbbec) have a
//! gyroscope and an accelerometer. Where the images and the depth leave a direction
//! unobserved (one wall and the floor, a blur), the IMU carries the motion for the
//! seconds that matter, and it measures gravity, which fixes the vertical.
//!
//! - [`config`]: the `[imu]` table: the IMU's mount in the camera, noise, clock;
//! - [`sample`]: one measurement, and a stream's checks (order, repeats, gaps, NaN) and
//!   the combination of separate gyroscope and accelerometer topics;
//! - [`feed`]: an input's samples handed to the tracker a frame at a time;
//! - [`noise`]: noise densities and bias random walks, with the figures of the parts
//!   these cameras carry;
//! - [`preintegration`]: the motion between two frames from the samples between them,
//!   on the manifold, with its covariance and its Jacobians with respect to the biases
//!   (Forster et al., "On-Manifold Preintegration for Real-Time Visual-Inertial
//!   Odometry", T-RO 2017);
//! - [`residual`]: the inertial residual between two states, with analytic Jacobians;
//! - [`initialisation`]: gravity, velocities and biases from the first seconds of
//!   visual poses (RGB-D poses are metric, so there is no scale to find);
//! - [`simulate`]: what an IMU on a known motion reads, for `gfsvo synth --imu`.
//!
//! Conventions: the world has gravity `g_w = (0, 0, -9.81)` only after
//! [`initialisation`] has found which way is down; a state is the IMU's pose `R_wb`,
//! `p_wb`, its velocity `v_wb` in the world, and the biases; a state is perturbed as
//! `R <- R Exp(dphi)`, `p <- p + dp`, `v <- v + dv`, `b <- b + db`.

pub mod config;
pub mod feed;
pub mod initialisation;
pub mod noise;
pub mod preintegration;
pub mod residual;
pub mod sample;
pub mod simulate;
#[cfg(test)]
pub(crate) mod testing;

pub use config::ImuConfig;
pub use feed::ImuFeed;
pub use initialisation::{InertialInit, InitError, initialise};
pub use noise::ImuNoise;
pub use preintegration::{Bias, Preintegrated};
pub use residual::{InertialResidual, State};
pub use sample::{GyroAccelUnion, ImuSample, ImuStream, Pushed, SampleIssue};

/// Standard gravity, m/s^2.
pub const GRAVITY: f64 = 9.80665;
