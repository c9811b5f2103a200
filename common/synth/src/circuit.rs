//! The loop trajectory ([`TrajectoryKind::Loop`]): laps of an ellipse around the centre
//! of the scene's free space, the camera looking outwards at the walls, so that it turns
//! a full circle per lap and sees each place again one lap later. Loop closure is
//! measured on it: after the first lap everything the camera sees was mapped before.
//!
//! Model: lap phase `theta = 2 pi t / LAP_SECONDS`; position `centre + (a cos theta,
//! b sin theta, h(t))` with `a / b` the free box's aspect and the size set so that the
//! mean speed is the kind's target (clamped to the free box); yaw `theta` plus a slow
//! seeded wobble, a small seeded pitch and roll, and the same hand tremor as the other
//! kinds. Frame `k * LAP_FRAMES` is back at frame 0's pose up to tremor and wobble.
//!
//! [`TrajectoryKind::Loop`]: crate::TrajectoryKind::Loop

use crate::rng::SplitMix64;
use crate::scene::Scene;
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use std::f64::consts::{PI, TAU};

/// Seconds per lap: a full turn at 30 deg/s.
pub const LAP_SECONDS: f64 = 12.0;
/// Target mean translational speed (m/s) and angular speed (deg/s) of a lap.
pub const MEAN_SPEEDS: (f64, f64) = (0.4, 360.0 / LAP_SECONDS);
/// Wobble amplitudes (radians) of yaw, pitch and roll, and of the height (metres).
const WOBBLE_RAD: [f64; 3] = [0.12, 0.05, 0.03];
const WOBBLE_HEIGHT_M: f64 = 0.05;
/// Wobble frequency range (Hz): slow, like a person turning their head while walking.
const WOBBLE_HZ: [f64; 2] = [0.07, 0.15];

/// A seeded loop: the ellipse, its start and the wobble.
#[derive(Clone, Debug)]
pub(crate) struct Lap {
    centre: Vector3<f64>,
    half_axes: (f64, f64),
    start: f64,
    wobble: [(f64, f64); 4],
    camera_in_body: UnitQuaternion<f64>,
    base_pitch: f64,
    tremor_phase: [f64; 6],
}

impl Lap {
    /// The loop in `scene` for `seed`; `tremor_phase` the phases of the hand tremor
    /// shared with the other kinds.
    pub(crate) fn new(
        scene: &Scene,
        seed: u64,
        camera_in_body: UnitQuaternion<f64>,
        base_pitch: f64,
        tremor_phase: [f64; 6],
    ) -> Self {
        let mut rng = SplitMix64::keyed(seed, &[0x6c6f_6f70]);
        let free = scene.free_space();
        let half = free.half_extents();
        // Ramanujan's perimeter of the ellipse with half axes (half.x, half.y), scaled to
        // the lap length the target speed asks for, never beyond 90 % of the free box.
        let (hx, hy) = (half.x, half.y);
        let h = ((hx - hy) / (hx + hy)).powi(2);
        let perimeter = PI * (hx + hy) * (1.0 + 3.0 * h / (10.0 + (4.0 - 3.0 * h).sqrt()));
        let size = (MEAN_SPEEDS.0 * LAP_SECONDS / perimeter).min(0.9);
        let start = rng.range(0.0, TAU);
        let wobble = [0; 4].map(|_| (rng.range(WOBBLE_HZ[0], WOBBLE_HZ[1]), rng.range(0.0, TAU)));
        Self {
            centre: free.center().coords,
            half_axes: (hx * size, hy * size),
            start,
            wobble,
            camera_in_body,
            base_pitch,
            tremor_phase,
        }
    }

    fn wave(&self, k: usize, t: f64) -> f64 {
        (TAU * self.wobble[k].0 * t + self.wobble[k].1).sin()
    }

    /// The pose `T_wc` at `t` seconds.
    pub(crate) fn pose(&self, t: f64) -> Isometry3<f64> {
        let (a, b) = self.half_axes;
        let theta = self.start + TAU * t / LAP_SECONDS;
        let (shake, angles) = crate::trajectory::tremor(&self.tremor_phase, t);
        let position = self.centre
            + Vector3::new(
                a * theta.cos(),
                b * theta.sin(),
                WOBBLE_HEIGHT_M * self.wave(3, t),
            )
            + shake;
        // Looking outwards: along the radius of the ellipse's phase.
        let body = UnitQuaternion::from_euler_angles(
            WOBBLE_RAD[2] * self.wave(2, t) + angles[2],
            self.base_pitch + WOBBLE_RAD[1] * self.wave(1, t) + angles[1],
            theta + WOBBLE_RAD[0] * self.wave(0, t) + angles[0],
        );
        Isometry3::from_parts(Translation3::from(position), body * self.camera_in_body)
    }
}
