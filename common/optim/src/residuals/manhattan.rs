//! Manhattan-axis error (paper eq. 14): a map line associated with a Manhattan axis
//! should be parallel to it. Same smooth vector form as [`super::ParallelLines`]:
//! `e = d x a` with the unit line direction `d` and the fixed unit axis `a` (world
//! frame), `|e| = |sin|` of the angle between line and axis.

use super::direction::{linearize_direction, unit_direction};
use gfs_core::se3::skew;
use nalgebra::{Matrix3x6, Vector3};

/// The association of a map line with a Manhattan axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ManhattanAxis {
    /// The axis direction in the world frame, unit norm (held fixed).
    pub axis: Vector3<f64>,
}

/// Error and Jacobian of a [`ManhattanAxis`] term at one estimate.
#[derive(Clone, Copy, Debug)]
pub struct ManhattanLinearization {
    /// `d x a`; its norm is `|sin|` of the angle between line and axis.
    pub error: Vector3<f64>,
    /// d(error)/d([S; E]), 3x6.
    pub d_line: Matrix3x6<f64>,
}

impl ManhattanAxis {
    /// The error; `None` when the line is degenerate (zero length).
    #[inline]
    pub fn error(&self, line: &[Vector3<f64>; 2]) -> Option<Vector3<f64>> {
        Some(unit_direction(line)?.cross(&self.axis))
    }

    /// The error and its Jacobian; `None` when the line is degenerate.
    #[inline]
    pub fn linearize(&self, line: &[Vector3<f64>; 2]) -> Option<ManhattanLinearization> {
        let d = linearize_direction(line)?;
        Some(ManhattanLinearization {
            error: d.direction.cross(&self.axis),
            d_line: -skew(&self.axis) * d.jacobian,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::residuals::testing::{SplitMix64, assert_jacobian};
    use nalgebra::Vector6;

    #[test]
    fn jacobian_matches_central_differences() {
        let mut rng = SplitMix64::new(5);
        for _ in 0..100 {
            let line = [rng.vector3(3.0), rng.vector3(3.0)];
            let term = ManhattanAxis {
                axis: rng.vector3(1.0).normalize(),
            };
            let lin = term.linearize(&line).expect("non-degenerate");
            assert_jacobian(
                |d: &Vector6<f64>| {
                    let moved = [
                        line[0] + d.fixed_rows::<3>(0),
                        line[1] + d.fixed_rows::<3>(3),
                    ];
                    term.error(&moved).expect("line")
                },
                &lin.d_line,
                "manhattan d_line",
            );
        }
    }

    #[test]
    fn error_vanishes_for_a_line_along_the_axis_either_way() {
        let term = ManhattanAxis {
            axis: Vector3::new(0.0, 1.0, 0.0),
        };
        let up = [Vector3::new(1.0, 0.0, 2.0), Vector3::new(1.0, 2.0, 2.0)];
        let down = [up[1], up[0]];
        assert!(term.error(&up).expect("line").norm() < 1e-15);
        assert!(term.error(&down).expect("line").norm() < 1e-15);
        let tilted = [Vector3::zeros(), Vector3::new(1.0, 1.0, 0.0)];
        let e = term.error(&tilted).expect("line").norm();
        assert!((e - std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-12);
    }
}
