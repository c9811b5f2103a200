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

/// `frames` poses `T_wc` at `rate_hz`, deterministic for `seed`; `tremor(t)` gives the
/// hand tremor (translation, yaw / pitch / roll) shared with the other kinds.
pub(crate) fn generate(
    scene: &Scene,
    frames: usize,
    seed: u64,
    rate_hz: f64,
    camera_in_body: UnitQuaternion<f64>,
    base_pitch: f64,
    tremor: impl Fn(f64) -> (Vector3<f64>, [f64; 3]),
) -> Vec<Isometry3<f64>> {
    let mut rng = SplitMix64::keyed(seed, &[0x6c6f_6f70]);
    let free = scene.free_space();
    let half = free.half_extents();
    // Ramanujan's perimeter of the ellipse with half axes (half.x, half.y), scaled to
    // the lap length the target speed asks for, never beyond 90 % of the free box.
    let (hx, hy) = (half.x, half.y);
    let h = ((hx - hy) / (hx + hy)).powi(2);
    let perimeter = PI * (hx + hy) * (1.0 + 3.0 * h / (10.0 + (4.0 - 3.0 * h).sqrt()));
    let size = (MEAN_SPEEDS.0 * LAP_SECONDS / perimeter).min(0.9);
    let (a, b) = (hx * size, hy * size);
    let start = rng.range(0.0, TAU);
    let wobble: [(f64, f64); 4] =
        [0; 4].map(|_| (rng.range(WOBBLE_HZ[0], WOBBLE_HZ[1]), rng.range(0.0, TAU)));
    let wave = |k: usize, t: f64| (TAU * wobble[k].0 * t + wobble[k].1).sin();
    let centre = free.center().coords;
    (0..frames)
        .map(|i| {
            let t = i as f64 / rate_hz;
            let theta = start + TAU * t / LAP_SECONDS;
            let (shake, angles) = tremor(t);
            let position = centre
                + Vector3::new(
                    a * theta.cos(),
                    b * theta.sin(),
                    WOBBLE_HEIGHT_M * wave(3, t),
                )
                + shake;
            // Looking outwards: along the radius of the ellipse's phase.
            let body = UnitQuaternion::from_euler_angles(
                WOBBLE_RAD[2] * wave(2, t) + angles[2],
                base_pitch + WOBBLE_RAD[1] * wave(1, t) + angles[1],
                theta + WOBBLE_RAD[0] * wave(0, t) + angles[0],
            );
            Isometry3::from_parts(Translation3::from(position), body * camera_in_body)
        })
        .collect()
}
