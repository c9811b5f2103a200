use super::*;
use crate::noise::ImuNoise;
use crate::simulate::Simulator;
use crate::testing::{hand_held, hand_held_velocity};
use gfs_core::rng::SplitMix64;
use gfs_core::stamp::Stamp;

/// Two seconds of frames at 30 Hz, their IMU poses expressed in a visual world turned
/// away from gravity by `world`, with visual noise of `pose_sd` (m, rad) per pose.
fn run(
    world: UnitQuaternion<f64>,
    bias: Bias,
    pose_sd: f64,
    seed: u64,
) -> (InertialInit, Vec<Vector3<f64>>) {
    let noise = ImuNoise::BMI055;
    let samples =
        Simulator::new(noise, bias, seed).run(&hand_held, (0.0, 2.1), 200.0, Stamp::default());
    let frames: Vec<f64> = (0..61).map(|k| 0.01 + k as f64 / 30.0).collect();
    let mut rng = SplitMix64::new(seed);
    let mut gaussian3 = || Vector3::new(rng.gaussian(), rng.gaussian(), rng.gaussian()) * pose_sd;
    let w = world.to_rotation_matrix().into_inner();
    let poses: Vec<(Matrix3<f64>, Vector3<f64>)> = frames
        .iter()
        .map(|&t| {
            let (r, p) = hand_held(t);
            let turn = UnitQuaternion::from_scaled_axis(gaussian3())
                .to_rotation_matrix()
                .into_inner();
            (w * r * turn, w * p + gaussian3())
        })
        .collect();
    let stamp = |t: f64| Stamp::from_nanos((t * 1e9).round() as i64);
    let intervals: Vec<Preintegrated> = frames
        .windows(2)
        .map(|f| {
            Preintegrated::between(
                &samples,
                stamp(f[0]),
                stamp(f[1]),
                Bias::default(),
                noise,
                0.05,
            )
            .expect("covered")
        })
        .collect();
    let init = initialise(&InitInput {
        poses: &poses,
        intervals: &intervals,
        pose_sd: (pose_sd.max(1e-4), pose_sd.max(1e-4)),
    })
    .expect("initialised");
    let velocities = frames.iter().map(|&t| w * hand_held_velocity(t)).collect();
    (init, velocities)
}

#[test]
fn gravity_biases_and_velocities_are_found_from_visual_poses() {
    let world = UnitQuaternion::from_euler_angles(0.3, -1.2, 2.0);
    let bias = Bias {
        gyro: Vector3::new(0.01, -0.015, 0.02),
        accel: Vector3::new(0.08, -0.05, 0.1),
    };
    for seed in 1..=3 {
        // Visual poses good to 2 mm and 0.1 degrees, as the tracker's are.
        let (init, velocities) = run(world, bias, 0.002, seed);
        let expected = world * Vector3::new(0.0, 0.0, -GRAVITY);
        let angle = init.gravity.angle(&expected).to_degrees();
        assert!(angle < 1.0, "seed {seed}: gravity off by {angle} deg");
        assert!((init.gravity.norm() - GRAVITY).abs() < 1e-9);
        // The gyro bias is the visual rotation over the 2 s against the integrated one:
        // two poses' 2 mrad errors per axis over 2 s, 2.4e-3 rad/s expected (3 axes).
        let gyro_error = (init.bias.gyro - bias.gyro).norm();
        assert!(
            gyro_error < 5e-3,
            "seed {seed}: gyro bias off by {gyro_error} rad/s"
        );
        let accel_error = (init.bias.accel - bias.accel).norm();
        assert!(
            accel_error < 0.1,
            "seed {seed}: accel bias off by {accel_error} m/s^2"
        );
        let worst = velocities
            .iter()
            .zip(&init.velocities)
            .map(|(a, b)| (a - b).norm())
            .fold(0.0, f64::max);
        assert!(worst < 0.05, "seed {seed}: a velocity off by {worst} m/s");
    }
}

#[test]
fn too_few_poses_are_refused() {
    let result = initialise(&InitInput {
        poses: &[],
        intervals: &[],
        pose_sd: (0.002, 0.002),
    });
    assert_eq!(
        result,
        Err(InitError::TooFew {
            needed: MIN_INTERVALS,
            had: 0
        })
    );
}
