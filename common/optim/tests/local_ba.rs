//! Local BA on a synthetic scene: 8 keyframes along a path, 300 points, 60 lines on
//! three orthogonal directions, 1 px observation noise, noisy initial values.

mod common;

use common::{BaScene, BaSceneSpec, Rng};
use gfs_optim::{BaConfig, BaError, BaResult, LocalBundleAdjuster};

fn spec() -> BaSceneSpec {
    BaSceneSpec {
        keyframes: 8,
        points: 300,
        lines: 60,
        fixed: 2,
        track_window: 0,
        partners: 2,
        outlier_ratio: 0.0,
        depth_range: 3.2,
    }
}

fn run(scene: &mut BaScene, config: &BaConfig) -> BaResult {
    let mut result = BaResult::default();
    LocalBundleAdjuster::new()
        .optimize(&mut scene.problem, config, &mut result)
        .expect("valid problem");
    result
}

#[test]
fn recovers_poses_and_structure_makes_lines_straighter() {
    let no_structure = BaConfig {
        parallel_weight: 0.0,
        perpendicular_weight: 0.0,
        manhattan_weight: 0.0,
        ..BaConfig::default()
    };
    for seed in 0..3 {
        let mut with = BaScene::new(&spec(), &mut Rng::new(seed));
        let mut without = BaScene::new(&spec(), &mut Rng::new(seed));
        let (t0, r0) = with.max_pose_error();
        let (dir0, pts0) = (with.mean_line_direction_error(), with.point_rms());
        let result = run(&mut with, &BaConfig::default());
        let plain = run(&mut without, &no_structure);
        // Parallel / perpendicular pairs alone (no Manhattan axes).
        let mut pairs_only = BaScene::new(&spec(), &mut Rng::new(seed));
        run(
            &mut pairs_only,
            &BaConfig {
                manhattan_weight: 0.0,
                ..BaConfig::default()
            },
        );
        let dir3 = pairs_only.mean_line_direction_error();
        println!("seed {seed}: line direction error with pairs only {dir3:.3} deg");
        let (t1, r1) = with.max_pose_error();
        let (t2, r2) = without.max_pose_error();
        let (dir1, dir2) = (
            with.mean_line_direction_error(),
            without.mean_line_direction_error(),
        );
        println!(
            "seed {seed}: poses {:.1} mm {:.2} deg -> {:.2} mm {:.3} deg (no structure {:.2} mm \
             {:.3} deg); points rms {:.1} -> {:.1} mm; line direction error {:.3} -> {:.4} deg \
             (no structure {:.3} deg); cost {:.0} -> {:.0}; {} iterations, converged {}",
            t0 * 1e3,
            r0,
            t1 * 1e3,
            r1,
            t2 * 1e3,
            r2,
            pts0 * 1e3,
            with.point_rms() * 1e3,
            dir0,
            dir1,
            dir2,
            result.initial_cost,
            result.final_cost,
            result.iterations,
            result.converged
        );
        assert!(result.final_cost < 0.05 * result.initial_cost);
        assert!(t1 < 0.008 && r1 < 0.2, "poses {t1} m {r1} deg");
        assert!(
            t2 < 0.008 && r2 < 0.2,
            "poses without structure {t2} m {r2} deg"
        );
        assert!(t1 < 0.3 * t0, "poses improve: {t0} -> {t1} m");
        assert!(dir1 < 0.05, "structural + Manhattan: {dir1} deg");
        assert!(dir1 < 0.3 * dir2, "structure helps: {dir1} vs {dir2} deg");
        assert!(dir3 < 0.5 * dir2, "pairs alone help: {dir3} vs {dir2} deg");
        let rejected = plain
            .inliers
            .point_observations
            .iter()
            .filter(|f| !**f)
            .count();
        assert!((rejected as f64) < 0.08 * plain.inliers.point_observations.len() as f64);
    }
}

