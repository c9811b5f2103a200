//! The motion model's prediction as a prior of the depth and geometry passes: what the
//! data leave weak (a wall's in-plane motion, a turn about its normal) stays near the
//! prediction instead of following their noise.
//!
//! The prediction is off by what an unknown acceleration does in a frame interval,
//! `0.5 a dt^2` per axis (`[tracking.depth] motion_prior_*`). A frame tracked on
//! features has its rotation measured by them (the depth comes in for a weak
//! translation), and hand-held turns change faster than slow pans: its rotational
//! prior is looser (`motion_prior_feature_angular_accel_deg_s2`).

use crate::depth::alignment::DepthAlignmentConfig;
use crate::tracking::motion::{RATE_INTERVAL_S, interval_s};
use gfs_core::stamp::Stamp;
use gfs_optim::map_eigenvalues;
use gfs_optim::residuals::PosePrior;
use nalgebra::{Isometry3, Matrix3, Matrix6, Point3, Translation3, UnitQuaternion, Vector3};

/// Information below which a direction of the last pose is unknown (to a kilometre, a
/// thousand radians).
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

/// The camera's velocity as each frame's data placed it: its centre's (world frame,
/// m/s) and its angular rate (rad/s, the left increment of `camera_from_world`'s
/// rotation, camera frame). Each step between the last two frames (over the motion
/// model's intervals) moves either with the gain `Q (Q + 2 C / dt^2)^-1`: `C` the last
/// frame's covariance (of its centre, of its rotation) from its data alone, `Q = (a
/// dt)^2` per axis what the velocity may change in the interval (`a` = `[tracking.
/// depth] motion_prior_velocity_accel_m_s2`, `motion_prior_angular_rate_accel_deg_s2`).
/// The velocity's own uncertainty is not carried from frame to frame (a Kalman filter
/// proper): after a wall, the first frame claiming to hold the slide would set it whole,
/// on information the photometric term overstates. Along a direction a frame's data
/// left free (a bare wall's in-plane motion, its turn about the optical axis) its error
/// does not go into the velocity and on into every next frame, as in a step taken from
/// the last two poses (rotation seed 1 drifted 4-7 mm a frame along one wall, and later
/// 3-4 mm a frame with 0.15 degrees of roll); where the data hold the frame, the
/// velocity follows the steps.
#[derive(Clone, Debug, Default)]
pub struct FilteredVelocity {
    /// The last frame's centre, rotation (`camera_from_world`'s) and timestamp.
    last: Option<(Vector3<f64>, UnitQuaternion<f64>, Stamp)>,
    centre_velocity: Option<Vector3<f64>>,
    angular_rate: Option<Vector3<f64>>,
}

/// How fast each part of [`FilteredVelocity`] may change.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VelocityChange {
    /// The centre's velocity, m/s^2.
    pub accel_m_s2: f64,
    /// The angular rate, rad/s^2.
    pub angular_accel_rad_s2: f64,
}

impl VelocityChange {
    /// The settings of `[tracking.depth]`.
    pub fn from_config(config: &DepthAlignmentConfig) -> Self {
        Self {
            accel_m_s2: config.motion_prior_velocity_accel_m_s2,
            angular_accel_rad_s2: config.motion_prior_angular_rate_accel_deg_s2.to_radians(),
        }
    }
}

impl FilteredVelocity {
    /// Takes in the frame at `camera_from_world`, taken at `timestamp`, whose data gave its
    /// pose `information` (left perturbation; `None` when it was not tracked: the velocity
    /// stays).
    pub fn update(
        &mut self,
        camera_from_world: &Isometry3<f64>,
        timestamp: Stamp,
        information: Option<&Matrix6<f64>>,
        change: VelocityChange,
    ) {
        let centre = camera_from_world.inverse().translation.vector;
        let rotation = camera_from_world.rotation;
        if let (Some((previous, previous_rotation, t0)), Some(information)) =
            (self.last, information)
            && let dt = interval_s(t0, timestamp)
            && RATE_INTERVAL_S.contains(&dt)
        {
            let covariance = data_covariance(information);
            // A left perturbation `rho` of camera_from_world moves the centre by `-R^T rho`.
            let r = rotation.to_rotation_matrix().into_inner();
            let centre_covariance = r.transpose() * covariance.fixed_view::<3, 3>(0, 0) * r;
            let rotation_covariance = covariance.fixed_view::<3, 3>(3, 3).into_owned();
            self.centre_velocity = Some(filtered(
                self.centre_velocity,
                (centre - previous) / dt,
                change.accel_m_s2 * dt,
                centre_covariance * (2.0 / (dt * dt)),
            ));
            if change.angular_accel_rad_s2 > 0.0 {
                self.angular_rate = Some(filtered(
                    self.angular_rate,
                    (rotation * previous_rotation.inverse()).scaled_axis() / dt,
                    change.angular_accel_rad_s2 * dt,
                    rotation_covariance * (2.0 / (dt * dt)),
                ));
            }
        }
        self.last = Some((centre, rotation, timestamp));
    }

