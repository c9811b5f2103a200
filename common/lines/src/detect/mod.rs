//! EDLines line-segment detection (Akinlar & Topal, "EDLines: A real-time line segment
//! detector with a false detection control", 2011), the first step of the paper's line
//! front end (GFS-VO section III-A), followed on request by the ELSED-style joining of
//! [`crate::join`].
//!
//! Pipeline, one private module per step, all scratch owned by [`LineDetector`]:
//! 1. `smooth`: 5x5 Gaussian (binomial 1-4-6-4-1, sigma 1 px), integer arithmetic.
//! 2. `gradient`: Sobel `gx`, `gy` (`i16`), magnitude `|gx| + |gy|` (`u16`), and the edge
//!    orientation (horizontal / vertical) of every pixel at or above the threshold.
//! 3. `anchors`: clear maxima of the magnitude across the edge, strongest first.
//! 4. `drawing`: Edge Drawing, routing from every anchor along the ridge of the
//!    magnitude in both directions, giving ordered chains of edge pixels.
//! 5. `fit`: chain pixels moved to the sub-pixel magnitude peak, then the EDLines
//!    incremental least-squares fit (window of the NFA minimum length, extended while
//!    every pixel stays within `max_fit_error`); endpoints are the projections of the
//!    first and last pixel onto the fitted line.
//! 6. `nfa`: the Helmholtz-principle validation, `NFA = (W H)^2 * binomial tail <= 1`
//!    on the 2x2 gradient of the unsmoothed image, so that noise gives no line.
//!
//! The step kernels stay private: the public surface is the detector, its config and
//! the gradients it exposes for the LBD descriptor. Measured on the 300 frames of TUM
//! fr1/rpy (640x480, one thread, a loaded 2-core machine): detection ~1.9 ms and joining
//! ~0.5 ms median per frame, ~220 lines per frame.
//!
//! Segment orientation: every detected segment is oriented so that the image is brighter
//! on its positive side, i.e. where [`crate::Segment::line_coefficients`] gives a positive
//! signed distance (the smoothed gradient points along `(a, b)`).

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
