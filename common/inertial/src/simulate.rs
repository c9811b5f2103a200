//! What an IMU riding a known motion measures: the exact angular velocity and specific
//! force, and a consumer part's white noise and walking biases on top. For
//! `gfsvo synth --imu` and the tests; the motion is any function of time giving the
//! IMU's pose in a world whose `z` is up.

use crate::GRAVITY;
use crate::noise::ImuNoise;
use crate::preintegration::Bias;
use crate::sample::ImuSample;
use gfs_core::rng::SplitMix64;
use gfs_core::stamp::Stamp;
use nalgebra::{Matrix3, Rotation3, Vector3};

/// Step of the central differences, seconds: small enough that the truncation error of
/// a hand-held motion (tremor at 2 Hz) is about 1e-5 m/s^2, large enough that rounding
/// of positions near 1 m stays near 1e-9 m/s^2.
const DIFFERENCE_STEP_S: f64 = 1e-3;

/// The world's gravity (z up), m/s^2.
pub fn world_gravity() -> Vector3<f64> {
    Vector3::new(0.0, 0.0, -GRAVITY)
}

/// The exact gyroscope and accelerometer readings at `t` of an IMU whose pose in the
/// world (`R_wb`, `p_wb`) is `pose_at(t)`: the angular velocity in the IMU's axes and
/// the specific force `R_wb^T (a - g)`.
pub fn exact_reading(
    pose_at: &impl Fn(f64) -> (Matrix3<f64>, Vector3<f64>),
    t: f64,
) -> (Vector3<f64>, Vector3<f64>) {
    let h = DIFFERENCE_STEP_S;
    let (r_before, p_before) = pose_at(t - h);
    let (r, p) = pose_at(t);
    let (r_after, p_after) = pose_at(t + h);
    // R(t -+ h) = R(t) Exp(-+ w h) to second order, so the turn between them is 2 w h.
    let turn = Rotation3::from_matrix_unchecked(r_before.transpose() * r_after).scaled_axis();
    let gyro = turn / (2.0 * h);
    let acceleration = (p_after - 2.0 * p + p_before) / (h * h);
    let accel = r.transpose() * (acceleration - world_gravity());
    (gyro, accel)
}

/// A consumer IMU on a known motion.
pub struct Simulator {
    noise: ImuNoise,
    bias: Bias,
    rng: SplitMix64,
}

impl Simulator {
    /// A part with `noise`, starting with `bias`, its random draws from `seed`.
    pub fn new(noise: ImuNoise, bias: Bias, seed: u64) -> Self {
        Self {
            noise,
            bias,
            rng: SplitMix64::keyed(seed, &[0x0069_6d75]),
        }
    }

    fn gaussian3(&mut self) -> Vector3<f64> {
        Vector3::new(
            self.rng.gaussian(),
            self.rng.gaussian(),
            self.rng.gaussian(),
        )
    }

    /// The bias now.
    pub fn bias(&self) -> &Bias {
        &self.bias
    }

    /// Samples at `rate_hz` over `[t0, t1)` seconds of the motion, stamped
    /// `epoch + t`; each is the exact reading plus the bias and white noise, and the
    /// bias then walks by one step.
    pub fn run(
        &mut self,
        pose_at: &impl Fn(f64) -> (Matrix3<f64>, Vector3<f64>),
        span: (f64, f64),
        rate_hz: f64,
        epoch: Stamp,
    ) -> Vec<ImuSample> {
        let dt = 1.0 / rate_hz;
        // [t0, t1): a rounding of the product above a whole number adds no sample.
        let count = ((span.1 - span.0) * rate_hz - 1e-9).ceil().max(0.0) as usize;
        let gyro_sd = self.noise.gyro_noise / dt.sqrt();
        let accel_sd = self.noise.accel_noise / dt.sqrt();
        let gyro_step = self.noise.gyro_walk * dt.sqrt();
        let accel_step = self.noise.accel_walk * dt.sqrt();
        (0..count)
            .map(|k| {
                let t = span.0 + k as f64 * dt;
                let (gyro, accel) = exact_reading(pose_at, t);
                let gyro_noise = self.gaussian3() * gyro_sd;
                let accel_noise = self.gaussian3() * accel_sd;
                let sample = ImuSample {
                    stamp: Stamp::from_nanos(epoch.nanos() + (t * 1e9).round() as i64),
                    gyro: gyro + self.bias.gyro + gyro_noise,
                    accel: accel + self.bias.accel + accel_noise,
                };
                let gyro_walk = self.gaussian3() * gyro_step;
                let accel_walk = self.gaussian3() * accel_step;
                self.bias.gyro += gyro_walk;
                self.bias.accel += accel_walk;
                sample
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    #[test]
    fn a_steady_turn_and_a_circle_read_as_their_formulas() {
        // Turning about z at 0.5 rad/s on a circle of 2 m radius: the IMU's x axis
        // along the tangent, so the centripetal acceleration 0.5 m/s^2 is along -y.
        let w = 0.5;
        let radius = 2.0;
        let pose = |t: f64| {
            let r = UnitQuaternion::from_euler_angles(0.0, 0.0, w * t)
                .to_rotation_matrix()
                .into_inner();
            let p = Vector3::new(radius * (w * t).sin(), -radius * (w * t).cos(), 0.0);
            (r, p)
        };
        let (gyro, accel) = exact_reading(&pose, 3.0);
        assert!((gyro - Vector3::new(0.0, 0.0, w)).norm() < 1e-6, "{gyro}");
        let expected = Vector3::new(0.0, w * w * radius, GRAVITY);
        assert!((accel - expected).norm() < 1e-5, "{accel} vs {expected}");
    }

    #[test]
    fn noise_and_bias_walk_have_the_datasheet_sizes() {
        let still = |_: f64| (Matrix3::identity(), Vector3::zeros());
        let mut imu = Simulator::new(ImuNoise::BMI055, Bias::default(), 7);
        let rate = 200.0;
        let samples = imu.run(&still, (0.0, 100.0), rate, Stamp::default());
        assert_eq!(samples.len(), 20_000);
        // White noise: per-sample sd = density * sqrt(rate); the bias drifts far less.
        let sd = |f: &dyn Fn(&ImuSample) -> f64| {
            let values: Vec<f64> = samples.windows(2).map(|w| f(&w[1]) - f(&w[0])).collect();
            let mean = values.iter().sum::<f64>() / values.len() as f64;
            (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / values.len() as f64).sqrt()
                / 2f64.sqrt()
        };
        let gyro_sd = sd(&|s| s.gyro.x);
        let expected = ImuNoise::BMI055.gyro_noise * rate.sqrt();
        assert!(
            (gyro_sd / expected - 1.0).abs() < 0.05,
            "{gyro_sd} vs {expected}"
        );
        let accel_sd = sd(&|s| s.accel.z);
        let expected = ImuNoise::BMI055.accel_noise * rate.sqrt();
        assert!(
            (accel_sd / expected - 1.0).abs() < 0.05,
            "{accel_sd} vs {expected}"
        );
        // After 100 s the gyro bias walked about walk * sqrt(100 s) per axis.
        let walked = imu.bias().gyro.norm() / (ImuNoise::BMI055.gyro_walk * 10.0 * 3f64.sqrt());
        assert!(walked > 0.1 && walked < 3.0, "{walked}");
    }
}
