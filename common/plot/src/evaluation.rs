//! The evaluation figure: top view of the ground truth and the aligned estimate (left)
//! and the ATE of each matched pose over time (right).

use crate::canvas::{
    Area, MIN_SIDE, PlotConfig, PlotError, chart, draw_legend, draw_mesh, plot_size, polyline,
    range_of, render, rgb, save_png, swatch, titled, widened,
};
use gfs_dataset::Evaluation;
use image::RgbImage;
use plotters::prelude::*;
use std::path::Path;

const GT_COLOR: [u8; 3] = [31, 100, 200];
const EST_COLOR: [u8; 3] = [235, 110, 20];
const ERROR_COLOR: [u8; 3] = [200, 30, 30];
const AXIS_NAMES: [&str; 3] = ["x", "y", "z"];

/// Indices of the two position axes with the largest extent over both trajectories,
/// in axis order (x-y for a level ground-truth frame).
fn top_view_axes(eval: &Evaluation) -> (usize, usize) {
    let extent: [f64; 3] = std::array::from_fn(|axis| {
        let values = eval
            .gt_matched
            .poses()
            .iter()
            .chain(eval.est_aligned.poses())
            .map(|p| p.translation.vector[axis]);
        range_of(values, 0.0, 0.0).map_or(0.0, |r| r.1 - r.0)
    });
    let smallest = (0..3)
        .min_by(|&a, &b| extent[a].total_cmp(&extent[b]))
        .unwrap_or(2);
    match smallest {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    }
}

/// Renders the evaluation figure.
///
/// # Errors
/// [`PlotError::TooSmall`] when the configured size has no room for the panels.
pub fn render_evaluation(eval: &Evaluation, config: &PlotConfig) -> Result<RgbImage, PlotError> {
    let half = u32::try_from(config.width / 2).unwrap_or(u32::MAX);
    let lw = config.line_width.max(1) as u32;
    render(config, 2 * MIN_SIDE, |root| {
        let (left, right) = root.split_horizontally(half);
        top_view(&left, eval, lw)?;
        error_over_time(&right, eval, lw)
    })
}

/// Both trajectories with equal scales on both axes, the start marked.
fn top_view(area: &Area, eval: &Evaluation, lw: u32) -> Result<(), PlotError> {
    let (ax, ay) = top_view_axes(eval);
    let project = |poses: &[nalgebra::Isometry3<f64>]| -> Vec<(f64, f64)> {
        poses
            .iter()
            .map(|p| (p.translation.vector[ax], p.translation.vector[ay]))
            .collect()
    };
    let gt = project(eval.gt_matched.poses());
    let est = project(eval.est_aligned.poses());
    let area = titled(area, "Top view (aligned)")?;
    let (pw, ph) = plot_size(&area);
    let all = || gt.iter().chain(&est);
    let x = range_of(all().map(|p| p.0), 0.1, 0.05).unwrap_or((-1.0, 1.0));
    let y = range_of(all().map(|p| p.1), 0.1, 0.05).unwrap_or((-1.0, 1.0));
    let metres_per_px = ((x.1 - x.0) / pw).max((y.1 - y.0) / ph);
    let mut chart = chart(
        &area,
        widened(x, metres_per_px * pw),
        widened(y, metres_per_px * ph),
    )?;
    draw_mesh(
        &mut chart,
        &format!("{} (m)", AXIS_NAMES[ax]),
        &format!("{} (m)", AXIS_NAMES[ay]),
    )?;
    for (points, color, label) in [
        (&gt, GT_COLOR, "ground truth"),
        (&est, EST_COLOR, "estimate"),
    ] {
        polyline(&mut chart, points, rgb(color).stroke_width(lw))?
            .label(label)
            .legend(swatch(rgb(color)));
    }
    if let Some(&start) = gt.first() {
        chart.draw_series(std::iter::once(Circle::new(
            start,
            3 * lw + 2,
            rgb(GT_COLOR).filled(),
        )))?;
    }
    draw_legend(&mut chart)
}

/// The ATE of each matched pose over time, with its RMSE dashed.
fn error_over_time(area: &Area, eval: &Evaluation, lw: u32) -> Result<(), PlotError> {
    let stats = &eval.ate.stats;
    let area = titled(
        area,
        &format!(
            "ATE over time ({} matched, max {:.4} m)",
            eval.matched(),
            stats.max
        ),
    )?;
    let times = eval.est_aligned.timestamps();
    let t0 = times.first().copied().unwrap_or_default();
    let errors: Vec<(f64, f64)> = times
        .iter()
        .zip(&eval.ate.errors_m)
        .map(|(t, e)| (t.secs_since(t0), *e))
        .collect();
    let t = range_of(errors.iter().map(|p| p.0), 1e-3, 0.0).unwrap_or((0.0, 1.0));
    let t = (t.0.max(0.0), t.1);
    let mut chart = chart(&area, t, (0.0, 1.1 * stats.max.max(1e-6)))?;
    draw_mesh(&mut chart, "time (s)", "ATE (m)")?;
    polyline(&mut chart, &errors, rgb(ERROR_COLOR).stroke_width(lw))?
        .label("ATE of each pose")
        .legend(swatch(rgb(ERROR_COLOR)));
    let ink = crate::canvas::INK;
    chart
        .draw_series(DashedLineSeries::new(
            [(t.0, stats.rmse), (t.1, stats.rmse)],
            8,
            6,
            ink.stroke_width(1),
        ))?
        .label(format!("RMSE {:.4} m", stats.rmse))
        .legend(move |(x, y)| {
            plotters::element::DashedPathElement::new(vec![(x, y), (x + 24, y)], 5, 3, ink)
        });
    draw_legend(&mut chart)
}

