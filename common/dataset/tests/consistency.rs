//! The NEES of frame-to-frame motions against errors drawn from known covariances.

use gfs_core::rng::SplitMix64;
use gfs_core::se3;
use gfs_dataset::{CHI2_6DOF_999, Covariances, Trajectory, TrajectoryError, consistency};
use nalgebra::{Isometry3, Matrix6, Translation3, UnitQuaternion, Vector3, Vector6};

/// A random covariance: translation sigmas 1-5 mm, rotation 0.5-2 mrad, correlated
/// (a random lower-triangular factor). Returns the factor `L` (`C = L L^T`).
fn random_factor(rng: &mut SplitMix64) -> Matrix6<f64> {
    let mut l = Matrix6::zeros();
    for r in 0..6 {
        let scale = if r < 3 {
            rng.range(0.001, 0.005)
        } else {
            rng.range(0.0005, 0.002)
        };
        l[(r, r)] = scale;
        for c in 0..r {
            l[(r, c)] = 0.5 * scale * (2.0 * rng.uniform() - 1.0);
        }
    }
    l
}

/// A walk of `n` poses at 30 Hz (about 0.3 m/s, 20 deg/s), the estimate the same walk
/// in another world frame with each pose's error drawn from its covariance, and the
/// covariances scaled by `reported_scale`.
fn walk(n: usize, reported_scale: f64) -> (Trajectory, Trajectory, Covariances) {
    let mut rng = SplitMix64::new(11);
    let other_world = Isometry3::from_parts(
        Translation3::new(1.0, -2.0, 0.5),
        UnitQuaternion::from_scaled_axis(Vector3::new(0.3, -0.2, 1.0)),
    );
    let (mut gt, mut est, mut covariances) =
        (Trajectory::new(), Trajectory::new(), Covariances::new());
    for k in 0..n {
        let t = k as f64 / 30.0;
        let stamp = gfs_core::stamp::Stamp::from_secs(t).unwrap();
        let pose = Isometry3::from_parts(
            Translation3::new(0.3 * t, (0.7 * t).sin(), 0.2 * (0.3 * t).cos()),
            UnitQuaternion::from_scaled_axis(Vector3::new(0.2 * (0.5 * t).sin(), 0.35 * t, 0.1)),
        );
        let factor = random_factor(&mut rng);
        let z = Vector6::from_fn(|_, _| rng.gaussian());
        let error = factor * z;
        gt.push(stamp, pose);
        est.push(stamp, other_world * pose * se3::exp(&error));
        covariances.push(stamp, factor * factor.transpose() * reported_scale);
    }
    (gt, est, covariances)
}

#[test]
fn errors_drawn_from_the_reported_covariances_give_a_mean_nees_of_6() {
    let (gt, est, covariances) = walk(2001, 1.0);
    let c = consistency(&gt, &est, &covariances, 0.01);
    assert_eq!((c.pairs, c.nees.len()), (2000, 2000));
    let mean = c.mean_nees.unwrap_or(f64::NAN);
    assert!((mean - 6.0).abs() < 0.5, "mean NEES {mean}");
    let beyond = c.beyond_bound.unwrap_or(f64::NAN);
    assert!(
        beyond < 0.005,
        "{beyond} of the pairs beyond {CHI2_6DOF_999}"
    );
    // Each pose's translation error is a few millimetres: so is a motion's.
    let median = c.median_translation_error_m.unwrap_or(f64::NAN);
    assert!((0.003..0.012).contains(&median), "median {median} m");
}

#[test]
fn covariances_ten_times_too_small_give_a_mean_nees_of_60() {
    let (gt, est, covariances) = walk(2001, 0.1);
    let c = consistency(&gt, &est, &covariances, 0.01);
    let mean = c.mean_nees.unwrap_or(f64::NAN);
    assert!((mean - 60.0).abs() < 5.0, "mean NEES {mean}");
    assert!(c.beyond_bound.unwrap_or(0.0) > 0.5);
}

#[test]
fn a_pose_without_covariance_leaves_its_two_pairs_out_of_the_nees_only() {
    let (gt, est, full) = walk(11, 1.0);
    let mut covariances = Covariances::new();
    for (k, &t) in est.timestamps().iter().enumerate() {
        if k != 5
            && let Some(c) = full.at(t, 0.0)
        {
            covariances.push(t, *c);
        }
    }
    let c = consistency(&gt, &est, &covariances, 0.01);
    assert_eq!((c.pairs, c.nees.len()), (10, 8));
}

#[test]
fn covariance_files_round_trip_and_name_the_bad_line() {
    let (_, est, covariances) = walk(5, 1.0);
    let dir = std::env::temp_dir().join(format!("gfs-covariances-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join("covariance.txt");
    covariances.write(&path).expect("written");
    // Stamps to the microsecond (as trajectories), matrices exactly.
    let read = Covariances::read(&path).expect("read back");
    assert_eq!(read.len(), 5);
    for &t in est.timestamps() {
        assert_eq!(read.at(t, 1e-6), covariances.at(t, 0.0));
    }
    let text = std::fs::read_to_string(&path).expect("text");
    // Line 3, the first pose's, with a word among its numbers.
    let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
    lines[2] = lines[2].replacen(' ', " x ", 1);
    std::fs::write(&path, lines.join("\n")).expect("written");
    match Covariances::read(&path) {
        Err(TrajectoryError::Malformed { line, .. }) => assert_eq!(line, 3),
        other => panic!("expected a malformed line 3, got {other:?}"),
    }
    let _ = std::fs::remove_dir_all(&dir);
}
