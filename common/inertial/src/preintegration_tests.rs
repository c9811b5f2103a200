use super::*;
use crate::residual::State;
use crate::simulate::{Simulator, exact_reading, world_gravity};
use crate::testing::{hand_held, hand_held_velocity};
use nalgebra::Rotation3;

const RATE: f64 = 400.0;

fn exact_samples(span: (f64, f64)) -> Vec<ImuSample> {
    let dt = 1.0 / RATE;
    let count = ((span.1 - span.0) * RATE).round() as usize + 1;
    (0..count)
        .map(|k| {
            let t = span.0 + k as f64 * dt;
            let (gyro, accel) = exact_reading(&hand_held, t);
            ImuSample {
                stamp: Stamp::from_nanos((t * 1e9).round() as i64),
                gyro,
                accel,
            }
        })
        .collect()
}

fn stamp(t: f64) -> Stamp {
    Stamp::from_nanos((t * 1e9).round() as i64)
}

fn true_state(t: f64) -> State {
    let (rotation, position) = hand_held(t);
    State {
        rotation,
        position,
        velocity: hand_held_velocity(t),
        bias: Bias::default(),
    }
}

#[test]
fn exact_samples_carry_the_state_across_a_frame_interval() {
    // Three frames at 30 Hz, integrated from samples that do not fall on the frames.
    let (t0, t1) = (1.0013, 1.0013 + 0.1);
    let samples = exact_samples((0.99, 1.2));
    let pre = Preintegrated::between(
        &samples,
        stamp(t0),
        stamp(t1),
        Bias::default(),
        ImuNoise::default(),
        0.05,
    )
    .expect("covered");
    assert!((pre.dt() - 0.1).abs() < 1e-9);
    let predicted = true_state(t0).predicted(&pre, &world_gravity());
    let truth = true_state(t1);
    let angle = Rotation3::from_matrix_unchecked(predicted.rotation.transpose() * truth.rotation)
        .angle()
        .to_degrees();
    assert!(angle < 0.005, "rotation off by {angle} deg");
    let dp = (predicted.position - truth.position).norm();
    assert!(dp < 1e-4, "position off by {dp} m");
    let dv = (predicted.velocity - truth.velocity).norm();
    assert!(dv < 2e-3, "velocity off by {dv} m/s");
}

#[test]
fn a_bias_change_is_applied_to_first_order_by_the_jacobians() {
    let samples = exact_samples((0.0, 0.5));
    let noise = ImuNoise::default();
    let b0 = Bias {
        gyro: Vector3::new(0.01, -0.02, 0.015),
        accel: Vector3::new(0.1, 0.05, -0.08),
    };
    let change = Bias {
        gyro: Vector3::new(-0.004, 0.003, 0.005),
        accel: Vector3::new(0.03, -0.04, 0.02),
    };
    let b1 = Bias {
        gyro: b0.gyro + change.gyro,
        accel: b0.accel + change.accel,
    };
    let (from, to) = (stamp(0.0), stamp(0.3));
    let at_b0 = Preintegrated::between(&samples, from, to, b0, noise, 0.05).expect("covered");
    let at_b1 = Preintegrated::between(&samples, from, to, b1, noise, 0.05).expect("covered");
    // The corrected increments are much closer to a re-integration than the
    // uncorrected ones: the first-order error is second order in the change.
    let rotation_gap = |a: &Matrix3<f64>, b: &Matrix3<f64>| {
        Rotation3::from_matrix_unchecked(a.transpose() * b).angle()
    };
    let uncorrected = rotation_gap(&at_b0.delta_rotation(&b0), &at_b1.delta_rotation(&b1));
    let corrected = rotation_gap(&at_b0.delta_rotation(&b1), &at_b1.delta_rotation(&b1));
    assert!(
        corrected < 0.01 * uncorrected,
        "{corrected} vs {uncorrected}"
    );
    let uncorrected = (at_b0.delta_velocity(&b0) - at_b1.delta_velocity(&b1)).norm();
    let corrected = (at_b0.delta_velocity(&b1) - at_b1.delta_velocity(&b1)).norm();
    assert!(
        corrected < 0.01 * uncorrected,
        "{corrected} vs {uncorrected}"
    );
    let uncorrected = (at_b0.delta_position(&b0) - at_b1.delta_position(&b1)).norm();
    let corrected = (at_b0.delta_position(&b1) - at_b1.delta_position(&b1)).norm();
    assert!(
        corrected < 0.01 * uncorrected,
        "{corrected} vs {uncorrected}"
    );
}

