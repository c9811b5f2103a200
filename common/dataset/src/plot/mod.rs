//! The evaluation plot: a PNG with the top view of the ground truth and the aligned
//! estimate (left) and the ATE over time (right), drawn on a small raster canvas with a
//! built-in bitmap font, so that no plotting framework is needed. A multi-series line
//! chart ([`LineChart`]) on the same canvas serves other figures (per-stage timings).

mod axes;
mod canvas;
mod chart;
mod figure;
mod font;

pub use canvas::{Canvas, Rgb};
pub use chart::{
    LineChart, SERIES_COLORS, Series, render_line_chart, series_color, write_line_chart_png,
};
pub use figure::{PlotConfig, PlotError, render_evaluation, write_evaluation_png};
