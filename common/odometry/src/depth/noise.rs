//! A depth sensor's noise as a function of the depth, from the way it measures:
//! triangulation (structured light, stereo) errs in disparity `d = f b / z`, so its depth
//! error grows with `z^2`; a time-of-flight camera errs in phase, so its error grows
//! with `z`. The depth alignment weighs its pairs and the plane terms their offsets with
//! it. Nothing here is fitted to a renderer: the figures are the sensors' own.

/// Standard deviation of one depth measurement, `linear z + quadratic z^2` metres at
/// `z` metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthNoise {
    /// Share of the depth, per pixel (time of flight).
    pub linear: f64,
    /// Metres per square metre of depth (triangulation).
    pub quadratic: f64,
}

impl DepthNoise {
    /// A structured-light sensor like the Kinect v1: `1.425e-3 z^2` m (Khoshelham and
    /// Elberink, Sensors 2012, from its 1/8 px disparity steps and matching error at
    /// 580 px focal length and 7.5 cm baseline).
    pub const STRUCTURED_LIGHT: Self = Self {
        linear: 0.0,
        quadratic: 1.425e-3,
    };

    /// A time-of-flight camera (Kinect v2, Azure Kinect class): 0.2 % of the depth, a
    /// phase error of a few millimetres a metre.
    pub const TIME_OF_FLIGHT: Self = Self {
        linear: 2.0e-3,
        quadratic: 0.0,
    };

    /// A stereo camera of focal length `focal_px` and baseline `baseline_m` matching to
    /// `disparity_sigma_px`: `sigma_z = sigma_d z^2 / (f b)`.
    pub fn stereo(focal_px: f64, baseline_m: f64, disparity_sigma_px: f64) -> Self {
        Self {
            linear: 0.0,
            quadratic: disparity_sigma_px / (focal_px * baseline_m),
        }
    }

    /// Standard deviation of a depth measured at `z` metres, metres.
    pub fn sigma(&self, z: f64) -> f64 {
        z * (self.linear + self.quadratic * z)
    }
}

impl Default for DepthNoise {
    fn default() -> Self {
        Self::STRUCTURED_LIGHT
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangulation_grows_with_the_square_of_the_depth_and_time_of_flight_linearly() {
        let kinect = DepthNoise::STRUCTURED_LIGHT;
        // Khoshelham and Elberink: about 1.4 mm at 1 m, 5.7 mm at 2 m, 3.6 cm at 5 m.
        assert!((kinect.sigma(1.0) - 0.001425).abs() < 1e-9);
        assert!((kinect.sigma(2.0) / kinect.sigma(1.0) - 4.0).abs() < 1e-9);
        assert!((kinect.sigma(5.0) - 0.0356).abs() < 1e-4);
        let tof = DepthNoise::TIME_OF_FLIGHT;
        assert!((tof.sigma(3.0) / tof.sigma(1.0) - 3.0).abs() < 1e-9);
        // A RealSense D435-like stereo pair: 383 px, 5 cm, 0.08 px: 4.2 mm at 1 m.
        let stereo = DepthNoise::stereo(383.0, 0.05, 0.08);
        assert!((stereo.sigma(1.0) - 0.00418).abs() < 1e-5);
        assert!((stereo.sigma(3.0) / stereo.sigma(1.0) - 9.0).abs() < 1e-9);
    }
}
