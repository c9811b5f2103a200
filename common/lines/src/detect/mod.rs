//! EDLines line-segment detection (Akinlar & Topal, "EDLines: A real-time line segment
//! detector with a false detection control", 2011), the first step of the paper's line
//! front end (GFS-VO section III-A).
//!
//! Pipeline, one module per step, all scratch owned by [`LineDetector`]:
//! 1. [`smooth`]: 5x5 Gaussian (binomial 1-4-6-4-1, sigma 1 px).
//! 2. [`gradient`]: Sobel `gx`, `gy`, magnitude `|gx| + |gy|`, edge orientation
//!    (horizontal / vertical) of every pixel above the gradient threshold.
//! 3. [`anchors`]: local maxima of the magnitude across the edge, sorted strongest first.
//! 4. [`drawing`]: Edge Drawing, routing from every anchor along the ridge of the
//!    gradient magnitude in both directions, giving chains of edge pixels.
//! 5. [`fit`]: incremental least-squares line fitting along each chain.
//! 6. [`nfa`]: the Helmholtz-principle validation (number of false alarms <= 1).
//!
//! Segment orientation: every detected segment is oriented so that the image is brighter
//! on its positive side, i.e. where [`crate::Segment::line_coefficients`] gives a positive
//! signed distance (the gradient points along `(a, b)`).

mod anchors;
mod config;
mod detector;
mod drawing;
mod fit;
mod gradient;
mod nfa;
mod smooth;

pub use config::{DetectConfig, DetectConfigError};
pub(crate) use config::{check, clamped};
pub use detector::LineDetector;
pub(crate) use fit::Moments;

#[cfg(test)]
mod test_scenes;
#[cfg(test)]
mod tests;
