//! How raw 16-bit depth values become metres.

use serde::{Deserialize, Serialize};

/// `[depth]` table of a config: scale, valid range and kind of the depth sensor.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DepthConfig {
    /// Raw units per metre (5000 for TUM and ICL-NUIM, 1000 for 7-Scenes). Default 5000.
    pub scale: f64,
    /// Closest valid depth in metres; closer values are missing. Default 0.1.
    pub min_m: f32,
    /// Farthest valid depth in metres; farther values are missing. Default 10.
    pub max_m: f32,
    /// How the sensor measures depth, which sets how its noise grows with the depth.
    /// Default structured light (Kinect v1, Xtion).
    pub sensor: DepthSensor,
    /// A stereo sensor's baseline, metres. Default 0.05 (RealSense D435).
    pub baseline_m: f64,
    /// A stereo sensor's disparity matching error, pixels. Default 0.08 (RealSense
    /// D435's subpixel figure).
    pub disparity_sigma_px: f64,
}

/// How a depth sensor measures: its noise follows from it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DepthSensor {
    /// A projected pattern triangulated by an infrared camera (Kinect v1, Xtion).
    #[default]
    StructuredLight,
    /// Time of flight (Kinect v2, Azure Kinect).
    TimeOfFlight,
    /// Two cameras matched (RealSense D4xx, ZED): `baseline_m`, `disparity_sigma_px`.
    Stereo,
}

impl Default for DepthConfig {
    fn default() -> Self {
        Self {
            scale: 5000.0,
            min_m: 0.1,
            max_m: 10.0,
            sensor: DepthSensor::default(),
            baseline_m: 0.05,
            disparity_sigma_px: 0.08,
        }
    }
}

/// Raw value a Kinect-style sensor writes where it saturates; always missing.
const RAW_SATURATED: u16 = u16::MAX;

impl DepthConfig {
    /// Metres for one raw 16-bit value: `raw / scale`, or 0.0 (missing) when the raw value
    /// is 0 or 65535 or the result lies outside `[min_m, max_m]`.
    #[inline]
    pub fn metres(&self, raw: u16) -> f32 {
        if raw == 0 || raw == RAW_SATURATED {
            return 0.0;
        }
        let m = (f64::from(raw) / self.scale) as f32;
        if m >= self.min_m && m <= self.max_m {
            m
        } else {
            0.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn raw_values_become_metres_or_missing() {
        let tum = DepthConfig::default();
        assert_eq!(tum.metres(5000), 1.0);
        assert_eq!(tum.metres(12_500), 2.5);
        assert_eq!(tum.metres(0), 0.0);
        // 0.05 m is closer than min_m = 0.1; 13.1 m is past max_m = 10.
        assert_eq!(tum.metres(250), 0.0);
        assert_eq!(tum.metres(65_535), 0.0);
        let seven_scenes = DepthConfig {
            scale: 1000.0,
            min_m: 0.3,
            max_m: 100.0,
            ..DepthConfig::default()
        };
        assert_eq!(seven_scenes.metres(1500), 1.5);
        // 65535 is the 7-Scenes "no depth" marker even when the range would admit 65.5 m.
        assert_eq!(seven_scenes.metres(65_535), 0.0);
    }
}
