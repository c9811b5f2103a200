//! Figures of GFS-VO as PNG files, drawn with `plotters` into an RGB buffer and encoded
//! with `image`: the evaluation ([`write_evaluation_png`]: top view of the aligned
//! trajectories and the ATE over time) and line charts of several series
//! ([`write_line_chart_png`]: e.g. the processing time of each stage); and the tracking
//! image of a frame ([`draw_tracking_image`]: its matches on its colour image).
//!
//! Text is rasterised in pure Rust (ab_glyph) with DejaVu Sans, shipped in `fonts/`
//! with its licence and embedded in the binary, so the figures look the same on every
//! machine and need no system font.

mod canvas;
mod chart;
mod evaluation;

pub use canvas::{PlotConfig, PlotError, SERIES_COLORS, series_color};
pub use chart::{LineChart, Series, render_line_chart, write_line_chart_png};
pub use evaluation::{render_evaluation, write_evaluation_png};
mod map;
pub use map::{MapFigure, render_map, write_map_png};
mod tracking_image;
pub use tracking_image::{INLIER_COLOR, OUTLIER_COLOR, draw_tracking_image, status_line};
