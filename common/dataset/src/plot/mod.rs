//! The evaluation plot: a PNG with the top view of the ground truth and the aligned
//! estimate (left) and the ATE over time (right), drawn on a small raster canvas with a
//! built-in bitmap font, so that no plotting framework is needed.

mod axes;
mod canvas;
mod figure;
mod font;

pub use canvas::{Canvas, Rgb};
pub use figure::{PlotConfig, PlotError, render_evaluation, write_evaluation_png};
