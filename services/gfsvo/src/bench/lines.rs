//! `gfsvo bench lines DATASET`: per-step timings of the line front end
//! ([`gfs_lines::LineExtractor`]) over the frames of a dataset, single-threaded, plus the
//! line counts before and after homogenisation. With `--image-out`, the lines of frame
//! `--image-frame` are drawn into a PNG: before homogenisation on the left (red), after
//! on the right (green).
//!
//! Each frame is extracted [`REPEATS`] times and every step keeps its fastest time: on
//! a loaded machine a step that happens to be preempted would otherwise report the time
//! spent waiting for a core. The single-run (first, cold-cache) total is reported too.

use super::BenchArgs;
use super::stats::Summary;
use crate::CliResult;
use crate::config::Config;
use gfs_dataset::Sequence;
use gfs_lines::{DetectedLine, LineExtractor, LineFeatures};
use serde_json::json;
use std::path::Path;
use std::time::Duration;

/// Names of the timed steps, in pipeline order (also the JSON keys).
const STEPS: [&str; 5] = ["detect", "join", "homogenise", "lbd", "lines3d"];

/// Extractions per frame; each step keeps its fastest.
const REPEATS: usize = 3;

/// Runs the lines benchmark.
///
/// # Errors
/// Config, dataset and frame decoding errors; an image that cannot be written.
pub fn run(args: &BenchArgs) -> CliResult {
    let config = Config::load(args.config.as_deref(), &args.dataset)?;
    let camera = config.camera()?;
    let sequence = Sequence::open(&args.dataset, &camera, &config.depth)?;
    let mut extractor = LineExtractor::new(config.lines.clone());
    let mut features = LineFeatures::default();
    let mut steps: [Vec<f64>; 5] = Default::default();
    let mut total = Vec::new();
    let mut first_total = Vec::new();
    let (mut detected, mut kept, mut valid3d) = (0usize, 0usize, 0usize);
    // (min, max) per frame, to show how the adaptive target follows the scene.
    let (mut detected_range, mut kept_range) = ((usize::MAX, 0), (usize::MAX, 0));
    let mut image_written = false;
    for (k, frame) in sequence.frames(args.frames).enumerate() {
        let frame = frame?;
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        let mut fastest = [f64::INFINITY; 5];
        for repeat in 0..REPEATS {
            extractor.extract(
                &frame.gray.view(),
                &frame.depth.view(),
                &camera.pinhole,
                &mut features,
            );
            let t = extractor.timings();
            if repeat == 0 {
                first_total.push(ms(t.total()));
            }
            for (best, d) in
                fastest
                    .iter_mut()
                    .zip([t.detect, t.join, t.homogenise, t.lbd, t.lines3d])
            {
                *best = best.min(ms(d));
            }
        }
        for (samples, best) in steps.iter_mut().zip(fastest) {
            samples.push(best);
        }
        total.push(fastest.iter().sum());
        let counts = extractor.counts();
        detected += counts.detected;
        kept += counts.kept;
        detected_range = (
            detected_range.0.min(counts.detected),
            detected_range.1.max(counts.detected),
        );
        kept_range = (kept_range.0.min(counts.kept), kept_range.1.max(counts.kept));
        valid3d += features.lines3d.iter().filter(|l| l.is_valid()).count();
        if let Some(path) = &args.image_out
            && k == args.image_frame
        {
            write_lines_png(
                path,
                &frame.gray,
                extractor.detected_lines(),
                &features.lines,
            )?;
            image_written = true;
        }
    }
    let frames = total.len();
    if frames == 0 {
        return Err(format!("no frame read from {}", args.dataset.display()).into());
    }
    if let Some(path) = &args.image_out
        && !image_written
    {
        return Err(format!(
            "--image-frame {} is beyond the {frames} frames read; {} not written",
            args.image_frame,
            path.display()
        )
        .into());
    }
    // Detection + joining + LBD + homogenisation, the part the issue budgets (6 ms);
    // summed per frame before `Summary::of` reorders the samples.
    let mut front: Vec<f64> = (0..frames)
        .map(|i| steps[0][i] + steps[1][i] + steps[2][i] + steps[3][i])
        .collect();
    let summaries: Vec<Summary> = steps.iter_mut().map(|s| Summary::of(s)).collect();
    let front = Summary::of(&mut front);
    let total = Summary::of(&mut total);
    let first_total = Summary::of(&mut first_total);
    let mean = |n: usize| n as f64 / frames as f64;
    let scheme = format!("{:?}", config.lines.homogenise.scheme).to_lowercase();
    if args.json {
        let mut step_json = serde_json::Map::new();
        for (name, s) in STEPS.iter().zip(&summaries) {
            step_json.insert((*name).to_owned(), json!(s));
        }
        let out = json!({
            "dataset": args.dataset.display().to_string(),
            "frames": frames,
            "homogenise_scheme": scheme,
            "total_ms_median": total.median,
            "total_ms_p90": total.p90,
            "detect_join_lbd_homogenise_ms_median": front.median,
            "steps_ms": step_json,
            "total_ms": total,
            "single_run_total_ms": first_total,
            "lines_before_homogenise_mean": mean(detected),
            "lines_after_homogenise_mean": mean(kept),
            "lines_before_homogenise_min_max": [detected_range.0, detected_range.1],
            "lines_after_homogenise_min_max": [kept_range.0, kept_range.1],
            "lines3d_valid_mean": mean(valid3d),
        });
        println!("{out}");
    } else {
        println!(
            "lines on {} ({frames} frames, one thread, fastest of {REPEATS} runs per step, \
             homogenisation: {scheme})",
            args.dataset.display()
        );
        println!("{:<34} {:>9} {:>9}", "step", "median ms", "p90 ms");
        for (name, s) in STEPS.iter().zip(&summaries) {
            println!("{name:<34} {:>9.3} {:>9.3}", s.median, s.p90);
        }
        println!(
            "{:<34} {:>9.3} {:>9.3}",
            "detect+join+homogenise+lbd", front.median, front.p90
        );
        println!("{:<34} {:>9.3} {:>9.3}", "total", total.median, total.p90);
        println!(
            "{:<34} {:>9.3} {:>9.3}",
            "total, single cold run", first_total.median, first_total.p90
        );
        println!(
            "lines per frame: {:.1} before homogenisation ({}..{}), {:.1} after ({}..{}), \
             {:.1} with a valid 3D line",
            mean(detected),
            detected_range.0,
            detected_range.1,
            mean(kept),
            kept_range.0,
            kept_range.1,
            mean(valid3d)
        );
    }
    Ok(())
}

