//! Tests of the evaluation on trajectories with known answers.

use super::*;
use gfs_core::stamp::Stamp;
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

fn at(seconds: f64) -> Stamp {
    Stamp::from_secs(seconds).unwrap()
}

/// splitmix64: a tiny deterministic generator for test noise.
struct SplitMix(u64);

impl SplitMix {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    fn uniform(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    /// Standard normal sample (Box-Muller).
    fn normal(&mut self) -> f64 {
        let (u1, u2) = (self.uniform(), self.uniform());
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

/// A hand-held-like ground truth: `n` poses at `rate_hz`, moving and turning smoothly.
fn wavy_ground_truth(n: usize, rate_hz: f64) -> Trajectory {
    let mut gt = Trajectory::new();
    for k in 0..n {
        let t = k as f64 / rate_hz;
        let pos = Translation3::new(
            1.5 * (0.3 * t).cos(),
            (0.2 * t).sin(),
            0.3 * (0.5 * t).sin(),
        );
        let rot = UnitQuaternion::from_euler_angles(0.2 * (0.7 * t).sin(), 0.4 * t, 0.1 * t.cos());
        gt.push(at(1000.0 + t), Isometry3::from_parts(pos, rot));
    }
    gt
}

#[test]
fn a_rigidly_moved_copy_has_zero_ate_and_rpe() {
    let gt = wavy_ground_truth(300, 30.0);
    let moved = Isometry3::from_parts(
        Translation3::new(-3.0, 7.5, 1.2),
        UnitQuaternion::from_euler_angles(1.0, -0.5, 2.0),
    );
    let est = gt.transformed(&moved);
    let eval = evaluate(&gt, &est, EVO_MAX_DIFF_S).unwrap();
    assert_eq!(eval.matched(), 300);
    assert!(eval.ate.stats.rmse < 1e-9, "{:?}", eval.ate.stats);
    assert!(eval.ate.stats.max < 1e-9);
    // The alignment undoes the motion.
    assert!((eval.ate.alignment * moved).translation.vector.norm() < 1e-9);
    let rpe = eval.rpe_frame.unwrap();
    assert_eq!(rpe.pairs.len(), 299);
    assert!(rpe.trans_m.max < 1e-9 && rpe.rot_deg.max < 1e-6);
    let rpe_s = eval.rpe_second.unwrap();
    assert!(rpe_s.trans_m.max < 1e-9 && rpe_s.rot_deg.max < 1e-6);
}

#[test]
fn known_position_noise_gives_its_rmse() {
    // Isotropic noise of sigma per axis: |error| has RMS sigma * sqrt(3). The alignment
    // absorbs 6 of the 3n degrees of freedom, a 0.1 % effect at n = 3000.
    let sigma = 0.01;
    let gt = wavy_ground_truth(3000, 30.0);
    let mut rng = SplitMix(7);
    let mut est = Trajectory::new();
    for (t, pose) in gt.iter() {
        let noise = Vector3::new(rng.normal(), rng.normal(), rng.normal()) * sigma;
        est.push(
            t,
            Isometry3::from_parts(
                Translation3::from(pose.translation.vector + noise),
                pose.rotation,
            ),
        );
    }
    let eval = evaluate(&gt, &est, EVO_MAX_DIFF_S).unwrap();
    let want = sigma * 3f64.sqrt();
    let got = eval.ate.stats.rmse;
    assert!((got / want - 1.0).abs() < 0.03, "ATE RMSE {got} vs {want}");
    // Mean of a chi distribution with 3 dof: sigma * 2 sqrt(2 / pi) = 1.596 sigma.
    let want_mean = sigma * 2.0 * (2.0 / std::f64::consts::PI).sqrt();
    assert!((eval.ate.stats.mean / want_mean - 1.0).abs() < 0.03);
    // RPE per frame: the difference of two noisy positions, RMS sigma * sqrt(6)
    // (rotated into the camera frame, which keeps its norm).
    let rpe = eval.rpe_frame.unwrap();
    let want_rpe = sigma * 6f64.sqrt();
    assert!(
        (rpe.trans_m.rmse / want_rpe - 1.0).abs() < 0.03,
        "{}",
        rpe.trans_m.rmse
    );
    assert!(rpe.rot_deg.max < 1e-9);
}

#[test]
fn hand_computed_rpe_per_frame_and_per_second() {
    // Ground truth steps 1 m along its x axis; the estimate steps 1.1 m and turns 1 deg
    // about z each frame, so every consecutive error is E = (Rz(1 deg), (0.1, 0, 0)).
    let step_gt = Isometry3::translation(1.0, 0.0, 0.0);
    let step_est = Isometry3::from_parts(
        Translation3::new(1.1, 0.0, 0.0),
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 1f64.to_radians()),
    );
    let (mut gt, mut est) = (Trajectory::new(), Trajectory::new());
    let (mut q, mut p) = (Isometry3::identity(), Isometry3::identity());
    for k in 0..30 {
        let t = k as f64 * 0.1;
        gt.push(at(t), q);
        est.push(at(t), p);
        q *= step_gt;
        p *= step_est;
    }
    let eval = evaluate(&gt, &est, EVO_MAX_DIFF_S).unwrap();
    let rpe = eval.rpe_frame.unwrap();
    assert_eq!(rpe.pairs.len(), 29);
    assert!((rpe.trans_m.rmse - 0.1).abs() < 1e-12 && (rpe.trans_m.max - 0.1).abs() < 1e-12);
    assert!((rpe.rot_deg.mean - 1.0).abs() < 1e-9 && rpe.rot_deg.std < 1e-9);
    // Over 1 s = 10 frames, composed as TUM's tool does: E = D^10 G^-10
    // = (Rz(10 deg), t10 - Rz(10 deg) (10, 0, 0)) with t10 = sum_m Rz(m deg) (1.1, 0, 0).
    let mut t10 = Vector3::zeros();
    for m in 0..10 {
        let a = (m as f64).to_radians();
        t10 += Vector3::new(1.1 * a.cos(), 1.1 * a.sin(), 0.0);
    }
    let r10 = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 10f64.to_radians());
    let want = (t10 - r10 * Vector3::new(10.0, 0.0, 0.0)).norm();
    let rpe_s = eval.rpe_second.unwrap();
    // Pairs (i, i + 10) while i + 10 is not the last pose (index 29): i = 0..=18.
    assert_eq!(rpe_s.pairs.len(), 19);
    assert!(rpe_s.pairs.iter().all(|&(i, j)| j == i + 10));
    assert!(
        (rpe_s.trans_m.rmse - want).abs() < 1e-9,
        "{} vs {want}",
        rpe_s.trans_m.rmse
    );
    assert!((rpe_s.rot_deg.rmse - 10.0).abs() < 1e-9);
}

#[test]
fn stamps_with_jitter_are_matched_within_the_window() {
    // 100 Hz ground truth; the estimate at 30 Hz with jitter. Every third frame sits
    // 0.5 ms from a ground-truth stamp, the others 1.3 ms and 3.3 ms.
    let gt = wavy_ground_truth(1000, 100.0);
    let mut est = Trajectory::new();
    for k in 0..300 {
        let jitter = [0.0005, -0.002, 0.0][k % 3];
        let t = 1000.0 + k as f64 / 30.0 + jitter;
        // The pose of the closest ground-truth stamp: exact when matched.
        let idx = ((t - 1000.0) * 100.0).round() as usize;
        est.push(at(t), gt.poses()[idx]);
    }
    // With a 1 ms window only stamps within 1 ms of the 10 ms grid match.
    let tight = evaluate(&gt, &est, 0.001).unwrap();
    let all = evaluate(&gt, &est, EVO_MAX_DIFF_S).unwrap();
    assert_eq!(all.matched(), 300);
    assert_eq!(tight.matched(), 100);
    assert!(all.ate.stats.max < 1e-9);
    let mut shifted = Trajectory::new();
    for (t, p) in est.iter() {
        shifted.push(at(t.secs() + 100.0), *p);
    }
    assert!(matches!(
        evaluate(&gt, &shifted, EVO_MAX_DIFF_S),
        Err(EvalError::NoMatches { .. })
    ));
}

#[test]
fn stats_follow_numpy() {
    let s = Stats::from_values(&[3.0, 1.0, 4.0, 1.0]).unwrap();
    assert_eq!(s.median, 2.0);
    assert_eq!(s.mean, 2.25);
    assert_eq!((s.min, s.max, s.count), (1.0, 4.0, 4));
    assert!((s.rmse - (27.0f64 / 4.0).sqrt()).abs() < 1e-12);
    // numpy.std (population): sqrt(mean((x - 2.25)^2)) = sqrt(1.6875).
    assert!((s.std - 1.6875f64.sqrt()).abs() < 1e-12);
    assert_eq!(Stats::from_values(&[5.0, 1.0, 2.0]).unwrap().median, 2.0);
    assert!(Stats::from_values(&[]).is_none());
}
