//! How a frame's features become measurements for the optimisers, the same for the
//! tracker's pose optimisation and the local BA: a keypoint is its pixel, the inverse
//! variance of its pyramid level and its depth; an observed segment is its infinite
//! line.

use crate::matching::ScalePyramid;
use gfs_lines::DetectedLine;
use gfs_points::KeyPoint;
use nalgebra::{Vector2, Vector3};

/// Inverse variance of a line observation's endpoint distances (1 px sigma: the
/// segment fit is sub-pixel, its endpoints are not, so lines are weighed as level-0
/// keypoints).
pub const LINE_INV_SIGMA2: f64 = 1.0;

/// A keypoint as a measurement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KeypointMeasurement {
    /// Undistorted pixel.
    pub uv: Vector2<f64>,
    /// Inverse variance of the pixel position at the keypoint's level.
    pub inv_sigma2: f64,
    /// Measured depth, metres (0: none).
    pub depth: f64,
}

impl KeypointMeasurement {
    /// The measurement of `kp`, whose level is in `scale`.
    pub fn new(kp: &KeyPoint, scale: &ScalePyramid) -> Self {
        Self {
            uv: Vector2::new(f64::from(kp.u), f64::from(kp.v)),
            inv_sigma2: scale.inv_sigma2(kp.level),
            depth: f64::from(kp.depth),
        }
    }
}

/// The observed segment's infinite line `(a, b, c)` with `a^2 + b^2 = 1` (the endpoint
/// distances to it are pixels); `None` for a degenerate segment.
pub fn observed_line(line: &DetectedLine) -> Option<Vector3<f64>> {
    let [a, b, c] = line.segment.line_coefficients();
    if a == 0.0 && b == 0.0 {
        return None;
    }
    Some(Vector3::new(f64::from(a), f64::from(b), f64::from(c)))
}
