//! `[imu]`: where the IMU sits in the camera, how noisy it is, and its clock.

use crate::noise::ImuNoise;
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};
use serde::Deserialize;

/// The `[imu]` table.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ImuConfig {
    /// The IMU's pose in the colour camera's optical frame, `[x, y, z, qx, qy, qz, qw]`
    /// (metres, unit quaternion). Default the identity: IMU axes = camera axes.
    pub camera_from_imu: [f64; 7],
    /// Gyroscope white noise density, rad/s/sqrt(Hz). Default BMI055.
    pub gyro_noise: f64,
    /// Accelerometer white noise density, m/s^2/sqrt(Hz). Default BMI055.
    pub accel_noise: f64,
    /// Gyroscope bias random walk, rad/s^2/sqrt(Hz).
    pub gyro_walk: f64,
    /// Accelerometer bias random walk, m/s^3/sqrt(Hz).
    pub accel_walk: f64,
    /// Added to the IMU's stamps to put them on the camera's clock, seconds.
    pub time_offset_s: f64,
    /// The longest stretch without samples the preintegration bridges, seconds; a
    /// longer gap leaves the interval to the visual odometry alone.
    pub max_gap_s: f64,
}

impl Default for ImuConfig {
    fn default() -> Self {
        let noise = ImuNoise::default();
        Self {
            camera_from_imu: [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0],
            gyro_noise: noise.gyro_noise,
            accel_noise: noise.accel_noise,
            gyro_walk: noise.gyro_walk,
            accel_walk: noise.accel_walk,
            time_offset_s: 0.0,
            max_gap_s: 0.05,
        }
    }
}

/// Largest clock offset accepted, seconds: more is a wrong unit, not an offset.
const MAX_TIME_OFFSET_S: f64 = 1.0;

impl ImuConfig {
    /// The noise figures.
    pub fn noise(&self) -> ImuNoise {
        ImuNoise {
            gyro_noise: self.gyro_noise,
            accel_noise: self.accel_noise,
            gyro_walk: self.gyro_walk,
            accel_walk: self.accel_walk,
        }
    }

    /// The IMU's pose in the camera (the quaternion normalised).
    pub fn camera_from_imu(&self) -> Isometry3<f64> {
        let [x, y, z, qx, qy, qz, qw] = self.camera_from_imu;
        Isometry3::from_parts(
            Translation3::new(x, y, z),
            UnitQuaternion::from_quaternion(Quaternion::new(qw, qx, qy, qz)),
        )
    }

    /// The first field that is wrong, with why: `imu.FIELD: reason`.
    pub fn validate(&self) -> Result<(), String> {
        if let Some(field) = self.noise().invalid_field() {
            return Err(format!("imu.{field}: must be a finite number above 0"));
        }
        let pose = self.camera_from_imu;
        if pose.iter().any(|v| !v.is_finite()) {
            return Err("imu.camera_from_imu: every value must be finite".to_owned());
        }
        let norm = pose[3..].iter().map(|v| v * v).sum::<f64>().sqrt();
        if (norm - 1.0).abs() > 1e-3 {
            return Err(format!(
                "imu.camera_from_imu: the quaternion [qx, qy, qz, qw] has length {norm:.6}, 1 expected"
            ));
        }
        if pose[..3].iter().any(|v| v.abs() > 1.0) {
            return Err("imu.camera_from_imu: the IMU is more than 1 m from the camera".to_owned());
        }
        if !self.time_offset_s.is_finite() || self.time_offset_s.abs() > MAX_TIME_OFFSET_S {
            return Err(format!(
                "imu.time_offset_s: {} s is not within +-{MAX_TIME_OFFSET_S} s",
                self.time_offset_s
            ));
        }
        if !(self.max_gap_s > 0.0 && self.max_gap_s <= 1.0) {
            return Err(format!(
                "imu.max_gap_s: {} is not in (0, 1] s",
                self.max_gap_s
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_is_an_identity_mount_of_a_bmi055_and_errors_name_the_field() {
        let config = ImuConfig::default();
        assert_eq!(config.validate(), Ok(()));
        assert_eq!(config.camera_from_imu(), Isometry3::identity());
        let skewed = ImuConfig {
            camera_from_imu: [0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5],
            ..ImuConfig::default()
        };
        let error = skewed.validate().expect_err("not a unit quaternion");
        assert!(error.starts_with("imu.camera_from_imu:"), "{error}");
        let late = ImuConfig {
            time_offset_s: 5.0,
            ..ImuConfig::default()
        };
        assert!(
            late.validate()
                .expect_err("too late")
                .starts_with("imu.time_offset_s")
        );
        let silent = ImuConfig {
            gyro_noise: 0.0,
            ..ImuConfig::default()
        };
        assert!(
            silent
                .validate()
                .expect_err("zero")
                .starts_with("imu.gyro_noise")
        );
    }

    #[test]
    fn a_table_reads_into_the_mount_and_unknown_keys_are_refused() {
        let config: ImuConfig = toml::from_str(
            "camera_from_imu = [0.02, 0.005, -0.01, 0.0, 0.0, 0.7071067811865476, 0.7071067811865476]\n\
             time_offset_s = -0.004\n",
        )
        .expect("parses");
        let pose = config.camera_from_imu();
        assert!((pose.translation.vector.x - 0.02).abs() < 1e-12);
        assert!((pose.rotation.angle().to_degrees() - 90.0).abs() < 1e-9);
        assert_eq!(config.time_offset_s, -0.004);
        assert_eq!(config.noise(), ImuNoise::BMI055);
        let typo = toml::from_str::<ImuConfig>("gyro_nosie = 1e-4\n");
        assert!(
            typo.expect_err("unknown key")
                .to_string()
                .contains("gyro_nosie")
        );
    }
}
