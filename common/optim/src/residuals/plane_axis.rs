//! Manhattan-axis error of a map plane: a wall or floor whose normal is near a world
//! Manhattan axis should lie along it. `e = n x a` with the fixed unit axis `a` (either
//! sign), `|e| = |sin|` of the angle, as [`super::ManhattanAxis`] for lines. In the BA it
//! holds the plane on the axis the mapper turned it onto, where otherwise each
//! keyframe's noisy normal would pull it off.

use super::plane_pairs::normal_jacobian;
use gfs_core::se3::skew;
use nalgebra::{Matrix3, Vector3};

/// The association of a map plane's normal with a Manhattan axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneAxis {
    /// The axis direction in the world frame, unit norm (held fixed).
    pub axis: Vector3<f64>,
}

/// Error and Jacobian of a [`PlaneAxis`] term at one estimate.
#[derive(Clone, Copy, Debug)]
pub struct PlaneAxisLinearization {
    /// `n x a`.
    pub error: Vector3<f64>,
    /// d(error)/d(alpha, d), 3x3 (last column zero).
    pub d_plane: Matrix3<f64>,
}

impl PlaneAxis {
    /// The error of the unit normal `normal`.
    #[inline]
    pub fn error(&self, normal: &Vector3<f64>) -> Vector3<f64> {
        normal.cross(&self.axis)
    }

    /// The error and its Jacobian.
    #[inline]
    pub fn linearize(&self, normal: &Vector3<f64>) -> PlaneAxisLinearization {
        PlaneAxisLinearization {
            error: normal.cross(&self.axis),
            d_plane: -skew(&self.axis) * normal_jacobian(normal),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::residuals::plane_plus;
    use crate::residuals::testing::{SplitMix64, assert_jacobian};

    #[test]
    fn jacobian_matches_central_differences() {
        let mut rng = SplitMix64::new(29);
        for _ in 0..100 {
            let n = rng.vector3(1.0).normalize();
            let term = PlaneAxis {
                axis: rng.vector3(1.0).normalize(),
            };
            let lin = term.linearize(&n);
            assert!((lin.error - term.error(&n)).norm() < 1e-15);
            assert_jacobian(
                |s: &Vector3<f64>| term.error(&plane_plus(&n, -1.2, s).0),
                &lin.d_plane,
                "plane axis d_plane",
            );
        }
    }

    #[test]
    fn error_vanishes_on_the_axis_either_way() {
        let term = PlaneAxis {
            axis: Vector3::new(0.0, 1.0, 0.0),
        };
        assert!(term.error(&Vector3::new(0.0, -1.0, 0.0)).norm() < 1e-15);
        let tilted = Vector3::new(1.0, 1.0, 0.0).normalize();
        let e = term.error(&tilted).norm();
        assert!((e - std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-12);
    }
}