    /// `predicted` (`camera_from_world`, `dt` seconds after the last frame) turned by the
    /// filtered angular rate from the last frame's rotation, and its centre moved to where
    /// the filtered velocity takes the last frame's; each part as `predicted` has it
    /// before its velocity is known.
    pub fn predict(&self, predicted: &Isometry3<f64>, dt: f64) -> Isometry3<f64> {
        let Some((last_centre, last_rotation, _)) = self.last else {
            return *predicted;
        };
        let rotation = self.angular_rate.map_or(predicted.rotation, |rate| {
            UnitQuaternion::from_scaled_axis(rate * dt) * last_rotation
        });
        let centre = self.centre_velocity.map_or_else(
            || predicted.inverse().translation.vector,
            |velocity| last_centre + velocity * dt,
        );
        Isometry3::from_parts(Translation3::from(-(rotation * centre)), rotation)
    }

    /// Re-expresses the last pose and the velocity in a corrected world (`new_from_old`,
    /// a loop correction); the angular rate, in the camera's frame, stays.
    pub fn shift_world(&mut self, new_from_old: &Isometry3<f64>) {
        if let Some((centre, rotation, _)) = &mut self.last {
            *centre = new_from_old.transform_point(&Point3::from(*centre)).coords;
            *rotation *= new_from_old.rotation.inverse();
        }
        if let Some(velocity) = &mut self.centre_velocity {
            *velocity = new_from_old.rotation * *velocity;
        }
    }
}

/// The covariance of a pose whose data gave it `information`: a direction held by less
/// than [`MIN_INFORMATION`] (or by a negative amount, where the normals' noise was
/// discounted) is unknown.
fn data_covariance(information: &Matrix6<f64>) -> Matrix6<f64> {
    map_eigenvalues(
        information,
        |l| {
            if l > MIN_INFORMATION { 1.0 / l } else { 1e6 }
        },
    )
}

