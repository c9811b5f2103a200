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
use crate::motion::RATE_INTERVAL_S;
use gfs_optim::map_eigenvalues;
use gfs_optim::residuals::PosePrior;
use nalgebra::{Isometry3, Matrix3, Matrix6, Point3, Translation3, Vector3};

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

/// The camera centre's velocity (world frame, m/s) as each frame's data placed it. Each
/// step between the last two frames (over the motion model's intervals) moves it with
/// the gain `Q (Q + 2 C / dt^2)^-1`: `C` the last frame's centre covariance from its
/// data alone, `Q = (a dt)^2` per axis what the velocity may change in the interval
/// (`a` = `[tracking.depth] motion_prior_velocity_accel_m_s2`). The velocity's own
/// uncertainty is not carried from frame to frame (a Kalman filter proper): after a
/// wall, the first frame claiming to hold the slide would set it whole, on information
/// the photometric term overstates. Along a direction a frame's data left free (a bare
/// wall's in-plane motion) its error does not go into the velocity and on into every
/// next frame, as in a step taken from the last two poses (rotation seed 1 drifted 4-7
/// mm a frame along one wall); where the data hold the frame, the velocity follows the
/// steps.
#[derive(Clone, Debug, Default)]
pub struct CentreVelocity {
    /// The last frame's centre and timestamp.
    last: Option<(Vector3<f64>, f64)>,
    velocity: Option<Vector3<f64>>,
}

impl CentreVelocity {
    /// Takes in the frame at `camera_from_world`, taken at `timestamp`, whose data gave its
    /// pose `information` (left perturbation; `None` when it was not tracked: the velocity
    /// stays).
    pub fn update(
        &mut self,
        camera_from_world: &Isometry3<f64>,
        timestamp: f64,
        information: Option<&Matrix6<f64>>,
        accel_m_s2: f64,
    ) {
        let centre = camera_from_world.inverse().translation.vector;
        if let (Some((previous, t0)), Some(information)) = (self.last, information)
            && let dt = timestamp - t0
            && RATE_INTERVAL_S.contains(&dt)
        {
            let measured = (centre - previous) / dt;
            self.velocity = Some(match self.velocity {
                None => measured,
                Some(velocity) => {
                    let change = Matrix3::identity() * (accel_m_s2 * dt).powi(2);
                    let noise =
                        centre_covariance(information, camera_from_world) * (2.0 / (dt * dt));
                    match (change + noise).try_inverse() {
                        Some(inverse) => velocity + change * inverse * (measured - velocity),
                        None => velocity,
                    }
                }
            });
        }
        self.last = Some((centre, timestamp));
    }

    /// `predicted` (`camera_from_world`, `dt` seconds after the last frame) with its
    /// centre moved to where the filtered velocity takes the last frame's; `predicted`
    /// itself before a velocity is known.
    pub fn predict(&self, predicted: &Isometry3<f64>, dt: f64) -> Isometry3<f64> {
        let (Some((last, _)), Some(velocity)) = (self.last, self.velocity) else {
            return *predicted;
        };
        let centre = last + velocity * dt;
        let rotation = predicted.rotation;
        Isometry3::from_parts(Translation3::from(-(rotation * centre)), rotation)
    }

    /// Re-expresses the last centre and the velocity in a corrected world
    /// (`new_from_old`, a loop correction).
    pub fn shift_world(&mut self, new_from_old: &Isometry3<f64>) {
        if let Some((centre, _)) = &mut self.last {
            *centre = new_from_old.transform_point(&Point3::from(*centre)).coords;
        }
        if let Some(velocity) = &mut self.velocity {
            *velocity = new_from_old.rotation * *velocity;
        }
    }
}

/// The covariance of the camera centre (world frame) of `camera_from_world` with the
/// pose information `information`; a direction the information does not hold (less
/// than [`MIN_INFORMATION`], or negative where the normals' noise was discounted) is
/// unknown to a kilometre.
fn centre_covariance(
    information: &Matrix6<f64>,
    camera_from_world: &Isometry3<f64>,
) -> Matrix3<f64> {
    let variance = |l: f64| if l > MIN_INFORMATION { 1.0 / l } else { 1e6 };
    let covariance = map_eigenvalues(information, variance);
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

    const DT: f64 = 1.0 / 30.0;
    const ACCEL: f64 = 4.0;

    /// A camera at `centre` looking along world x (its z), turned 90 degrees about y.
    fn pose_at(centre: Vector3<f64>) -> Isometry3<f64> {
        let rotation =
            nalgebra::UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 90f64.to_radians());
        Isometry3::from_parts(Translation3::from(-(rotation * centre)), rotation)
    }

    /// Takes in frame `k` (at `k DT`), its camera at `centre`.
    fn take(
        filter: &mut CentreVelocity,
        k: u32,
        centre: [f64; 3],
        information: Option<&Matrix6<f64>>,
    ) {
        let pose = pose_at(Vector3::from(centre));
        filter.update(&pose, f64::from(k) * DT, information, ACCEL);
    }

    /// Where the filter centres the next frame, one `DT` on.
    fn next_centre(filter: &CentreVelocity) -> Vector3<f64> {
        let predicted = pose_at(Vector3::new(0.5, 0.5, 0.5));
        let next = filter.predict(&predicted, DT);
        assert!(next.rotation.angle_to(&predicted.rotation) < 1e-12);
        next.inverse().translation.vector
    }

    /// Known to a tenth of a millimetre.
    fn known() -> Matrix6<f64> {
        Matrix6::identity() * 1e8
    }

    #[test]
    fn a_frame_free_along_a_direction_leaves_the_velocity_there_as_it_was() {
        let mut filter = CentreVelocity::default();
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

    #[test]
    fn a_step_known_as_well_as_the_velocity_changes_moves_it_halfway() {
        let mut filter = CentreVelocity::default();
        take(&mut filter, 0, [0.0; 3], Some(&known()));
        take(&mut filter, 1, [0.0; 3], Some(&known()));
        // The step's covariance 2 C / DT^2 equal to the change's (ACCEL DT)^2 along x.
        let mut half = known();
        half[(2, 2)] = 2.0 / (ACCEL * DT * DT).powi(2);
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
        let mut filter = CentreVelocity::default();
        take(&mut filter, 0, [0.0; 3], Some(&known()));
        take(&mut filter, 1, [0.01, 0.0, 0.0], Some(&known()));
        let new_from_old = Isometry3::from_parts(
            Translation3::new(1.0, 0.0, 0.0),
            nalgebra::UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 90f64.to_radians()),
        );
        filter.shift_world(&new_from_old);
        // From (1, 0.01, 0) on along world y.
        let next = next_centre(&filter);
        assert!(
            (next - Vector3::new(1.0, 0.02, 0.0)).norm() < 1e-6,
            "{next}"
        );
    }
}
