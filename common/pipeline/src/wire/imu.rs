//! The `imu` topic's payload: one IMU sample, on the camera's clock.

use gfs_core::stamp::Stamp;
use gfs_inertial::ImuSample;
use gfs_ipc::ZeroCopySend;
use nalgebra::Vector3;

/// One IMU sample (`imu` topic: a frame's batch, a slice of these).
#[derive(Clone, Copy, Debug, Default, PartialEq, ZeroCopySend)]
#[type_name("gfsvo::WireImuSample")]
#[repr(C)]
pub struct WireImuSample {
    /// Capture stamp on the camera's clock, nanoseconds.
    pub stamp_ns: i64,
    /// Angular velocity, rad/s.
    pub gyro: [f64; 3],
    /// Specific force, m/s^2.
    pub accel: [f64; 3],
}

impl From<&ImuSample> for WireImuSample {
    fn from(s: &ImuSample) -> Self {
        Self {
            stamp_ns: s.stamp.nanos(),
            gyro: s.gyro.into(),
            accel: s.accel.into(),
        }
    }
}

impl WireImuSample {
    /// The sample.
    pub fn sample(&self) -> ImuSample {
        ImuSample {
            stamp: Stamp::from_nanos(self.stamp_ns),
            gyro: Vector3::from(self.gyro),
            accel: Vector3::from(self.accel),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sample_crosses_the_wire_bit_for_bit() {
        let sample = ImuSample {
            stamp: Stamp::from_nanos(1_305_031_102_175_304_001),
            gyro: Vector3::new(0.1, -0.25, 3.0e-7),
            accel: Vector3::new(-0.003, 9.80665, 0.125),
        };
        assert_eq!(WireImuSample::from(&sample).sample(), sample);
    }
}
