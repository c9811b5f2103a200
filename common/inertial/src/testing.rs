//! A smooth hand-held-like motion for the tests: every axis turning and moving.

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

/// The IMU's pose `(R_wb, p_wb)` at `t` seconds: about 0.5 m/s and 60 deg/s.
pub fn hand_held(t: f64) -> (Matrix3<f64>, Vector3<f64>) {
    let r = UnitQuaternion::from_euler_angles(
        0.4 * (1.3 * t).sin(),
        0.3 * (0.9 * t + 1.0).sin(),
        0.8 * (0.7 * t).sin() + 0.2 * t,
    );
    let p = Vector3::new(
        0.6 * (0.8 * t).sin(),
        0.4 * (1.1 * t + 0.5).cos(),
        0.2 * (1.7 * t).sin(),
    );
    (r.to_rotation_matrix().into_inner(), p)
}

/// The velocity of [`hand_held`] at `t` (central difference).
pub fn hand_held_velocity(t: f64) -> Vector3<f64> {
    let h = 1e-5;
    (hand_held(t + h).1 - hand_held(t - h).1) / (2.0 * h)
}
