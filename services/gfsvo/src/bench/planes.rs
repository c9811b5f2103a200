//! `gfsvo bench planes DATASET`: per-step timings of the planes stage
//! ([`gfs_planes::PlaneExtractor`] and [`gfs_planes::ManhattanEstimator`]) over the
//! frames of a dataset, single-threaded, plus the planes and Manhattan axes found.
//!
//! The Manhattan axes here use the plane normals only: the 3D line directions come from
//! the lines stage, which this benchmark does not run (`gfsvo bench lines` times it), and
//! no predicted rotation is given (identity), as for a stage without a tracker.

use super::BenchArgs;
use super::stats::Summary;
use crate::CliResult;
use crate::config::Config;
use gfs_dataset::Sequence;
use gfs_planes::{ManhattanEstimator, PlaneExtractor};
use serde_json::json;
use std::time::{Duration, Instant};

/// Names of the timed steps, in pipeline order (also the JSON keys).
const STEPS: [&str; 3] = ["normals", "bfs", "ma"];

/// Runs the planes benchmark.
///
/// # Errors
/// Config (including an invalid `[planes]` table), dataset and frame decoding errors.
pub fn run(args: &BenchArgs) -> CliResult {
    let config = Config::load(args.config.as_deref(), &args.dataset)?;
    let camera = config.camera()?;
    let sequence = Sequence::open(&args.dataset, &camera, &config.depth)?;
    let mut extractor = PlaneExtractor::new(&config.planes)?;
    let mut estimator = ManhattanEstimator::new(&config.planes)?;
    let mut planes = Vec::new();
    let mut steps: [Vec<f64>; 3] = Default::default();
    let mut total = Vec::new();
    let (mut plane_count, mut with_ma, mut with_two_axes) = (0usize, 0usize, 0usize);
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    for frame in sequence.frames(args.frames) {
        let frame = frame?;
        extractor.extract(&frame.depth.view(), &camera.pinhole, &mut planes)?;
        let ma_start = Instant::now();
        let axes = estimator.estimate(&planes, &[], &[], None);
        let ma_time = ma_start.elapsed();
        let t = extractor.timings();
        for (samples, d) in steps.iter_mut().zip([t.normals, t.regions, ma_time]) {
            samples.push(ms(d));
        }
        total.push(ms(t.normals + t.regions + ma_time));
        plane_count += planes.len();
        with_ma += usize::from(axes.is_some());
        with_two_axes += usize::from(axes.is_some_and(|a| a.observed_count() >= 2));
    }
    let frames = total.len();
    if frames == 0 {
        return Err(format!("no frame read from {}", args.dataset.display()).into());
    }
    let summaries: Vec<Summary> = steps.iter_mut().map(|s| Summary::of(s)).collect();
    let total = Summary::of(&mut total);
    let mean = |n: usize| n as f64 / frames as f64;
    let stride = config.planes.stride;
    if args.json {
        let mut step_json = serde_json::Map::new();
        for (name, s) in STEPS.iter().zip(&summaries) {
            step_json.insert((*name).to_owned(), json!(s));
        }
        let out = json!({
            "dataset": args.dataset.display().to_string(),
            "frames": frames,
            "stride": stride,
            "total_ms_median": total.median,
            "total_ms_p90": total.p90,
            "steps_ms": step_json,
            "total_ms": total,
            "planes_mean": mean(plane_count),
            "ma_fraction": mean(with_ma),
            "ma_two_axes_fraction": mean(with_two_axes),
            "ma_inputs": "plane normals only",
        });
        println!("{out}");
    } else {
        println!(
            "planes on {} ({frames} frames, one thread, stride {stride}, MA from plane normals only)",
            args.dataset.display()
        );
        println!("{:<24} {:>9} {:>9}", "step", "median ms", "p90 ms");
        for (name, s) in STEPS.iter().zip(&summaries) {
            println!("{name:<24} {:>9.3} {:>9.3}", s.median, s.p90);
        }
        println!("{:<24} {:>9.3} {:>9.3}", "total", total.median, total.p90);
        println!(
            "planes per frame: {:.2}; frames with MA: {:.1} % ({:.1} % with two or more observed axes)",
            mean(plane_count),
            100.0 * mean(with_ma),
            100.0 * mean(with_two_axes)
        );
    }
    Ok(())
}
