//! The IMU's noise: white noise densities and bias random walks.
//!
//! Continuous-time figures, as datasheets and calibration tools (Kalibr, allan
//! variance) give them; a sample over `dt` has a white noise of `density / sqrt(dt)`
//! and a bias that walks by `walk * sqrt(dt)`.

use serde::{Deserialize, Serialize};

/// Noise densities and bias random walks of a gyroscope and an accelerometer.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ImuNoise {
    /// Gyroscope white noise density, rad/s/sqrt(Hz).
    pub gyro_noise: f64,
    /// Accelerometer white noise density, m/s^2/sqrt(Hz).
    pub accel_noise: f64,
    /// Gyroscope bias random walk, rad/s^2/sqrt(Hz).
    pub gyro_walk: f64,
    /// Accelerometer bias random walk, m/s^3/sqrt(Hz).
    pub accel_walk: f64,
}

impl ImuNoise {
    /// Bosch BMI055 (RealSense D435i, D455): gyroscope 0.014 deg/s/sqrt(Hz),
    /// accelerometer 150 ug/sqrt(Hz) (datasheet BST-BMI055-DS000, typical). The bias
    /// walks are not in the datasheet; these are the usual allan-variance figures of
    /// consumer MEMS parts, rounded up: 2e-5 rad/s^2/sqrt(Hz), 3e-4 m/s^3/sqrt(Hz).
    pub const BMI055: ImuNoise = ImuNoise {
        gyro_noise: 0.014 * std::f64::consts::PI / 180.0,
        accel_noise: 150e-6 * crate::GRAVITY,
        gyro_walk: 2e-5,
        accel_walk: 3e-4,
    };

    /// Bosch BMI085 (RealSense D455 later revisions, Orbbec): gyroscope
    /// 0.014 deg/s/sqrt(Hz), accelerometer 120 ug/sqrt(Hz) (datasheet
    /// BST-BMI085-DS001, typical); bias walks as [`ImuNoise::BMI055`].
    pub const BMI085: ImuNoise = ImuNoise {
        gyro_noise: 0.014 * std::f64::consts::PI / 180.0,
        accel_noise: 120e-6 * crate::GRAVITY,
        gyro_walk: 2e-5,
        accel_walk: 3e-4,
    };

    /// The first field that is not a finite positive number, by name.
    pub fn invalid_field(&self) -> Option<&'static str> {
        [
            ("gyro_noise", self.gyro_noise),
            ("accel_noise", self.accel_noise),
            ("gyro_walk", self.gyro_walk),
            ("accel_walk", self.accel_walk),
        ]
        .into_iter()
        .find(|(_, v)| !(v.is_finite() && *v > 0.0))
        .map(|(name, _)| name)
    }
}

impl Default for ImuNoise {
    /// The cameras' most common part, [`ImuNoise::BMI055`].
    fn default() -> Self {
        ImuNoise::BMI055
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_is_the_bmi055_and_every_field_is_checked() {
        let noise = ImuNoise::default();
        assert_eq!(noise, ImuNoise::BMI055);
        assert!(noise.invalid_field().is_none());
        // 0.014 deg/s/sqrt(Hz) is 2.44e-4 rad/s/sqrt(Hz).
        assert!((noise.gyro_noise - 2.443e-4).abs() < 1e-6);
        let bad = ImuNoise {
            accel_walk: f64::NAN,
            ..noise
        };
        assert_eq!(bad.invalid_field(), Some("accel_walk"));
        let negative = ImuNoise {
            gyro_noise: -1.0,
            ..noise
        };
        assert_eq!(negative.invalid_field(), Some("gyro_noise"));
    }
}