#[test]
fn flags_outlier_observations_and_a_wrong_parallel_pair() {
    let mut spec = spec();
    spec.outlier_ratio = 0.05;
    let mut scene = BaScene::new(&spec, &mut Rng::new(11));
    // Lines 0 and 1 have perpendicular axes: declaring them parallel is wrong.
    scene.problem.parallel.push((0, 1));
    let wrong = scene.problem.parallel.len() - 1;
    let result = run(&mut scene, &BaConfig::default());
    assert!(!result.inliers.parallel[wrong], "the wrong pair is flagged");
    let good_pairs = result.inliers.parallel[..wrong]
        .iter()
        .filter(|f| **f)
        .count();
    assert_eq!(good_pairs, wrong, "true pairs stay inliers");
    let (t, r) = scene.max_pose_error();
    let flagged = result
        .inliers
        .point_observations
        .iter()
        .filter(|f| !**f)
        .count();
    let total = result.inliers.point_observations.len();
    println!(
        "5 % outliers: poses {:.2} mm {:.3} deg, {flagged} of {total} flagged",
        t * 1e3,
        r
    );
    // Outliers removal leaves some points with one 2D observation: weaker than clean.
    assert!(t < 0.02 && r < 0.3, "{t} m {r} deg");
    // About 5 % outliers plus about 5 % of true inliers beyond the 95 % quantile.
    assert!((flagged as f64) > 0.05 * total as f64 && (flagged as f64) < 0.13 * total as f64);
    assert!(scene.mean_line_direction_error() < 0.05);
}

#[test]
fn invalid_problems_are_errors() {
    let mut scene = BaScene::new(
        &BaSceneSpec {
            points: 20,
            lines: 6,
            ..spec()
        },
        &mut Rng::new(3),
    );
    let mut adjuster = LocalBundleAdjuster::new();
    let mut result = BaResult::default();
    let mut bad = scene.problem.clone();
    bad.point_observations[3].point = 999;
    let err = adjuster
        .optimize(&mut bad, &BaConfig::default(), &mut result)
        .unwrap_err();
    assert_eq!(
        err,
        BaError::IndexOutOfRange {
            list: "point_observations",
            entry: 3,
            field: "point",
            index: 999,
            len: 20
        }
    );
    let mut bad = scene.problem.clone();
    bad.poses.iter_mut().for_each(|p| p.fixed = false);
    let err = adjuster
        .optimize(&mut bad, &BaConfig::default(), &mut result)
        .unwrap_err();
    assert_eq!(err, BaError::NoFixedPose { poses: 8 });
    let mut bad = scene.problem.clone();
    bad.lines[2][1].x = f64::NAN;
    let err = adjuster
        .optimize(&mut bad, &BaConfig::default(), &mut result)
        .unwrap_err();
    assert_eq!(
        err,
        BaError::NonFinite {
            list: "lines",
            entry: 2
        }
    );
    // All poses fixed: only landmarks move, no reduced system at all.
    scene.problem.poses.iter_mut().for_each(|p| p.fixed = true);
    scene.problem.parallel.clear();
    scene.problem.perpendicular.clear();
    adjuster
        .optimize(&mut scene.problem, &BaConfig::default(), &mut result)
        .expect("valid");
    assert!(result.final_cost < result.initial_cost);
}

#[test]
fn edge_cases_do_not_fail() {
    let mut adjuster = LocalBundleAdjuster::new();
    let mut result = BaResult::default();
    // Empty problem.
    let mut empty = gfs_optim::BaProblem::new(common::camera());
    adjuster
        .optimize(&mut empty, &BaConfig::default(), &mut result)
        .expect("empty is valid");
    assert_eq!(result.iterations, 0);
    // A pair listed twice, a line paired with itself, a line with no observation but
    // structural terms, and a point with no observation.
    let mut scene = BaScene::new(
        &BaSceneSpec {
            points: 40,
            lines: 9,
            ..spec()
        },
        &mut Rng::new(5),
    );
    let p = &mut scene.problem;
    p.parallel.push(p.parallel[0]);
    p.perpendicular.push((4, 4));
    p.lines.push([
        nalgebra::Vector3::new(0.0, 0.0, 3.0),
        nalgebra::Vector3::new(0.1, 0.5, 3.0),
    ]);
    let lonely = p.lines.len() - 1;
    p.parallel.push((lonely, 1));
    p.points.push(nalgebra::Vector3::new(0.0, 0.0, 2.0));
    adjuster
        .optimize(&mut scene.problem, &BaConfig::default(), &mut result)
        .expect("valid");
    assert!(
        !result.inliers.perpendicular[scene.problem.perpendicular.len() - 1],
        "self pair"
    );
    assert!(result.final_cost < result.initial_cost);
    // The unobserved line is pulled towards its partner's direction (axis y).
    let l = scene.problem.lines[lonely];
    let angle = common::direction_error_deg(&l, &common::AXES[1]);
    assert!(angle < 1.0, "{angle} deg");
    assert_eq!(
        scene.problem.points[40],
        nalgebra::Vector3::new(0.0, 0.0, 2.0)
    );
}

