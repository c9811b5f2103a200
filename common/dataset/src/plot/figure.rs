//! The evaluation figure: top view (left) and ATE over time (right).

use super::axes::{Panel, Range, TEXT_SCALE};
use super::canvas::{Canvas, Rgb};
use crate::trajectory::Evaluation;
use gfs_core::RgbImage;
use serde::Deserialize;
use std::path::{Path, PathBuf};
use thiserror::Error;

const BACKGROUND: Rgb = [255, 255, 255];
const GT_COLOR: Rgb = [31, 100, 200];
const EST_COLOR: Rgb = [235, 110, 20];
const ERROR_COLOR: Rgb = [200, 30, 30];
const TEXT_COLOR: Rgb = [20, 20, 20];
/// Smallest image side that leaves room for labels.
pub(super) const MIN_SIDE: usize = 200;

/// `[plot]` settings of the evaluation figure.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlotConfig {
    /// Image width in pixels. Default 1400 (two 600-pixel panels plus labels).
    pub width: usize,
    /// Image height in pixels. Default 640.
    pub height: usize,
    /// Line width of the trajectories in pixels. Default 2.
    pub line_width: usize,
}

impl Default for PlotConfig {
    fn default() -> Self {
        Self {
            width: 1400,
            height: 640,
            line_width: 2,
        }
    }
}

/// The plot could not be made or written.
#[derive(Debug, Error)]
pub enum PlotError {
    /// The configured size leaves no room for the panels.
    #[error("plot size {width}x{height} is too small (at least {MIN_SIDE}x{MIN_SIDE})")]
    TooSmall {
        /// Configured width.
        width: usize,
        /// Configured height.
        height: usize,
    },
    /// The PNG could not be encoded or written.
    #[error("{path}: cannot write the plot: {message}", path = path.display())]
    Write {
        /// The output file.
        path: PathBuf,
        /// The encoder's or file system's message.
        message: String,
    },
}

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
        Range::of(values, 0.0, 0.0).map_or(0.0, |r| r.span())
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
    let (w, h) = (config.width, config.height);
    if w < 2 * MIN_SIDE || h < MIN_SIDE {
        return Err(PlotError::TooSmall {
            width: w,
            height: h,
        });
    }
    let mut canvas = Canvas::new(w, h, BACKGROUND);
    let (wf, hf) = (w as f64, h as f64);
    let (top, bottom) = (80.0, hf - 70.0);
    let half = wf / 2.0;
    let lw = config.line_width.max(1);

    // Left: top view with equal scales on both axes.
    let (ax, ay) = top_view_axes(eval);
    let names = ["x", "y", "z"];
    let gt_pts: Vec<(f64, f64)> = eval
        .gt_matched
        .poses()
        .iter()
        .map(|p| (p.translation.vector[ax], p.translation.vector[ay]))
        .collect();
    let est_pts: Vec<(f64, f64)> = eval
        .est_aligned
        .poses()
        .iter()
        .map(|p| (p.translation.vector[ax], p.translation.vector[ay]))
        .collect();
    let all = || gt_pts.iter().chain(&est_pts);
    let (left, right) = (90.0, half - 30.0);
    let mut xr = Range::of(all().map(|p| p.0), 0.1, 0.05).unwrap_or(Range { lo: -1.0, hi: 1.0 });
    let mut yr = Range::of(all().map(|p| p.1), 0.1, 0.05).unwrap_or(Range { lo: -1.0, hi: 1.0 });
    let metres_per_px = (xr.span() / (right - left)).max(yr.span() / (bottom - top));
    xr = xr.widened_to(metres_per_px * (right - left));
    yr = yr.widened_to(metres_per_px * (bottom - top));
    let view = Panel {
        left,
        top,
        right,
        bottom,
        x: xr,
        y: yr,
    };
    view.draw_axes(
        &mut canvas,
        "TOP VIEW (ALIGNED)",
        &format!("{} (m)", names[ax]),
        &format!("{} (m)", names[ay]),
    );
    view.polyline(&mut canvas, &gt_pts, lw, GT_COLOR);
    view.polyline(&mut canvas, &est_pts, lw, EST_COLOR);
    if let Some(&(x, y)) = gt_pts.first() {
        let (u, v) = view.to_px(x, y);
        canvas.dot(u, v, 3 * lw + 4, GT_COLOR);
    }
    let legend_y = top as i64 + 10;
    for (i, (label, color)) in [("ground truth", GT_COLOR), ("estimate", EST_COLOR)]
        .into_iter()
        .enumerate()
    {
        let y = legend_y + i as i64 * 22;
        let x = left as i64 + 12;
        canvas.fill_rect(x, y + 5, x + 24, y + 9, color);
        canvas.text(x + 32, y, label, TEXT_SCALE, TEXT_COLOR);
    }

    // Right: ATE of each matched pose over time, with its RMSE dashed.
    let t0 = eval
        .est_aligned
        .timestamps()
        .first()
        .copied()
        .unwrap_or(0.0);
    let err_pts: Vec<(f64, f64)> = eval
        .est_aligned
        .timestamps()
        .iter()
        .zip(&eval.ate.errors_m)
        .map(|(t, e)| (t - t0, *e))
        .collect();
    let tr =
        Range::of(err_pts.iter().map(|p| p.0), 1e-3, 0.0).unwrap_or(Range { lo: 0.0, hi: 1.0 });
    let emax = eval.ate.stats.max.max(1e-6);
    let errors = Panel {
        left: half + 90.0,
        top,
        right: wf - 30.0,
        bottom,
        x: tr,
        y: Range {
            lo: 0.0,
            hi: emax * 1.1,
        },
    };
    errors.draw_axes(&mut canvas, "ATE OVER TIME", "time (s)", "ATE (m)");
    errors.polyline(&mut canvas, &err_pts, lw, ERROR_COLOR);
    let (_, rmse_v) = errors.to_px(0.0, eval.ate.stats.rmse);
    canvas.dashed_hline(
        errors.left as i64,
        errors.right as i64,
        rmse_v.round() as i64,
        8,
        TEXT_COLOR,
    );
    let summary = format!(
        "RMSE {:.4} m   MAX {:.4} m   MATCHED {}",
        eval.ate.stats.rmse,
        eval.ate.stats.max,
        eval.matched()
    );
    canvas.text(
        errors.left as i64 + 12,
        top as i64 + 10,
        &summary,
        TEXT_SCALE,
        TEXT_COLOR,
    );
    Ok(canvas.into_image())
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

