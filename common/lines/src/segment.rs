//! The 2D line segment shared by every step of the line front end.

/// A segment in undistorted pixel coordinates (u, v), from `start` to `end`.
///
/// Plain `#[repr(C)]` data so that it can travel in a zero-copy message.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[repr(C)]
pub struct Segment {
    /// First endpoint (u, v), pixels.
    pub start: [f32; 2],
    /// Second endpoint (u, v), pixels.
    pub end: [f32; 2],
}

impl Segment {
    /// A segment from (`u0`, `v0`) to (`u1`, `v1`).
    pub fn new(u0: f32, v0: f32, u1: f32, v1: f32) -> Self {
        Self {
            start: [u0, v0],
            end: [u1, v1],
        }
    }

    /// Length in pixels.
    pub fn length(&self) -> f32 {
        (self.end[0] - self.start[0]).hypot(self.end[1] - self.start[1])
    }

    /// Midpoint (u, v).
    pub fn midpoint(&self) -> [f32; 2] {
        [
            0.5 * (self.start[0] + self.end[0]),
            0.5 * (self.start[1] + self.end[1]),
        ]
    }

    /// Direction angle of `end - start` in radians, in (-pi, pi].
    pub fn angle(&self) -> f32 {
        (self.end[1] - self.start[1]).atan2(self.end[0] - self.start[0])
    }

    /// Normalised line coefficients (a, b, c) with a^2 + b^2 = 1, so that
    /// a u + b v + c is the signed distance of (u, v) to the infinite line.
    /// A degenerate (zero-length) segment gives (0, 0, 0).
    pub fn line_coefficients(&self) -> [f32; 3] {
        let (du, dv) = (self.end[0] - self.start[0], self.end[1] - self.start[1]);
        let len = du.hypot(dv);
        if len <= f32::EPSILON {
            return [0.0; 3];
        }
        let (a, b) = (dv / len, -du / len);
        [a, b, -(a * self.start[0] + b * self.start[1])]
    }
}

/// A detected segment with the evidence the homogenisation ranks it by.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[repr(C)]
pub struct DetectedLine {
    /// The segment, pixels.
    pub segment: Segment,
    /// Mean gradient magnitude along the segment (same units as the detector's gradient).
    pub mean_gradient: f32,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coefficients_give_signed_distances() {
        let s = Segment::new(0.0, 0.0, 10.0, 0.0);
        let [a, b, c] = s.line_coefficients();
        assert!((a * 5.0 + b * 3.0 + c).abs() - 3.0 < 1e-6);
        assert_eq!(s.length(), 10.0);
        assert_eq!(Segment::default().line_coefficients(), [0.0; 3]);
    }
}
