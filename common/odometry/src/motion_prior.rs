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
use nalgebra::{Isometry3, Matrix3, Matrix6, Translation3};

/// Information below which a direction of the last pose is unknown (a kilometre).
const MIN_INFORMATION: f64 = 1e-6;

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

/// The motion model's prediction `predicted` with its step from the last pose `last`
/// (both `camera_from_world`) shrunk where the last pose's data (`last_information`,
/// left perturbation, the normals' noise discounted) knew its position less well than
/// a step of `step_sigma_m` per axis is known: the step's estimate `S (S + 2 C)^-1 d`
/// (a step is the difference of two poses known about as well). The rotation is the
/// prediction's.
pub fn shrunk_prediction(
    predicted: &Isometry3<f64>,
    last: &Isometry3<f64>,
    last_information: &Matrix6<f64>,
    step_sigma_m: f64,
) -> Isometry3<f64> {
    let centre = |pose: &Isometry3<f64>| pose.inverse().translation.vector;
    let step = centre(predicted) - centre(last);
    let prior = Matrix3::identity() * step_sigma_m.powi(2);
    let Some(gain) = (prior + centre_covariance(last_information, last) * 2.0).try_inverse() else {
        return *predicted;
    };
    let shrunk = centre(last) + prior * gain * step;
    let rotation = predicted.rotation;
    Isometry3::from_parts(Translation3::from(-(rotation * shrunk)), rotation)
}

/// The covariance of the camera centre (world frame) of `camera_from_world` with the
/// pose information `information`; a direction the information does not hold (less
/// than [`MIN_INFORMATION`], or negative where the normals' noise was discounted) is
/// unknown to a kilometre.
fn centre_covariance(
    information: &Matrix6<f64>,
    camera_from_world: &Isometry3<f64>,
) -> Matrix3<f64> {
    let eigen = ((information + information.transpose()) * 0.5).symmetric_eigen();
    let variances = eigen
        .eigenvalues
        .map(|l| if l > MIN_INFORMATION { 1.0 / l } else { 1e6 });
    let covariance =
        eigen.eigenvectors * Matrix6::from_diagonal(&variances) * eigen.eigenvectors.transpose();
    // A left perturbation `rho` of camera_from_world moves the centre by `-R^T rho`.
    let r = camera_from_world.rotation.to_rotation_matrix().into_inner();
    r.transpose() * covariance.fixed_view::<3, 3>(0, 0) * r
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

    #[test]
    fn the_step_is_kept_where_the_last_pose_was_known_and_dropped_where_it_was_not() {
        // The last camera at (1, 0, 0) turned 90 degrees about y (its z along world x);
        // the prediction 1 cm further along each world axis.
        let rotation = nalgebra::UnitQuaternion::from_axis_angle(
            &nalgebra::Vector3::y_axis(),
            90f64.to_radians(),
        );
        let pose_at = |c: nalgebra::Vector3<f64>| {
            Isometry3::from_parts(Translation3::from(-(rotation * c)), rotation)
        };
        let last = pose_at(nalgebra::Vector3::new(1.0, 0.0, 0.0));
        let predicted = pose_at(nalgebra::Vector3::new(1.01, 0.01, 0.01));
        let centre = |pose: &Isometry3<f64>| pose.inverse().translation.vector;
        // Known to a tenth of a millimetre: the step stays.
        let known = Matrix6::identity() * 1e8;
        let kept = shrunk_prediction(&predicted, &last, &known, 0.0167);
        assert!((centre(&kept) - centre(&predicted)).norm() < 1e-5);
        assert!(kept.rotation.angle_to(&predicted.rotation) < 1e-12);
        // Nothing known along the camera's z (world x), as on a wall seen edge-on: that
        // part of the step goes, the rest stays.
        let mut free = known;
        free[(2, 2)] = 0.0;
        let shrunk = centre(&shrunk_prediction(&predicted, &last, &free, 0.0167));
        let expected = nalgebra::Vector3::new(1.0, 0.01, 0.01);
        assert!((shrunk - expected).norm() < 1e-5, "{shrunk}");
        // Known as well as a step is: half of it.
        let mut half = known;
        half[(2, 2)] = 2.0 / 0.0167f64.powi(2);
        let shrunk = centre(&shrunk_prediction(&predicted, &last, &half, 0.0167));
        assert!((shrunk.x - 1.005).abs() < 1e-5, "{shrunk}");
    }
}
