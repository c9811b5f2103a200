//! The motion model's prediction as a prior of the depth and geometry passes: what the
//! data leave weak (a wall's in-plane motion, a turn about its normal) stays near the
//! prediction instead of following their noise.
//!
//! The prediction is off by what an unknown acceleration does in a frame interval,
//! `0.5 a dt^2` per axis (`[tracking.depth] motion_prior_*`). A frame tracked on
//! features has its rotation measured by them (the depth comes in for a weak
//! translation), and hand-held turns change faster than slow pans: its rotational
//! prior is looser (`motion_prior_feature_angular_accel_deg_s2`).

use crate::depth_alignment::DepthAlignmentConfig;
use gfs_optim::residuals::PosePrior;
use nalgebra::Isometry3;

/// What tracked the frame, for the prior's rotational sigma.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PriorFor {
    /// Features, with the depth added for their weak directions.
    Features,
    /// Depth and planes alone.
    Geometry,
}

/// The prior of a frame predicted at `predicted`, `dt` seconds after the last frame;
/// None when a setting is 0 (the prior off).
pub fn motion_prior(
    config: &DepthAlignmentConfig,
    predicted: &Isometry3<f64>,
    dt: f64,
    tracked_on: PriorFor,
) -> Option<PosePrior> {
    let angular_accel_deg_s2 = match tracked_on {
        PriorFor::Features => config.motion_prior_feature_angular_accel_deg_s2,
        PriorFor::Geometry => config.motion_prior_angular_accel_deg_s2,
    };
    let half_dt2 = 0.5 * dt * dt;
    let sigma_m = config.motion_prior_accel_m_s2 * half_dt2;
    let sigma_rad = angular_accel_deg_s2.to_radians() * half_dt2;
    (sigma_m > 0.0 && sigma_rad > 0.0).then(|| PosePrior::isotropic(*predicted, sigma_m, sigma_rad))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sigmas(prior: &PosePrior) -> (f64, f64) {
        (
            prior.information[(0, 0)].powf(-0.5),
            prior.information[(5, 5)].powf(-0.5).to_degrees(),
        )
    }

    #[test]
    fn the_sigmas_are_what_the_accelerations_do_in_a_frame_interval() {
        let config = DepthAlignmentConfig::default();
        let predicted = Isometry3::translation(0.1, 0.0, 1.0);
        let dt = 1.0 / 30.0;
        let geometry = motion_prior(&config, &predicted, dt, PriorFor::Geometry).expect("prior");
        // 12 m/s^2 and 800 deg/s^2 over 1/30 s: 6.7 mm and 0.44 degrees.
        let (t, r) = sigmas(&geometry);
        assert!(
            (t - 0.00667).abs() < 1e-5 && (r - 0.444).abs() < 1e-3,
            "{t} m {r} deg"
        );
        let features = motion_prior(&config, &predicted, dt, PriorFor::Features).expect("prior");
        let (t, r) = sigmas(&features);
        assert!(
            (t - 0.00667).abs() < 1e-5 && (r - 1.778).abs() < 1e-3,
            "{t} m {r} deg"
        );
        // A frame twice as late is predicted four times less surely.
        let late = motion_prior(&config, &predicted, 2.0 * dt, PriorFor::Geometry).expect("prior");
        assert!((sigmas(&late).0 - 4.0 * 0.00667).abs() < 1e-4);
        let off = DepthAlignmentConfig {
            motion_prior_accel_m_s2: 0.0,
            ..config
        };
        assert!(motion_prior(&off, &predicted, dt, PriorFor::Geometry).is_none());
    }
}
