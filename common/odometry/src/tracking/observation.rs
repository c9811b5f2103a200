//! How a frame's features become measurements for the optimisers, the same for the
//! tracker's pose optimisation and the local BA: a keypoint is its pixel, the inverse
//! variance of its pyramid level and its depth; an observed segment is its infinite
//! line.

use crate::tracking::matching::ScalePyramid;
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

#[cfg(test)]
mod tests {
    use super::*;
    use gfs_lines::Segment;

    #[test]
    fn a_keypoint_is_weighed_by_its_level_and_keeps_its_depth() {
        let kp = KeyPoint {
            u: 10.5,
            v: 20.0,
            level: 2,
            angle: 0.0,
            response: 1.0,
            depth: 1.5,
        };
        let m = KeypointMeasurement::new(&kp, &ScalePyramid::new(1.2, 8));
        assert_eq!((m.uv, m.depth), (Vector2::new(10.5, 20.0), 1.5));
        assert!((m.inv_sigma2 - 1.0 / 1.2f64.powi(4)).abs() < 1e-12);
    }

    #[test]
    fn a_segment_gives_its_normalised_line_and_a_point_gives_none() {
        let line = |s| DetectedLine {
            segment: s,
            mean_gradient: 1.0,
        };
        let l = observed_line(&line(Segment::new(0.0, 2.0, 10.0, 2.0))).expect("a line");
        assert!((l.x.hypot(l.y) - 1.0).abs() < 1e-6);
        // The distance of (5, 5) to the line v = 2 is 3 px.
        assert!((l.x * 5.0 + l.y * 5.0 + l.z).abs() - 3.0 < 1e-6);
        assert!(observed_line(&line(Segment::new(3.0, 3.0, 3.0, 3.0))).is_none());
    }
}
