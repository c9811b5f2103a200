//! Timing of the pose optimisation and the local BA on synthetic problems (printed,
//! nothing asserted). Run with
//! `cargo run --release -p gfs-optim --example ba_bench`.

#[path = "../tests/common/mod.rs"]
mod common;

use common::{BaScene, BaSceneSpec, Rng, camera, perturb, pose_error, synthetic_frame};
use gfs_optim::{
    BaConfig, BaResult, LocalBundleAdjuster, PoseOptimizerConfig, PoseResult, optimize_pose,
};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

/// CPU time of this thread, nanoseconds: the machine the benchmark runs on may be
/// shared, and CPU time is what a dedicated core would take.
fn cpu_ns() -> u64 {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `t` is a valid, writable timespec for the duration of the call.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut t) };
    if rc != 0 {
        return 0;
    }
    t.tv_sec as u64 * 1_000_000_000 + t.tv_nsec as u64
}

fn median_ms(mut samples: Vec<f64>) -> f64 {
    samples.sort_by(f64::total_cmp);
    samples[samples.len() / 2]
}

fn bench_pose() {
    let camera = camera();
    let truth = Isometry3::from_parts(
        Translation3::new(0.3, -0.2, 0.5),
        UnitQuaternion::from_scaled_axis(Vector3::new(0.1, -0.3, 0.05)),
    );
    let config = PoseOptimizerConfig::default();
    let mut result = PoseResult::default();
    let mut times = Vec::new();
    let mut worst = (0.0f64, 0.0f64);
    let mut iterations = 0;
    for seed in 0..200 {
        let mut rng = Rng::new(seed);
        let frame = synthetic_frame(&camera, &truth, 300, 60, 0.2, true, &mut rng);
        let initial = perturb(&truth, 0.02, 1f64.to_radians(), &mut rng);
        let start = cpu_ns();
        optimize_pose(
            &camera,
            &initial,
            &frame.points,
            &frame.lines,
            &config,
            &mut result,
        );
        times.push((cpu_ns() - start) as f64 * 1e-6);
        let (dt, dr) = pose_error(&result.camera_from_world, &truth);
        worst = (worst.0.max(dt), worst.1.max(dr));
        iterations += result.iterations;
    }
    println!(
        "pose optimisation, 300 points + 60 lines, 20 % outliers, 200 frames: median {:.3} ms \
         CPU, max {:.3} ms, mean {:.1} LM iterations, worst error {:.2} mm {:.3} deg",
        median_ms(times.clone()),
        times.iter().cloned().fold(0.0, f64::max),
        iterations as f64 / 200.0,
        worst.0 * 1e3,
        worst.1
    );
}

fn bench_ba(
    keyframes: usize,
    points: usize,
    lines: usize,
    partners: usize,
    track_window: usize,
    runs: u64,
) {
    let spec = BaSceneSpec {
        keyframes,
        points,
        lines,
        fixed: 2,
        track_window,
        partners,
        outlier_ratio: 0.02,
        depth_range: 3.2,
    };
    let mut adjuster = LocalBundleAdjuster::new();
    let mut result = BaResult::default();
    let mut times = Vec::new();
    let mut summary = String::new();
    let track = if track_window == 0 {
        "all keyframes".to_string()
    } else {
        format!("<= {track_window} keyframes")
    };
    for seed in 0..runs {
        let mut scene = BaScene::new(&spec, &mut Rng::new(seed));
        let start = cpu_ns();
        adjuster
            .optimize(&mut scene.problem, &BaConfig::default(), &mut result)
            .expect("valid problem");
        times.push((cpu_ns() - start) as f64 * 1e-6);
        if seed == 0 {
            let (dt, dr) = scene.max_pose_error();
            summary = format!(
                "{} point obs, {} line obs, {} parallel, {} perpendicular, {} manhattan; \
                 {} iterations, {} solves; pose error {:.2} mm {:.3} deg",
                scene.problem.point_observations.len(),
                scene.problem.line_observations.len(),
                scene.problem.parallel.len(),
                scene.problem.perpendicular.len(),
                scene.problem.manhattan.len(),
                result.iterations,
                result.linear_solves,
                dt * 1e3,
                dr
            );
        }
    }
    println!(
        "local BA, {keyframes} keyframes / {points} points / {lines} lines, {partners} parallel + \
         {partners} perpendicular partners per line, tracks {track}: median {:.1} ms CPU over {runs} runs ({summary})",
        median_ms(times)
    );
}

fn main() {
    if let Some(partners) = std::env::args().nth(1).and_then(|a| a.parse().ok()) {
        bench_ba(10, 1500, 200, partners, 0, 5);
        return;
    }
    bench_pose();
    bench_ba(10, 1500, 200, 0, 0, 5);
    bench_ba(10, 1500, 200, 2, 0, 5);
    bench_ba(10, 1500, 200, 6, 0, 5);
    bench_ba(10, 1500, 200, 0, 4, 5);
    bench_ba(10, 1500, 200, 2, 4, 5);
    bench_ba(20, 3000, 300, 2, 4, 3);
}
