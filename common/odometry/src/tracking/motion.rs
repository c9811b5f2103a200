//! Constant-velocity motion model: the pose prediction every tracking step starts from.

use gfs_core::se3;
use gfs_core::stamp::Stamp;
use nalgebra::{Isometry3, Vector3};

/// Predicts `camera_from_world` of the next frame from the last two.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct MotionModel {
    last: Option<Isometry3<f64>>,
    last_timestamp: Option<Stamp>,
    /// `current_from_previous` of the last tracked step.
    velocity: Option<Isometry3<f64>>,
    /// Time the velocity's step took, seconds.
    velocity_interval_s: Option<f64>,
}

/// Frame intervals outside this range (seconds) do not give an angular rate: equal or
/// reversed timestamps, or a gap after which the last motion means little.
pub(crate) const RATE_INTERVAL_S: std::ops::RangeInclusive<f64> = 1e-4..=1.0;
/// Most velocity steps a prediction extrapolates over.
const MAX_STEPS: f64 = 4.0;

/// Seconds from `earlier` to `later` as the difference of their [`Stamp::secs`]: the
/// intervals the model was tuned with. The exact difference ([`Stamp::secs_since`])
/// differs by up to 1e-7 s at today's epoch, and a run's trajectory follows such a
/// change chaotically (15 mm at most on TUM fr1_rpy).
pub(crate) fn interval_s(earlier: Stamp, later: Stamp) -> f64 {
    later.secs() - earlier.secs()
}

impl MotionModel {
    /// Records the pose (`camera_from_world`) of the frame just processed, taken at
    /// `timestamp`. When the frame was not tracked, `tracked = false` keeps the
    /// velocity but forgets nothing else, so that a short outage continues on the same
    /// motion.
    pub fn update(&mut self, camera_from_world: &Isometry3<f64>, timestamp: Stamp, tracked: bool) {
        // Renormalised at every step: `inverse` conjugates the quaternion, which is exact
        // only for unit ones, so a rounding error in the norm would otherwise compound
        // from frame to frame through the velocity (roughly x2.4 per frame).
        let mut current = *camera_from_world;
        current.rotation.renormalize();
        if tracked && let Some(last) = &self.last {
            let mut velocity = current * last.inverse();
            velocity.rotation.renormalize();
            self.velocity = Some(velocity);
            self.velocity_interval_s = self.last_timestamp.map(|t| interval_s(t, timestamp));
        }
        self.last = Some(current);
        self.last_timestamp = Some(timestamp);
    }

    /// The camera's angular velocity, rad/s, as a rotation vector in the current camera
    /// frame: the velocity's rotation over the time its step took.
    pub fn angular_velocity(&self) -> Option<Vector3<f64>> {
        let interval = self
            .velocity_interval_s
            .filter(|dt| RATE_INTERVAL_S.contains(dt))?;
        Some(self.velocity?.rotation.scaled_axis() / interval)
    }

    /// The predicted `camera_from_world` of the next frame (the last pose when no
    /// velocity is known yet), or `None` before the first frame.
    pub fn predict(&self) -> Option<Isometry3<f64>> {
        let last = self.last?;
        let mut predicted = match &self.velocity {
            Some(v) => v * last,
            None => last,
        };
        predicted.rotation.renormalize();
        Some(predicted)
    }

    /// The predicted `camera_from_world` of a frame taken at `timestamp`: the velocity
    /// is taken per second, so a frame that comes late (the pipeline dropped the ones
    /// before it, or the camera skipped) is predicted that much further. Without
    /// timestamps to go by, as [`Self::predict`].
    pub fn predict_at(&self, timestamp: Stamp) -> Option<Isometry3<f64>> {
        let last = self.last?;
        let (Some(velocity), Some(t0), Some(interval)) =
            (self.velocity, self.last_timestamp, self.velocity_interval_s)
        else {
            return self.predict();
        };
        let dt = interval_s(t0, timestamp);
        if !RATE_INTERVAL_S.contains(&interval) || !RATE_INTERVAL_S.contains(&dt) {
            return self.predict();
        }
        let steps = (dt / interval).min(MAX_STEPS);
        let mut predicted = se3::exp(&(se3::log(&velocity) * steps)) * last;
        predicted.rotation.renormalize();
        Some(predicted)
    }

    /// Seconds from the last frame to `timestamp`, when a velocity is known and that
    /// interval is one a prediction is made over (not equal or reversed timestamps, not
    /// a gap of over a second).
    pub fn interval_to(&self, timestamp: Stamp) -> Option<f64> {
        self.velocity?;
        let dt = interval_s(self.last_timestamp?, timestamp);
        RATE_INTERVAL_S.contains(&dt).then_some(dt)
    }