#[test]
fn a_depth_prior_holds_lines_where_depth_measured_them() {
    let mut with = BaScene::new(&spec(), &mut Rng::new(11));
    let mut without = BaScene::new(&spec(), &mut Rng::new(11));
    // Every line starts 15 % deeper along the rays of the first keyframe, the error
    // that the image of a nearby keyframe hardly sees.
    for scene in [&mut with, &mut without] {
        let first = scene.true_poses[0];
        for (line, truth) in scene.problem.lines.iter_mut().zip(&scene.true_lines) {
            for (end, true_end) in line.iter_mut().zip(truth) {
                let in_camera = first * nalgebra::Point3::from(*true_end);
                *end = (first.inverse() * nalgebra::Point3::from(in_camera.coords * 1.15)).coords;
            }
        }
    }
    let first = with.true_poses[0];
    for (k, truth) in with.true_lines.iter().enumerate() {
        let depth = truth.map(|e| (first * nalgebra::Point3::from(e)).z);
        with.problem.line_priors.push(gfs_optim::BaLinePrior {
            line: k,
            endpoints: *truth,
            // 2 cm sigma at every depth.
            information: depth.map(|_| 1.0 / (0.02 * 0.02)),
        });
    }
    run(&mut with, &BaConfig::default());
    run(&mut without, &BaConfig::default());
    let mean_error = |scene: &BaScene| {
        let sum: f64 = scene
            .problem
            .lines
            .iter()
            .zip(&scene.true_lines)
            .map(|(l, t)| ((l[0] - t[0]).norm() + (l[1] - t[1]).norm()) / 2.0)
            .sum();
        sum / scene.true_lines.len() as f64
    };
    let (e_with, e_without) = (mean_error(&with), mean_error(&without));
    println!("mean endpoint error: {e_with:.4} m with the prior, {e_without:.4} m without");
    assert!(e_with < 0.01, "with the prior: {e_with} m");
    assert!(
        e_with < 0.5 * e_without,
        "{e_with} m with, {e_without} m without"
    );
    // An out-of-range or non-finite prior is refused.
    let mut bad = BaScene::new(&spec(), &mut Rng::new(12));
    let n = bad.problem.lines.len();
    bad.problem.line_priors.push(gfs_optim::BaLinePrior {
        line: n,
        endpoints: bad.true_lines[0],
        information: [1.0, 1.0],
    });
    let error = LocalBundleAdjuster::new()
        .optimize(
            &mut bad.problem,
            &BaConfig::default(),
            &mut BaResult::default(),
        )
        .unwrap_err();
    assert!(
        matches!(
            error,
            BaError::IndexOutOfRange {
                list: "line_priors",
                ..
            }
        ),
        "{error}"
    );
}