/// Writes `gray` twice side by side: `before` drawn in red on the left, `after` in
/// green on the right.
fn write_lines_png(
    path: &Path,
    gray: &gfs_core::GrayImage,
    before: &[DetectedLine],
    after: &[DetectedLine],
) -> CliResult {
    let (w, h) = (gray.width(), gray.height());
    let stride = 2 * w;
    let mut rgb = vec![0u8; 3 * stride * h];
    for y in 0..h {
        for (x, &g) in gray.row(y).iter().enumerate() {
            for offset in [x, x + w] {
                let i = 3 * (y * stride + offset);
                rgb[i..i + 3].copy_from_slice(&[g, g, g]);
            }
        }
    }
    let mut draw = |lines: &[DetectedLine], x_offset: usize, colour: [u8; 3]| {
        for l in lines {
            let s = &l.segment;
            let steps = s.length().ceil().max(1.0) as usize;
            for k in 0..=steps {
                let t = k as f32 / steps as f32;
                let u = (s.start[0] + t * (s.end[0] - s.start[0])).round();
                let v = (s.start[1] + t * (s.end[1] - s.start[1])).round();
                if u >= 0.0 && v >= 0.0 && (u as usize) < w && (v as usize) < h {
                    let i = 3 * (v as usize * stride + u as usize + x_offset);
                    rgb[i..i + 3].copy_from_slice(&colour);
                }
            }
        }
    };
    draw(before, 0, [255, 40, 40]);
    draw(after, w, [40, 255, 40]);
    image::save_buffer(
        path,
        &rgb,
        stride as u32,
        h as u32,
        image::ExtendedColorType::Rgb8,
    )
    .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    Ok(())
}
