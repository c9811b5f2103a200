//! Pose optimisation on a synthetic frame: 300 points and 60 lines, 1 px noise, 20 %
//! outliers, initial pose 10 cm / 5 deg off.

mod common;

use common::{Rng, camera, perturb, pose_error, synthetic_frame};
use gfs_optim::{PointObservation, PoseOptimizerConfig, PoseResult, optimize_pose};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector2, Vector3};

fn true_pose() -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(0.3, -0.2, 0.5),
        UnitQuaternion::from_scaled_axis(Vector3::new(0.1, -0.3, 0.05)),
    )
}

/// Fractions of the true outliers flagged outlier and of the true inliers kept.
fn flag_rates(flags: &[bool], outlier: &[bool]) -> (f64, f64) {
    let count = |want_outlier: bool| {
        let total = outlier.iter().filter(|&&o| o == want_outlier).count();
        let right = flags
            .iter()
            .zip(outlier)
            .filter(|&(&inlier, &o)| o == want_outlier && inlier != o)
            .count();
        right as f64 / total.max(1) as f64
    };
    (count(true), count(false))
}

#[test]
fn recovers_the_pose_and_flags_outliers() {
    let camera = camera();
    let mut result = PoseResult::default();
    let config = PoseOptimizerConfig::default();
    // Odd seeds give depth to the points closer than 3.2 m (RGB-D error).
    for seed in 0..6 {
        let mut rng = Rng::new(100 + seed);
        let truth = true_pose();
        let frame = synthetic_frame(&camera, &truth, 300, 60, 0.2, seed % 2 == 1, &mut rng);
        let initial = perturb(&truth, 0.10, 5f64.to_radians(), &mut rng);
        optimize_pose(
            &camera,
            &initial,
            &frame.points,
            &frame.lines,
            &config,
            &mut result,
        );
        let (dt, dr) = pose_error(&result.camera_from_world, &truth);
        let (point_out, point_in) = flag_rates(&result.point_inliers, &frame.point_outlier);
        let (line_out, line_in) = flag_rates(&result.line_inliers, &frame.line_outlier);
        println!(
            "seed {seed}: error {:.2} mm {:.3} deg, outliers flagged: points {:.1} % lines {:.1} %, \
             inliers kept: points {:.1} % lines {:.1} %, rms {:.3} px, {} iterations, converged {}",
            dt * 1e3,
            dr,
            point_out * 100.0,
            line_out * 100.0,
            point_in * 100.0,
            line_in * 100.0,
            result.rms_error_px,
            result.iterations,
            result.converged
        );
        assert!(dt < 0.01, "seed {seed}: translation error {dt} m");
        assert!(dr < 0.2, "seed {seed}: rotation error {dr} deg");
        // Every outlier is at least 20 px off: all must be caught.
        assert!(
            point_out >= 0.95 && line_out >= 0.95,
            "seed {seed}: outliers {point_out} {line_out}"
        );
        // The chi-square test at 95 % drops about 5 % of true 1 px inliers by design.
        assert!(
            point_in >= 0.9 && line_in >= 0.9,
            "seed {seed}: inliers {point_in} {line_in}"
        );
        assert!(result.converged);
        assert!(result.rms_error_px < 1.5, "rms {}", result.rms_error_px);
    }
}

#[test]
fn lines_alone_constrain_the_pose() {
    let camera = camera();
    let mut rng = Rng::new(7);
    let truth = true_pose();
    let frame = synthetic_frame(&camera, &truth, 300, 60, 0.0, false, &mut rng);
    let initial = perturb(&truth, 0.05, 2f64.to_radians(), &mut rng);
    let mut result = PoseResult::default();
    optimize_pose(
        &camera,
        &initial,
        &[],
        &frame.lines,
        &PoseOptimizerConfig::default(),
        &mut result,
    );
    let (dt, dr) = pose_error(&result.camera_from_world, &truth);
    println!(
        "lines only: {:.2} mm {:.3} deg, {} inliers",
        dt * 1e3,
        dr,
        result.num_line_inliers
    );
    assert!(dt < 0.02 && dr < 0.3, "{dt} m {dr} deg");
    assert!(result.num_line_inliers >= 57);
}

#[test]
fn no_observations_returns_the_initial_pose_unconverged() {
    let camera = camera();
    let initial = true_pose();
    let mut result = PoseResult::default();
    optimize_pose(
        &camera,
        &initial,
        &[],
        &[],
        &PoseOptimizerConfig::default(),
        &mut result,
    );
    assert_eq!(result.camera_from_world, initial);
    assert!(!result.converged);
    assert_eq!(result.rms_error_px, 0.0);
    // A point behind the camera and a NaN observation are outliers, not panics.
    let behind = PointObservation {
        point_in_world: (initial.inverse() * nalgebra::Point3::new(0.0, 0.0, -2.0)).coords,
        uv: Vector2::new(320.0, 240.0),
        inv_sigma2: 1.0,
        depth: 0.0,
    };
    let nan = PointObservation {
        uv: Vector2::new(f64::NAN, 1.0),
        ..behind
    };
    optimize_pose(
        &camera,
        &initial,
        &[behind, nan],
        &[],
        &PoseOptimizerConfig::default(),
        &mut result,
    );
    assert_eq!(result.point_inliers, vec![false, false]);
    assert!(!result.converged);
}

/// The covariance is the pose's real uncertainty: over 60 noise draws of 1 px (what the
/// information assumes), the squared errors weighed by it (NEES) average the 6 degrees
/// of freedom; a covariance 4x too small or too large would average 24 or 1.5.
#[test]
fn covariance_matches_the_spread_of_the_estimates() {
    let camera = camera();
    let mut result = PoseResult::default();
    let config = PoseOptimizerConfig::default();
    let truth = true_pose();
    let mut nees = Vec::new();
    for seed in 0..60 {
        let mut rng = Rng::new(500 + seed);
        let frame = synthetic_frame(&camera, &truth, 150, 0, 0.0, false, &mut rng);
        let initial = perturb(&truth, 0.05, 2f64.to_radians(), &mut rng);
        optimize_pose(&camera, &initial, &frame.points, &[], &config, &mut result);
        let covariance = result
            .covariance
            .expect("a converged pose has a covariance");
        // Left perturbation: estimate = exp(delta) * truth.
        let delta = gfs_core::se3::log(&(result.camera_from_world * truth.inverse()));
        let weighed = covariance
            .cholesky()
            .expect("positive definite")
            .solve(&delta);
        nees.push(delta.dot(&weighed));
    }
    let mean = nees.iter().sum::<f64>() / nees.len() as f64;
    println!(
        "mean NEES over {} draws: {mean:.2} (6 expected)",
        nees.len()
    );
    assert!((4.0..9.0).contains(&mean), "mean NEES {mean}");
    optimize_pose(&camera, &truth, &[], &[], &config, &mut result);
    assert_eq!(result.covariance, None, "no observation, no covariance");
}
