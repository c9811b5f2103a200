//! The camera's IMU (`gfsvo synth --imu`): a consumer MEMS part riding the exact
//! trajectory, mounted off the colour camera's optical centre and turned from its axes
//! as in a real camera body, with white noise and walking biases, written as `imu.txt`
//! (`# timestamp gx gy gz ax ay az`, rad/s and m/s^2 in the IMU's axes) with its
//! `[imu]` table in `synthetic.toml`.

use crate::sequence::SynthSequence;
use gfs_core::rng::SplitMix64;
use gfs_core::stamp::Stamp;
use gfs_inertial::simulate::Simulator;
use gfs_inertial::{Bias, ImuNoise, ImuSample};
use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};
use std::fmt::Write;

/// Seconds of IMU data before the first frame and after the last, so the first and
/// last intervals are covered whatever the rate.
const MARGIN_S: f64 = 0.1;
/// Standard deviation of the initial biases drawn per axis: what stays of a consumer
/// part's zero offsets after the factory calibration (BMI055: up to 1 deg/s and
/// 70 mg uncalibrated), rad/s and m/s^2.
const GYRO_BIAS_SD: f64 = 0.005;
const ACCEL_BIAS_SD: f64 = 0.05;

/// The IMU of a synthetic sequence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SynthImu {
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// The part's noise.
    pub noise: ImuNoise,
    /// The IMU's pose in the colour camera's optical frame.
    pub camera_from_imu: Isometry3<f64>,
}

impl SynthImu {
    /// A RealSense-D435i-like IMU at `rate_hz`: the BMI055, about 2 cm beside the
    /// colour camera, its axes forward-left-up (the camera's are right-down-forward),
    /// mounted half a degree off.
    pub fn realsense_like(rate_hz: f64) -> Self {
        let axes = Matrix3::new(0.0, -1.0, 0.0, 0.0, 0.0, -1.0, 1.0, 0.0, 0.0);
        let mounting = UnitQuaternion::from_euler_angles(0.005, -0.004, 0.006);
        let rotation =
            UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(axes));
        Self {
            rate_hz,
            noise: ImuNoise::BMI055,
            camera_from_imu: Isometry3::from_parts(
                Translation3::new(0.0203, 0.0051, -0.0112),
                rotation * mounting,
            ),
        }
    }
}

impl SynthSequence {
    /// The IMU's samples from `MARGIN_S` before the first frame to as long after the
    /// last, and its true biases at the first sample; `None` without an IMU.
    pub fn imu_samples(&self) -> Option<(Vec<ImuSample>, Bias)> {
        let imu = self.config().imu?;
        let seed = self.config().seed;
        let mut rng = SplitMix64::keyed(seed, &[0x0000_6269_6173]);
        let mut draw = |sd: f64| Vector3::new(rng.gaussian(), rng.gaussian(), rng.gaussian()) * sd;
        let bias = Bias {
            gyro: draw(GYRO_BIAS_SD),
            accel: draw(ACCEL_BIAS_SD),
        };
        let extrinsic = imu.camera_from_imu;
        let pose = |t: f64| {
            let world_from_imu = self.pose_at(t) * extrinsic;
            (
                world_from_imu.rotation.to_rotation_matrix().into_inner(),
                world_from_imu.translation.vector,
            )
        };
        let duration = self.len().saturating_sub(1) as f64 / self.config().rate_hz;
        let epoch = Stamp::from_secs(self.config().start_time).unwrap_or_default();
        let samples = Simulator::new(imu.noise, bias, seed).run(
            &pose,
            (-MARGIN_S, duration + MARGIN_S),
            imu.rate_hz,
            epoch,
        );
        Some((samples, bias))
    }

