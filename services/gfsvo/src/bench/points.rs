//! `gfsvo bench points DATASET`: per-step timings of the ORB extractor
//! ([`gfs_points::OrbExtractor`]) over the frames of a dataset, single-threaded, with
//! the keypoint counts and the spatial coverage: the fraction of the cells of an 8x6
//! grid holding a FAST corner at the minimum threshold that also hold a feature, counting
//! corners anywhere, and only corners where a patch fits (`EDGE` pixels from the
//! border, where the extractor can put a feature).
//!
//! Each frame is extracted [`REPEATS`] times and every step keeps its fastest time: on
//! a loaded machine a step that happens to be preempted would otherwise report the time
//! spent waiting for a core. The single-run (first, cold-cache) total is reported too.

use super::BenchArgs;
use super::stats::Summary;
use crate::CliResult;
use crate::config::Config;
use gfs_core::GrayImage;
use gfs_dataset::Sequence;
use gfs_points::{Corner, EDGE, OrbExtractor, OrbFeatures, detect_fast};
use serde_json::json;
use std::time::Duration;

/// Names of the timed steps, in pipeline order (also the JSON keys).
const STEPS: [&str; 3] = ["pyramid", "fast_distribution", "orientation_descriptors"];

/// Extractions per frame; each step keeps its fastest.
const REPEATS: usize = 3;

/// The coverage grid (columns, rows).
const GRID: (usize, usize) = (8, 6);

/// Runs the points benchmark.
///
/// # Errors
/// Config (including an invalid `[points]` table), dataset and frame decoding errors.
pub fn run(args: &BenchArgs) -> CliResult {
    let config = Config::load(args.config.as_deref(), &args.dataset)?;
    let camera = config.camera()?;
    let sequence = Sequence::open(&args.dataset, &camera, &config.depth)?;
    let mut extractor = OrbExtractor::new(config.points.clone())?;
    let mut features = OrbFeatures::default();
    let mut corners = Vec::new();
    let mut steps: [Vec<f64>; 3] = Default::default();
    let mut total = Vec::new();
    let mut first_total = Vec::new();
    let (mut keypoints, mut with_depth) = (0usize, 0usize);
    let mut coverage = Vec::new();
    let mut coverage_inner = Vec::new();
    for frame in sequence.frames(args.frames) {
        let frame = frame?;
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        let mut fastest = [f64::INFINITY; 3];
        for repeat in 0..REPEATS {
            extractor.extract(frame.gray.view(), Some(frame.depth.view()), &mut features)?;
            let t = extractor.timings();
            if repeat == 0 {
                first_total.push(ms(t.total()));
            }
            for (best, d) in fastest.iter_mut().zip([t.pyramid, t.detect, t.describe]) {
                *best = best.min(ms(d));
            }
        }
        for (samples, best) in steps.iter_mut().zip(fastest) {
            samples.push(best);
        }
        total.push(fastest.iter().sum());
        keypoints += features.len();
        with_depth += features.keypoints.iter().filter(|k| k.depth > 0.0).count();
        let (all, inner) = covered_fraction(
            &frame.gray,
            &features,
            config.points.fast_min_threshold,
            &mut corners,
        );
        coverage.push(all);
        coverage_inner.push(inner);
    }
    let frames = total.len();
    if frames == 0 {
        return Err(format!("no frame read from {}", args.dataset.display()).into());
    }
    let summaries: Vec<Summary> = steps.iter_mut().map(|s| Summary::of(s)).collect();
    let total = Summary::of(&mut total);
    let first_total = Summary::of(&mut first_total);
    let lowest = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
    let (coverage_min, inner_min) = (lowest(&coverage), lowest(&coverage_inner));
    let coverage = Summary::of(&mut coverage);
    let inner = Summary::of(&mut coverage_inner);
    let mean = |n: usize| n as f64 / frames as f64;
    if args.json {
        let mut step_json = serde_json::Map::new();
        for (name, s) in STEPS.iter().zip(&summaries) {
            step_json.insert((*name).to_owned(), json!(s));
        }
        let out = json!({
            "dataset": args.dataset.display().to_string(),
            "frames": frames,
            "features": config.points.features,
            "levels": config.points.levels,
            "total_ms_median": total.median,
            "total_ms_p90": total.p90,
            "steps_ms": step_json,
            "total_ms": total,
            "single_run_total_ms": first_total,
            "keypoints_mean": mean(keypoints),
            "keypoints_with_depth_mean": mean(with_depth),
            "grid_coverage_mean": coverage.mean,
            "grid_coverage_min": coverage_min,
            "grid_coverage_inner_mean": inner.mean,
            "grid_coverage_inner_min": inner_min,
        });
        println!("{out}");
    } else {
        println!(
            "points on {} ({frames} frames, one thread, fastest of {REPEATS} runs per step, \
             {} features, {} levels)",
            args.dataset.display(),
            config.points.features,
            config.points.levels
        );
        println!("{:<34} {:>9} {:>9}", "step", "median ms", "p90 ms");
        for (name, s) in STEPS.iter().zip(&summaries) {
            println!("{name:<34} {:>9.3} {:>9.3}", s.median, s.p90);
        }
        println!("{:<34} {:>9.3} {:>9.3}", "total", total.median, total.p90);
        println!(
            "{:<34} {:>9.3} {:>9.3}",
            "total, single cold run", first_total.median, first_total.p90
        );
        println!(
            "keypoints per frame: {:.1}, {:.1} with depth",
            mean(keypoints),
            mean(with_depth)
        );
        println!(
            "{}x{} grid cells with a FAST corner at threshold {} that hold a feature: \
             {:.1} % mean, {:.1} % worst frame; counting only corners {EDGE} px or more \
             from the border: {:.1} % mean, {:.1} % worst frame",
            GRID.0,
            GRID.1,
            config.points.fast_min_threshold,
            100.0 * coverage.mean,
            100.0 * coverage_min,
            100.0 * inner.mean,
            100.0 * inner_min
        );
    }
    Ok(())
}