    /// The velocity (`current_from_previous`), if known.
    pub fn velocity(&self) -> Option<&Isometry3<f64>> {
        self.velocity.as_ref()
    }

    /// Re-expresses the last pose in a corrected world (`new_from_old`, a loop
    /// correction); the velocity is relative to the camera and stays.
    pub fn shift_world(&mut self, new_from_old: &Isometry3<f64>) {
        if let Some(last) = &mut self.last {
            *last *= new_from_old.inverse();
            last.rotation.renormalize();
        }
    }

    /// Forgets the velocity (after a relocalisation the last motion means nothing).
    pub fn reset_velocity(&mut self) {
        self.velocity = None;
        self.velocity_interval_s = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(seconds: f64) -> Stamp {
        Stamp::from_secs(seconds).unwrap()
    }
    use nalgebra::{Translation3, UnitQuaternion};

    #[test]
    fn constant_motion_is_extrapolated() {
        let step = Isometry3::from_parts(
            Translation3::new(0.01, 0.0, 0.02),
            UnitQuaternion::from_euler_angles(0.0, 0.01, 0.0),
        );
        let mut m = MotionModel::default();
        let mut pose = Isometry3::identity();
        m.update(&pose, at(0.0), true);
        pose = step * pose;
        m.update(&pose, at(0.0), true);
        let predicted = m.predict().unwrap();
        let truth = step * pose;
        assert!((predicted.translation.vector - truth.translation.vector).norm() < 1e-12);
        assert!(predicted.rotation.angle_to(&truth.rotation) < 1e-12);
    }

    #[test]
    fn angular_velocity_is_the_step_rotation_over_its_interval() {
        let step = Isometry3::from_parts(
            Translation3::new(0.01, 0.0, 0.0),
            UnitQuaternion::from_euler_angles(0.0, 0.01, 0.0),
        );
        let mut m = MotionModel::default();
        m.update(&Isometry3::identity(), at(10.0), true);
        assert!(m.angular_velocity().is_none());
        m.update(&step, at(10.04), true);
        let w = m.angular_velocity().expect("two frames 40 ms apart");
        assert!(
            (w - nalgebra::Vector3::new(0.0, 0.25, 0.0)).norm() < 1e-9,
            "{w}"
        );
        // Equal timestamps say nothing about the rate.
        m.update(&(step * step), at(10.04), true);
        assert!(m.angular_velocity().is_none());
    }

    #[test]
    fn a_late_frame_is_predicted_further_along_the_same_motion() {
        let step = Isometry3::from_parts(
            Translation3::new(0.01, 0.0, 0.02),
            UnitQuaternion::from_euler_angles(0.0, 0.02, 0.0),
        );
        let mut m = MotionModel::default();
        m.update(&Isometry3::identity(), at(1.0), true);
        m.update(&step, at(1.04), true);
        // The next frame on time: one step; two frames dropped: three steps.
        let on_time = m.predict_at(at(1.08)).expect("velocity");
        assert!((on_time.translation.vector - (step * step).translation.vector).norm() < 1e-9);
        let late = m.predict_at(at(1.16)).expect("velocity");
        let truth = step * step * step * step;
        assert!((late.translation.vector - truth.translation.vector).norm() < 1e-9);
        assert!(late.rotation.angle_to(&truth.rotation) < 1e-9);
        // A timestamp that goes backwards or jumps by seconds falls back to one step.
        let fallback = m.predict().expect("velocity");
        for t in [1.0, 9.0] {
            let p = m.predict_at(at(t)).expect("velocity");
            assert!((p.translation.vector - fallback.translation.vector).norm() < 1e-15);
        }
    }

    #[test]
    fn a_rounding_error_in_the_rotation_norm_does_not_compound() {
        let step = Isometry3::from_parts(
            Translation3::new(0.01, 0.0, 0.0),
            UnitQuaternion::from_euler_angles(0.0, 0.02, 0.0),
        );
        let mut m = MotionModel::default();
        let mut pose = Isometry3::identity();
        for _ in 0..200 {
            // Each tracked pose is 1e-12 off unit norm, as rounding leaves them.
            pose.rotation =
                UnitQuaternion::new_unchecked(pose.rotation.into_inner() * (1.0 + 1e-12));
            m.update(&pose, at(0.0), true);
            let predicted = m.predict().unwrap();
            assert!((predicted.rotation.into_inner().norm() - 1.0).abs() < 1e-9);
            pose = step * pose;
        }
        let v = m.velocity().unwrap();
        assert!(
            (v.rotation.angle() - 0.02).abs() < 1e-9,
            "velocity angle {}",
            v.rotation.angle()
        );
    }
}