/// `velocity` moved towards `measured` with the gain `Q (Q + noise)^-1`, `Q` the
/// isotropic variance `change^2`; `measured` itself when there was no velocity.
fn filtered(
    velocity: Option<Vector3<f64>>,
    measured: Vector3<f64>,
    change: f64,
    noise: Matrix3<f64>,
) -> Vector3<f64> {
    let Some(velocity) = velocity else {
        return measured;
    };
    let q = Matrix3::identity() * change * change;
    match (q + noise).try_inverse() {
        Some(inverse) => velocity + q * inverse * (measured - velocity),
        None => velocity,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(seconds: f64) -> Stamp {
        Stamp::from_secs(seconds).unwrap()
    }

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

    const DT: f64 = 1.0 / 30.0;
    const CHANGE: VelocityChange = VelocityChange {
        accel_m_s2: 4.0,
        angular_accel_rad_s2: 2.0,
    };

    /// A camera at `centre` looking along world x (its z), turned 90 degrees about y.
    fn pose_at(centre: Vector3<f64>) -> Isometry3<f64> {
        let rotation =
            nalgebra::UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 90f64.to_radians());
        Isometry3::from_parts(Translation3::from(-(rotation * centre)), rotation)
    }

    /// Takes in frame `k` (at `k DT`), its camera at `centre`.
    fn take(
        filter: &mut FilteredVelocity,
        k: u32,
        centre: [f64; 3],
        information: Option<&Matrix6<f64>>,
    ) {
        let pose = pose_at(Vector3::from(centre));
        filter.update(&pose, at(f64::from(k) * DT), information, CHANGE);
    }

    /// Where the filter centres the next frame, one `DT` on, and how it turns it.
    fn next_pose(filter: &FilteredVelocity) -> (Vector3<f64>, UnitQuaternion<f64>) {
        let next = filter.predict(&pose_at(Vector3::new(0.5, 0.5, 0.5)), DT);
        (next.inverse().translation.vector, next.rotation)
    }

    /// Where the filter centres the next frame of a camera that does not turn.
    fn next_centre(filter: &FilteredVelocity) -> Vector3<f64> {
        let (centre, rotation) = next_pose(filter);
        assert!(rotation.angle_to(&pose_at(Vector3::zeros()).rotation) < 1e-12);
        centre
    }

    /// Known to a tenth of a millimetre.
    fn known() -> Matrix6<f64> {
        Matrix6::identity() * 1e8
    }

    #[test]
    fn a_frame_free_along_a_direction_leaves_the_velocity_there_as_it_was() {
        let mut filter = FilteredVelocity::default();
        // 0.3 m/s along each world axis for three frames.
        for k in 0..3 {
            take(&mut filter, k, [0.01 * f64::from(k); 3], Some(&known()));
        }
        assert!((next_centre(&filter) - Vector3::repeat(0.03)).norm() < 1e-5);
        // The next frame slid 2 cm along the camera's z (world x), which its data left
        // free: the velocity there stays; it is followed along the others.
        let mut free = known();
        free[(2, 2)] = 0.0;
        take(&mut filter, 3, [0.05, 0.03, 0.03], Some(&free));
        let next = next_centre(&filter);
        assert!(
            (next - Vector3::new(0.06, 0.04, 0.04)).norm() < 1e-5,
            "{next}"
        );
        // A frame not tracked (no information) keeps the velocity too.
        take(&mut filter, 4, [0.06, 0.04, 0.04], None);
        let next = next_centre(&filter);
        assert!(
            (next - Vector3::new(0.07, 0.05, 0.05)).norm() < 1e-5,
            "{next}"
        );
    }

    /// The camera at the origin, rolled `degrees` about its optical axis.
    fn rolled(degrees: f64) -> Isometry3<f64> {
        Isometry3::rotation(Vector3::z() * degrees.to_radians())
    }

    /// The roll, degrees, at which the filter turns the next frame, one `DT` on.
    fn next_roll(filter: &FilteredVelocity) -> f64 {
        let next = filter.predict(&Isometry3::identity(), DT);
        next.rotation.scaled_axis().z.to_degrees()
    }

    #[test]
    fn a_roll_the_data_leave_free_does_not_turn_the_next_frames() {
        let mut filter = FilteredVelocity::default();
        // 30 degrees/s of roll, a degree a frame, well known.
        for k in 0..3 {
            filter.update(
                &rolled(f64::from(k)),
                at(f64::from(k) * DT),
                Some(&known()),
                CHANGE,
            );
        }
        // 1e-6: the stamps are `DT` to the nanosecond (a relative 1e-8).
        assert!((next_roll(&filter) - 3.0).abs() < 1e-6);
        // A frame rolled half a degree more, along a roll its data leave free: its roll
        // stays, the rate does not take it.
        let mut free = known();
        free[(5, 5)] = 0.0;
        filter.update(&rolled(3.5), at(3.0 * DT), Some(&free), CHANGE);
        assert!(
            (next_roll(&filter) - 4.5).abs() < 0.01,
            "{}",
            next_roll(&filter)
        );
        // A well-known frame is followed: its step of half a degree is the rate (to a
        // gain of 0.996 against what the rate may change in a frame).
        filter.update(&rolled(4.0), at(4.0 * DT), Some(&known()), CHANGE);
        assert!(
            (next_roll(&filter) - 4.502).abs() < 1e-3,
            "{}",
            next_roll(&filter)
        );
        // Off (0), the prior turns as the motion model predicts.
        let mut off = FilteredVelocity::default();
        let motion_model = VelocityChange {
            angular_accel_rad_s2: 0.0,
            ..CHANGE
        };
        for k in 0..3 {
            off.update(
                &rolled(f64::from(k)),
                at(f64::from(k) * DT),
                Some(&known()),
                motion_model,
            );
        }
        assert!(next_roll(&off).abs() < 1e-12);
    }

    #[test]
    fn a_step_known_as_well_as_the_velocity_changes_moves_it_halfway() {
        let mut filter = FilteredVelocity::default();
        take(&mut filter, 0, [0.0; 3], Some(&known()));
        take(&mut filter, 1, [0.0; 3], Some(&known()));
        // The step's covariance 2 C / DT^2 equal to the change's (a DT)^2 along x.
        let mut half = known();
        half[(2, 2)] = 2.0 / (CHANGE.accel_m_s2 * DT * DT).powi(2);
        take(&mut filter, 2, [0.01, 0.0, 0.0], Some(&half));
        // Velocity 0.15 m/s along x: 5 mm further.
        let next = next_centre(&filter);
        assert!(
            (next - Vector3::new(0.015, 0.0, 0.0)).norm() < 1e-6,
            "{next}"
        );
    }

    #[test]
    fn a_loop_correction_moves_the_centre_and_turns_the_velocity() {
        let mut filter = FilteredVelocity::default();
        take(&mut filter, 0, [0.0; 3], Some(&known()));
        take(&mut filter, 1, [0.01, 0.0, 0.0], Some(&known()));
        let new_from_old = Isometry3::from_parts(
            Translation3::new(1.0, 0.0, 0.0),
            nalgebra::UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 90f64.to_radians()),
        );
        filter.shift_world(&new_from_old);
        // From (1, 0.01, 0) on along world y, the camera turned with the world.
        let (next, rotation) = next_pose(&filter);
        assert!(
            (next - Vector3::new(1.0, 0.02, 0.0)).norm() < 1e-6,
            "{next}"
        );
        let corrected = pose_at(Vector3::zeros()).rotation * new_from_old.rotation.inverse();
        assert!(rotation.angle_to(&corrected) < 1e-12);
    }
}