/// Writes `image` as a PNG to `path`.
///
/// # Errors
/// [`PlotError::Write`] naming the file that could not be encoded or written.
pub(super) fn save_png(image: &RgbImage, path: &Path) -> Result<(), PlotError> {
    image::save_buffer_with_format(
        path,
        image.as_slice().as_flattened(),
        image.width() as u32,
        image.height() as u32,
        image::ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .map_err(|e| PlotError::Write {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trajectory::{EVO_MAX_DIFF_S, Trajectory, evaluate};
    use nalgebra::Isometry3;

    fn circle_eval() -> Evaluation {
        let (mut gt, mut est) = (Trajectory::new(), Trajectory::new());
        for k in 0..100 {
            let a = k as f64 * 0.05;
            gt.push(a, Isometry3::translation(a.cos(), a.sin(), 0.0));
            est.push(a, Isometry3::translation(1.05 * a.cos(), a.sin(), 0.01 * a));
        }
        evaluate(&gt, &est, EVO_MAX_DIFF_S).unwrap()
    }

    fn count(image: &RgbImage, color: Rgb) -> usize {
        image.as_slice().iter().filter(|&&p| p == color).count()
    }

    #[test]
    fn the_figure_draws_both_trajectories_and_the_error() {
        let image = render_evaluation(&circle_eval(), &PlotConfig::default()).unwrap();
        assert_eq!((image.width(), image.height()), (1400, 640));
        // A unit circle over ~480 px is ~1500 px long; a 2-px line covers > 2000 px.
        assert!(
            count(&image, GT_COLOR) > 2000,
            "{}",
            count(&image, GT_COLOR)
        );
        assert!(count(&image, EST_COLOR) > 2000);
        assert!(count(&image, ERROR_COLOR) > 500);
        // The trajectories are in the left half, the error curve in the right half.
        let in_half = |color, right: bool| {
            (0..image.height())
                .flat_map(|y| image.row(y).iter().enumerate())
                .filter(|(x, p)| **p == color && (*x >= 700) == right)
                .count()
        };
        assert_eq!(in_half(GT_COLOR, true), 0);
        assert_eq!(in_half(ERROR_COLOR, false), 0);
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
