use super::*;
use crate::noise::ImuNoise;
use crate::sample::ImuSample;
use crate::simulate::{Simulator, world_gravity};
use crate::testing::{hand_held, hand_held_velocity};
use gfs_core::stamp::Stamp;

fn state(t: f64, bias: Bias) -> State {
    let (rotation, position) = hand_held(t);
    State {
        rotation,
        position,
        velocity: hand_held_velocity(t),
        bias,
    }
}

fn noisy_preintegration() -> Preintegrated {
    let samples: Vec<ImuSample> = Simulator::new(ImuNoise::BMI055, Bias::default(), 3).run(
        &hand_held,
        (0.0, 0.4),
        200.0,
        Stamp::default(),
    );
    let bias = Bias {
        gyro: Vector3::new(0.002, -0.001, 0.003),
        accel: Vector3::new(0.02, 0.01, -0.03),
    };
    Preintegrated::between(
        &samples,
        Stamp::from_nanos(50_000_000),
        Stamp::from_nanos(250_000_000),
        bias,
        ImuNoise::BMI055,
        0.05,
    )
    .expect("covered")
}

#[test]
fn analytic_jacobians_match_numeric_ones() {
    let pre = noisy_preintegration();
    // States a little off the truth, with biases off the linearisation point, so no
    // term of the Jacobians vanishes.
    let mut off = SVector::<f64, 15>::zeros();
    for k in 0..15 {
        off[k] = 0.01 * ((k as f64 * 1.7).sin());
    }
    let i = state(0.05, Bias::default()).perturbed(&off);
    let j = state(0.25, Bias::default()).perturbed(&(-off * 0.5));
    let g = world_gravity();
    let analytic = InertialResidual::evaluate(&pre, &i, &j, &g);
    let h = 1e-6;
    let mut worst: f64 = 0.0;
    for k in 0..15 {
        let mut d = SVector::<f64, 15>::zeros();
        d[k] = h;
        let plus = InertialResidual::evaluate(&pre, &i.perturbed(&d), &j, &g).residual;
        let minus = InertialResidual::evaluate(&pre, &i.perturbed(&-d), &j, &g).residual;
        let numeric = (plus - minus) / (2.0 * h);
        let error = (numeric - analytic.jacobian_i.column(k)).norm();
        worst = worst.max(error / numeric.norm().max(1e-3));
    }
    for k in 0..9 {
        let mut d = SVector::<f64, 15>::zeros();
        d[k] = h;
        let plus = InertialResidual::evaluate(&pre, &i, &j.perturbed(&d), &g).residual;
        let minus = InertialResidual::evaluate(&pre, &i, &j.perturbed(&-d), &g).residual;
        let numeric = (plus - minus) / (2.0 * h);
        let error = (numeric - analytic.jacobian_j.column(k)).norm();
        worst = worst.max(error / numeric.norm().max(1e-3));
    }
    assert!(worst < 1e-5, "worst relative Jacobian error {worst}");
}

#[test]
fn the_true_states_leave_a_residual_the_noise_explains() {
    let pre = noisy_preintegration();
    let bias = *pre.bias();
    let i = state(0.05, bias);
    let j = state(0.25, bias);
    let r = InertialResidual::evaluate(&pre, &i, &j, &world_gravity());
    // The samples were drawn with a zero bias; the states claim the preintegration's
    // (small) one: chi2 of 9 residuals well under the 99.9 % bound of 27.9 is not
    // expected then, but the rotation residual stays at the gyro bias times 0.2 s.
    let rotation = r.residual.fixed_rows::<3>(0).norm();
    assert!(
        rotation < 0.004 * 0.2 * 2.0,
        "rotation residual {rotation} rad"
    );
    let exact = InertialResidual::evaluate(
        &pre,
        &state(0.05, Bias::default()),
        &state(0.25, Bias::default()),
        &world_gravity(),
    );
    let chi2 = exact.chi2(&pre);
    assert!(chi2 < 27.9, "chi2 {chi2} at the true states and biases");
}

#[test]
fn the_bias_walk_information_is_the_inverse_of_the_walk_variance() {
    let pre = noisy_preintegration();
    let info = bias_walk_information(&pre);
    let expected = 1.0 / (ImuNoise::BMI055.gyro_walk.powi(2) * 0.2);
    assert!((info[0] / expected - 1.0).abs() < 1e-9);
    let expected = 1.0 / (ImuNoise::BMI055.accel_walk.powi(2) * 0.2);
    assert!((info[5] / expected - 1.0).abs() < 1e-9);
}
