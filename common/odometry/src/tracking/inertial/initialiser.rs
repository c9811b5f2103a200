//! The first seconds: the visual poses of consecutive tracked frames and the samples
//! between them, until `gfs_inertial::initialise` finds gravity, the velocity and the
//! biases. A frame not tracked on its own data breaks the chain (its pose is a
//! prediction, not a measurement), and the chain starts again after it.

use gfs_inertial::initialisation::InitInput;
use gfs_inertial::preintegration::Preintegrated;
use gfs_inertial::{InertialInit, initialise};
use nalgebra::{Matrix3, Vector3};

/// Seconds of tracked frames initialisation waits for: the "first seconds";
/// 1.5 s of hand-held motion turns gravity's share of the accelerometer enough to
/// separate it from the bias (0.25-0.3 degrees of gravity on the crate's tests).
pub const INIT_WINDOW_S: f64 = 1.5;
/// The visual poses' error initialisation assumes: a few millimetres and a tenth of a
/// degree, the tracker's frame-to-frame jitter on real sequences.
const POSE_SD: (f64, f64) = (0.003, 0.1 * std::f64::consts::PI / 180.0);
/// Largest RMS of the rotation residuals (radians, 0.5 degrees) an initialisation is
/// accepted with: more means the samples and the poses disagree (a wrong mount, a
/// clock offset, a pose that was off), and the window moves on instead.
const MAX_ROTATION_RMS: f64 = 0.5 * std::f64::consts::PI / 180.0;

/// The chain of tracked frames waiting for initialisation.
#[derive(Clone, Debug, Default)]
pub struct Initialiser {
    poses: Vec<(Matrix3<f64>, Vector3<f64>)>,
    intervals: Vec<Preintegrated>,
}

impl Initialiser {
    /// Adds a frame's IMU pose; `interval` is the preintegration from the previous
    /// frame, `None` when the chain breaks there (no samples, or the previous frame
    /// was not tracked on its data). `tracked` says this frame's pose was measured.
    pub fn add(
        &mut self,
        pose: (Matrix3<f64>, Vector3<f64>),
        interval: Option<Preintegrated>,
        tracked: bool,
    ) {
        match interval {
            Some(pre) if tracked && !self.poses.is_empty() => {
                self.poses.push(pose);
                self.intervals.push(pre);
            }
            _ => {
                self.poses.clear();
                self.intervals.clear();
                if tracked {
                    self.poses.push(pose);
                }
            }
        }
    }

    /// Seconds the chain covers.
    fn span_s(&self) -> f64 {
        self.intervals.iter().map(Preintegrated::dt).sum()
    }

    /// Gravity, velocities and biases once the chain covers [`INIT_WINDOW_S`]; a
    /// failed or implausible attempt drops the oldest frame and waits for the next.
    pub fn try_initialise(&mut self) -> Option<InertialInit> {
        if self.span_s() < INIT_WINDOW_S {
            return None;
        }
        let found = initialise(&InitInput {
            poses: &self.poses,
            intervals: &self.intervals,
            pose_sd: POSE_SD,
        });
        match found {
            Ok(init) if init.rotation_rms <= MAX_ROTATION_RMS => {
                self.poses.clear();
                self.intervals.clear();
                Some(init)
            }
            outcome => {
                tracing::debug!(?outcome, "inertial initialisation not accepted yet");
                self.poses.remove(0);
                self.intervals.remove(0);
                None
            }
        }
    }
}