#[test]
fn the_propagated_covariance_matches_the_scatter_of_noisy_integrations() {
    // 400 noisy integrations of 0.2 s at 200 Hz: the NEES of the increment errors
    // under the propagated covariance averages 9 (9 degrees of freedom).
    let noise = ImuNoise::BMI055;
    let (from, to) = (stamp(2.0), stamp(2.2));
    // Biases frozen (walks of zero) so only the white noise scatters; the truth is
    // integrated from noise-free samples at the same stamps, so the discretisation is
    // the same on both sides.
    let white = ImuNoise {
        gyro_walk: 1e-30,
        accel_walk: 1e-30,
        ..noise
    };
    let silent = ImuNoise {
        gyro_noise: 1e-30,
        accel_noise: 1e-30,
        ..white
    };
    let exact = Simulator::new(silent, Bias::default(), 0).run(
        &hand_held,
        (1.99, 2.21),
        200.0,
        Stamp::default(),
    );
    let truth =
        Preintegrated::between(&exact, from, to, Bias::default(), noise, 0.05).expect("covered");
    let runs = 400;
    let mut total = 0.0;
    for seed in 0..runs {
        let samples = Simulator::new(white, Bias::default(), seed).run(
            &hand_held,
            (1.99, 2.21),
            200.0,
            Stamp::default(),
        );
        let pre = Preintegrated::between(&samples, from, to, Bias::default(), noise, 0.05)
            .expect("covered");
        let mut e = crate::residual::Vector9::zeros();
        let dr = Rotation3::from_matrix_unchecked(
            truth.delta_rotation(&Bias::default()).transpose()
                * pre.delta_rotation(&Bias::default()),
        )
        .scaled_axis();
        e.fixed_rows_mut::<3>(0).copy_from(&dr);
        e.fixed_rows_mut::<3>(3).copy_from(
            &(pre.delta_velocity(&Bias::default()) - truth.delta_velocity(&Bias::default())),
        );
        e.fixed_rows_mut::<3>(6).copy_from(
            &(pre.delta_position(&Bias::default()) - truth.delta_position(&Bias::default())),
        );
        let info = pre.covariance().try_inverse().expect("invertible");
        total += (e.transpose() * info * e)[(0, 0)];
    }
    let mean = total / runs as f64;
    assert!((mean - 9.0).abs() < 1.0, "mean NEES {mean}, 9 expected");
}

#[test]
fn intervals_the_samples_do_not_cover_are_refused_with_the_stamp() {
    let samples = exact_samples((1.0, 1.5));
    let noise = ImuNoise::default();
    let before = Preintegrated::between(
        &samples,
        stamp(0.5),
        stamp(1.2),
        Bias::default(),
        noise,
        0.05,
    );
    assert!(
        matches!(before, Err(CoverageError::Start { .. })),
        "{before:?}"
    );
    let after = Preintegrated::between(
        &samples,
        stamp(1.2),
        stamp(1.8),
        Bias::default(),
        noise,
        0.05,
    );
    assert!(matches!(after, Err(CoverageError::End { .. })), "{after:?}");
    let mut holed = samples.clone();
    holed.retain(|s| s.stamp < stamp(1.2) || s.stamp > stamp(1.3));
    let gap = Preintegrated::between(&holed, stamp(1.1), stamp(1.4), Bias::default(), noise, 0.05);
    assert!(matches!(gap, Err(CoverageError::Gap { .. })), "{gap:?}");
    let backwards = Preintegrated::between(
        &samples,
        stamp(1.3),
        stamp(1.2),
        Bias::default(),
        noise,
        0.05,
    );
    assert!(matches!(backwards, Err(CoverageError::Backwards { .. })));
    let message = gap.expect_err("gap").to_string();
    assert!(message.contains("gap of 0.10"), "{message}");
}