#[test]
fn an_interrupted_optimisation_keeps_its_best_iterate() {
    let initial = BaScene::new(&spec(), &mut Rng::new(4));
    let mut full = BaScene::new(&spec(), &mut Rng::new(4));
    let complete = run(&mut full, &BaConfig::default());
    assert!(!complete.interrupted && complete.iterations > 3);

    // Stop before the fourth iteration: the first pass ends there, the second is skipped.
    for allowed in [0, 3] {
        let mut scene = BaScene::new(&spec(), &mut Rng::new(4));
        let asked = std::cell::Cell::new(0usize);
        let stop = || {
            asked.set(asked.get() + 1);
            asked.get() > allowed
        };
        let mut result = BaResult::default();
        LocalBundleAdjuster::new()
            .optimize_until(&mut scene.problem, &BaConfig::default(), &mut result, &stop)
            .expect("valid problem");
        assert!(result.interrupted && !result.converged);
        assert_eq!(result.iterations, allowed);
        assert_eq!(asked.get(), allowed + 1, "asked once per iteration");
        let (t0, _) = initial.max_pose_error();
        let (t, _) = scene.max_pose_error();
        let (tf, _) = full.max_pose_error();
        println!("stopped after {allowed}: pose error {t:.4} m (start {t0:.4}, full {tf:.4})");
        if allowed == 0 {
            assert_eq!(t, t0, "no iteration: the problem is unchanged");
        } else {
            assert!(result.final_cost < result.initial_cost);
            assert!(t < t0, "three iterations already lower the pose error");
        }
        assert!(
            result
                .inliers
                .point_observations
                .iter()
                .filter(|f| **f)
                .count()
                > 100,
            "inliers classified"
        );
    }
}

/// One adjuster reused over problems of other patterns (more line pairs, fewer
/// keyframes) and of the same pattern gives what a fresh adjuster gives: the symbolic
/// analysis it keeps is redone whenever the reduced system's pattern changes.
#[test]
fn a_reused_adjuster_matches_a_fresh_one() {
    let specs = [
        spec(),
        spec(),
        BaSceneSpec {
            partners: 3,
            ..spec()
        },
        BaSceneSpec {
            keyframes: 6,
            ..spec()
        },
        spec(),
    ];
    let mut reused = LocalBundleAdjuster::new();
    for (k, spec) in specs.iter().enumerate() {
        let mut kept = BaScene::new(spec, &mut Rng::new(21));
        let mut fresh = BaScene::new(spec, &mut Rng::new(21));
        let mut result = BaResult::default();
        reused
            .optimize(&mut kept.problem, &BaConfig::default(), &mut result)
            .expect("valid problem");
        let expected = run(&mut fresh, &BaConfig::default());
        assert_eq!(result.iterations, expected.iterations, "problem {k}");
        for (a, b) in kept.problem.poses.iter().zip(&fresh.problem.poses) {
            assert_eq!(a.camera_from_world, b.camera_from_world, "problem {k}");
        }
        assert_eq!(kept.problem.lines, fresh.problem.lines, "problem {k}");
    }
}

/// A pass ends once a step moves no free pose by `settled_step_m` / `settled_step_rad`:
/// fewer iterations than iterating until the cost stops falling, and the same poses
/// to well within their accuracy.
#[test]
fn a_pass_ends_once_its_poses_settle() {
    let until_the_cost_stops = BaConfig {
        settled_step_m: 0.0,
        settled_step_rad: 0.0,
        ..BaConfig::default()
    };
    for seed in 0..3 {
        let mut settled = BaScene::new(&spec(), &mut Rng::new(seed));
        let mut strict = BaScene::new(&spec(), &mut Rng::new(seed));
        let quick = run(&mut settled, &BaConfig::default());
        let full = run(&mut strict, &until_the_cost_stops);
        let (apart_m, apart_deg) = settled.max_pose_difference(&strict);
        println!(
            "seed {seed}: {} -> {} iterations, poses apart by {:.4} mm {:.5} deg, cost {:.3} \
             -> {:.3}, points rms {:.3} -> {:.3} mm",
            full.iterations,
            quick.iterations,
            apart_m * 1e3,
            apart_deg,
            full.final_cost,
            quick.final_cost,
            strict.point_rms() * 1e3,
            settled.point_rms() * 1e3
        );
        assert!(quick.converged);
        assert!(quick.iterations < full.iterations);
        assert!(
            apart_m < 1e-4 && apart_deg < 1e-4f64.to_degrees(),
            "{apart_m} m {apart_deg} deg"
        );
        // The points are left where the settled poses put them, a step or two short.
        assert!(quick.final_cost < full.final_cost * 1.001);
        assert!(settled.point_rms() < strict.point_rms() * 1.01);
    }
}