    /// `imu.txt` and the `[imu]` table of `synthetic.toml`; `None` without an IMU.
    pub(crate) fn imu_texts(&self) -> Option<(String, String)> {
        let imu = self.config().imu?;
        let (samples, bias) = self.imu_samples()?;
        let mut list = format!(
            "# IMU of a synthetic sequence: {} Hz, BMI055-like noise, true initial bias gyro {:.6} {:.6} {:.6} rad/s, accel {:.5} {:.5} {:.5} m/s^2\n# timestamp gx gy gz ax ay az\n",
            imu.rate_hz,
            bias.gyro.x,
            bias.gyro.y,
            bias.gyro.z,
            bias.accel.x,
            bias.accel.y,
            bias.accel.z
        );
        for s in &samples {
            // Writing to a String cannot fail.
            let _ = writeln!(
                list,
                "{} {:.9} {:.9} {:.9} {:.9} {:.9} {:.9}",
                s.stamp, s.gyro.x, s.gyro.y, s.gyro.z, s.accel.x, s.accel.y, s.accel.z
            );
        }
        let t = imu.camera_from_imu.translation.vector;
        let q = imu.camera_from_imu.rotation.coords;
        let n = imu.noise;
        let table = format!(
            "\n# The IMU's pose in the colour camera's optical frame, its noise (BMI055).\n\
             [imu]\ncamera_from_imu = [{:?}, {:?}, {:?}, {:?}, {:?}, {:?}, {:?}]\n\
             gyro_noise = {:?}\naccel_noise = {:?}\ngyro_walk = {:?}\naccel_walk = {:?}\n",
            t.x,
            t.y,
            t.z,
            q.x,
            q.y,
            q.z,
            q.w,
            n.gyro_noise,
            n.accel_noise,
            n.gyro_walk,
            n.accel_walk
        );
        Some((list, table))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sequence::SynthConfig;
    use crate::trajectory::TrajectoryKind;
    use gfs_inertial::preintegration::Preintegrated;
    use gfs_inertial::residual::State;
    use gfs_inertial::simulate::world_gravity;

    #[test]
    fn the_imu_integrates_to_the_camera_trajectory_through_the_extrinsic() {
        // Fast hand-held motion: integrating the IMU over a frame interval from the
        // true state gives the next frame's true camera pose within the noise.
        let imu = SynthImu::realsense_like(200.0);
        let sequence = SynthSequence::new(SynthConfig {
            trajectory: TrajectoryKind::Fast,
            frames: 31,
            imu: Some(imu),
            ..SynthConfig::default()
        });
        let (samples, bias) = sequence.imu_samples().expect("an IMU");
        // [-0.1 s, 1.1 s) at 200 Hz.
        assert_eq!(samples.len(), 240);
        let extrinsic = imu.camera_from_imu;
        let state = |i: usize| {
            let t = i as f64 / 30.0;
            let pose = |t: f64| sequence.pose_at(t) * extrinsic;
            let h = 1e-5;
            State {
                rotation: pose(t).rotation.to_rotation_matrix().into_inner(),
                position: pose(t).translation.vector,
                velocity: (pose(t + h).translation.vector - pose(t - h).translation.vector)
                    / (2.0 * h),
                bias,
            }
        };
        let stamp = |i: usize| sequence.timestamp(i);
        let mut worst = (0.0f64, 0.0f64);
        for i in 0..30 {
            let pre =
                Preintegrated::between(&samples, stamp(i), stamp(i + 1), bias, imu.noise, 0.02)
                    .expect("covered");
            let predicted = state(i).predicted(&pre, &world_gravity());
            let truth = state(i + 1);
            let camera = |s: &State| {
                Isometry3::from_parts(
                    Translation3::from(s.position),
                    gfs_core::se3::rotation_from_matrix(&s.rotation),
                ) * extrinsic.inverse()
            };
            let error = camera(&truth).inverse() * camera(&predicted);
            worst.0 = worst.0.max(error.translation.vector.norm());
            worst.1 = worst.1.max(error.rotation.angle().to_degrees());
        }
        // Over 33 ms: white noise ~1e-5 m and 0.001 deg; the bias walk is negligible.
        assert!(
            worst.0 < 2e-4,
            "camera position off by {} m after one frame",
            worst.0
        );
        assert!(
            worst.1 < 0.01,
            "camera rotation off by {} deg after one frame",
            worst.1
        );
    }

    #[test]
    fn the_imu_is_written_beside_the_frames_with_its_table() {
        let sequence = SynthSequence::new(SynthConfig {
            frames: 3,
            imu: Some(SynthImu::realsense_like(400.0)),
            ..SynthConfig::default()
        });
        let (list, table) = sequence.imu_texts().expect("an IMU");
        let lines: Vec<&str> = list.lines().filter(|l| !l.starts_with('#')).collect();
        // 2/30 s of frames plus 0.1 s each side at 400 Hz.
        assert_eq!(lines.len(), 107);
        assert!(lines[0].starts_with("999.900000 "), "{}", lines[0]);
        assert_eq!(lines[0].split_whitespace().count(), 7);
        assert!(
            table.contains("[imu]\ncamera_from_imu = [0.0203, 0.0051, -0.0112,"),
            "{table}"
        );
        let without = SynthSequence::new(SynthConfig {
            frames: 3,
            ..SynthConfig::default()
        });
        assert!(without.imu_texts().is_none());
    }
}