/// Renders the evaluation figure and writes it as a PNG.
///
/// # Errors
/// [`PlotError::TooSmall`], or [`PlotError::Write`] naming the file that could not be
/// encoded or written.
pub fn write_evaluation_png(
    eval: &Evaluation,
    path: &Path,
    config: &PlotConfig,
) -> Result<(), PlotError> {
    save_png(&render_evaluation(eval, config)?, path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use gfs_core::stamp::Stamp;
    use gfs_dataset::{EVO_MAX_DIFF_S, Trajectory, evaluate};
    use nalgebra::Isometry3;

    fn circle_eval() -> Evaluation {
        let (mut gt, mut est) = (Trajectory::new(), Trajectory::new());
        for k in 0..100 {
            let a = k as f64 * 0.05;
            let t = Stamp::from_nanos(k * 50_000_000);
            gt.push(t, Isometry3::translation(a.cos(), a.sin(), 0.0));
            est.push(t, Isometry3::translation(1.05 * a.cos(), a.sin(), 0.01 * a));
        }
        evaluate(&gt, &est, EVO_MAX_DIFF_S).unwrap()
    }

    /// Pixels of exactly `color` in columns `x_from..x_to`.
    fn count(image: &RgbImage, color: [u8; 3], x_from: u32, x_to: u32) -> usize {
        image
            .enumerate_pixels()
            .filter(|(x, _, p)| (x_from..x_to).contains(x) && p.0 == color)
            .count()
    }

    #[test]
    fn the_figure_draws_both_trajectories_and_the_error() {
        let image = render_evaluation(&circle_eval(), &PlotConfig::default()).unwrap();
        assert_eq!(image.dimensions(), (1400, 640));
        // A unit circle over ~480 px is ~1500 px long; a 2-px line covers > 2000 px.
        let gt = count(&image, GT_COLOR, 0, 700);
        assert!(gt > 2000, "{gt}");
        assert!(count(&image, EST_COLOR, 0, 700) > 2000);
        // 100 poses over ~550 px, 2 px wide.
        let error = count(&image, ERROR_COLOR, 700, 1400);
        assert!(error > 500, "{error}");
        // The trajectories are in the left half, the error curve in the right half.
        assert_eq!(count(&image, GT_COLOR, 700, 1400), 0);
        assert_eq!(count(&image, ERROR_COLOR, 0, 700), 0);
    }

    #[test]
    fn the_top_view_has_equal_scales() {
        // A square path 1 m x 0.25 m: drawn as a square of pixels in x and y ratio 4:1.
        let (mut gt, mut est) = (Trajectory::new(), Trajectory::new());
        let corners = [(0.0, 0.0), (1.0, 0.0), (1.0, 0.25), (0.0, 0.25), (0.0, 0.0)];
        for (k, w) in corners.windows(2).enumerate() {
            for s in 0..50 {
                let f = f64::from(s) / 50.0;
                let (x, y) = (
                    w[0].0 + f * (w[1].0 - w[0].0),
                    w[0].1 + f * (w[1].1 - w[0].1),
                );
                let t = Stamp::from_nanos((k as i64 * 50 + i64::from(s)) * 30_000_000);
                gt.push(t, Isometry3::translation(x, y, 0.0));
                est.push(t, Isometry3::translation(x, y, 0.0));
            }
        }
        let eval = evaluate(&gt, &est, EVO_MAX_DIFF_S).unwrap();
        let image = render_evaluation(&eval, &PlotConfig::default()).unwrap();
        // The estimate hides the ground truth: its orange pixels span the rectangle.
        let (mut xs, mut ys) = (Vec::new(), Vec::new());
        for (x, y, p) in image.enumerate_pixels() {
            if x < 700 && p.0 == EST_COLOR && y > 100 {
                xs.push(x);
                ys.push(y);
            }
        }
        let span = |v: &[u32]| v.iter().max().unwrap() - v.iter().min().unwrap();
        let ratio = f64::from(span(&xs)) / f64::from(span(&ys));
        assert!((ratio - 4.0).abs() < 0.2, "{ratio}");
    }

    #[test]
    fn writes_a_png_and_rejects_tiny_sizes() {
        let eval = circle_eval();
        let path = std::env::temp_dir().join(format!("gfs_plot_{}.png", std::process::id()));
        write_evaluation_png(&eval, &path, &PlotConfig::default()).unwrap();
        let back = image::open(&path).unwrap();
        assert_eq!((back.width(), back.height()), (1400, 640));
        std::fs::remove_file(&path).unwrap();
        let tiny = PlotConfig {
            width: 50,
            height: 50,
            line_width: 1,
        };
        assert!(matches!(
            render_evaluation(&eval, &tiny),
            Err(PlotError::TooSmall { .. })
        ));
        let bad = write_evaluation_png(
            &eval,
            Path::new("/nonexistent/dir/p.png"),
            &PlotConfig::default(),
        );
        assert!(matches!(bad, Err(PlotError::Write { .. })));
    }
}