/// Fraction of the grid cells holding a FAST corner at `threshold` that also hold a
/// keypoint (1 when no cell has a corner): counting every corner, and counting only
/// corners at least `EDGE` pixels from the border.
fn covered_fraction(
    gray: &GrayImage,
    features: &OrbFeatures,
    threshold: u8,
    corners: &mut Vec<Corner>,
) -> (f64, f64) {
    let (w, h) = (gray.width(), gray.height());
    let cell = |u: f32, v: f32| {
        let cx = ((u / w as f32 * GRID.0 as f32) as usize).min(GRID.0 - 1);
        let cy = ((v / h as f32 * GRID.1 as f32) as usize).min(GRID.1 - 1);
        cy * GRID.0 + cx
    };
    corners.clear();
    detect_fast(gray.view(), threshold, corners);
    let mut has_corner = [false; GRID.0 * GRID.1];
    let mut has_inner_corner = [false; GRID.0 * GRID.1];
    for c in corners.iter() {
        let (x, y) = (c.x as usize, c.y as usize);
        let k = cell(x as f32, y as f32);
        has_corner[k] = true;
        if x >= EDGE && y >= EDGE && x + EDGE < w && y + EDGE < h {
            has_inner_corner[k] = true;
        }
    }
    let mut has_feature = [false; GRID.0 * GRID.1];
    for k in &features.keypoints {
        has_feature[cell(k.u, k.v)] = true;
    }
    let fraction = |wanted: &[bool]| {
        let n = wanted.iter().filter(|&&c| c).count();
        let covered = wanted
            .iter()
            .zip(&has_feature)
            .filter(|&(&c, &f)| c && f)
            .count();
        if n == 0 {
            1.0
        } else {
            covered as f64 / n as f64
        }
    };
    (fraction(&has_corner), fraction(&has_inner_corner))
}
