//! Parallel-lines structural error (paper eq. 11 and 13, as MSC-VO).
//!
//! The paper's `|sin(L_i, L_j)|` has a kink at zero, exactly where the optimum lies, so
//! the smooth vector form `e = d_i x d_j` (unit directions) is used: `|e| = |sin|`, the
//! squared cost is the same, and Gauss-Newton sees a differentiable residual. Directions
//! are compared in the world frame: an angle does not depend on the frame, so this
//! equals the paper's camera-frame angle.

use super::direction::{linearize_direction, unit_direction};
use gfs_core::se3::skew;
use nalgebra::{Matrix3x6, Vector3};

/// A pair of map lines that should be parallel (no measurement: the target is 0).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ParallelLines;

/// Error and Jacobians of [`ParallelLines`] at one estimate.
#[derive(Clone, Copy, Debug)]
pub struct ParallelLinearization {
    /// `d_i x d_j`; its norm is `|sin|` of the angle between the lines.
    pub error: Vector3<f64>,
    /// d(error)/d([S_i; E_i]), 3x6.
    pub d_first: Matrix3x6<f64>,
    /// d(error)/d([S_j; E_j]), 3x6.
    pub d_second: Matrix3x6<f64>,
}

impl ParallelLines {
    /// The error; `None` when a line is degenerate (zero length).
    #[inline]
    pub fn error(
        &self,
        first: &[Vector3<f64>; 2],
        second: &[Vector3<f64>; 2],
    ) -> Option<Vector3<f64>> {
        Some(unit_direction(first)?.cross(&unit_direction(second)?))
    }

    /// The error and its Jacobians; `None` when a line is degenerate.
    #[inline]
    pub fn linearize(
        &self,
        first: &[Vector3<f64>; 2],
        second: &[Vector3<f64>; 2],
    ) -> Option<ParallelLinearization> {
        let di = linearize_direction(first)?;
        let dj = linearize_direction(second)?;
        Some(ParallelLinearization {
            error: di.direction.cross(&dj.direction),
            // d(a x b)/da = -[b]x, d(a x b)/db = [a]x.
            d_first: -skew(&dj.direction) * di.jacobian,
            d_second: skew(&di.direction) * dj.jacobian,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::residuals::testing::{SplitMix64, assert_jacobian};
    use nalgebra::Vector6;

    #[test]
    fn jacobians_match_central_differences() {
        let mut rng = SplitMix64::new(3);
        for _ in 0..100 {
            let a = [rng.vector3(3.0), rng.vector3(3.0)];
            let b = [rng.vector3(3.0), rng.vector3(3.0)];
            let lin = ParallelLines.linearize(&a, &b).expect("non-degenerate");
            let moved = |l: &[Vector3<f64>; 2], d: &Vector6<f64>| {
                [l[0] + d.fixed_rows::<3>(0), l[1] + d.fixed_rows::<3>(3)]
            };
            assert_jacobian(
                |d: &Vector6<f64>| ParallelLines.error(&moved(&a, d), &b).expect("line"),
                &lin.d_first,
                "parallel d_first",
            );
            assert_jacobian(
                |d: &Vector6<f64>| ParallelLines.error(&a, &moved(&b, d)).expect("line"),
                &lin.d_second,
                "parallel d_second",
            );
        }
    }

    #[test]
    fn error_norm_is_the_sine_of_the_angle() {
        let a = [Vector3::zeros(), Vector3::new(2.0, 0.0, 0.0)];
        let angle = 10f64.to_radians();
        let b = [
            Vector3::new(0.0, 1.0, 5.0),
            Vector3::new(-angle.cos(), 1.0 - angle.sin(), 5.0),
        ];
        let e = ParallelLines.error(&a, &b).expect("lines");
        assert!((e.norm() - angle.sin()).abs() < 1e-12, "{e}");
        let degenerate = [Vector3::zeros(), Vector3::zeros()];
        assert!(ParallelLines.error(&a, &degenerate).is_none());
    }
}
