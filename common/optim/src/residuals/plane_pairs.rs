//! Structural errors of two map planes: walls facing each other are
//! parallel, a wall and the floor perpendicular. As for lines ([`super::ParallelLines`],
//! [`super::PerpendicularLines`]) the smooth forms are used: `e = n_i x n_j` (`|e| =
//! |sin|` of the angle between the normals, zero for opposite normals too) and
//! `e = n_i . n_j` (`cos`).
//!
//! Each plane moves by its minimal step `[alpha; delta_d]` ([`super::plane_plus`]):
//! `d n / d alpha = B`, the tangent basis, and the offset does not enter.

use super::plane::tangent_basis;
use gfs_core::se3::skew;
use nalgebra::{Matrix3, RowVector3, Vector3};

/// A pair of map planes that should be parallel (no measurement: the target is 0).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ParallelPlanes;

/// A pair of map planes that should be perpendicular (the target is 0).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PerpendicularPlanes;

/// Error and Jacobians of [`ParallelPlanes`] at one estimate.
#[derive(Clone, Copy, Debug)]
pub struct ParallelPlanesLinearization {
    /// `n_i x n_j`.
    pub error: Vector3<f64>,
    /// d(error)/d(alpha_i, d_i), 3x3 (last column zero).
    pub d_first: Matrix3<f64>,
    /// d(error)/d(alpha_j, d_j), 3x3 (last column zero).
    pub d_second: Matrix3<f64>,
}

/// Error and Jacobians of [`PerpendicularPlanes`] at one estimate.
#[derive(Clone, Copy, Debug)]
pub struct PerpendicularPlanesLinearization {
    /// `n_i . n_j`.
    pub error: f64,
    /// d(error)/d(alpha_i, d_i), 1x3 (last entry zero).
    pub d_first: RowVector3<f64>,
    /// d(error)/d(alpha_j, d_j), 1x3 (last entry zero).
    pub d_second: RowVector3<f64>,
}

/// `d n / d [alpha; delta_d]` of a unit normal: the tangent basis, then a zero column.
pub(crate) fn normal_jacobian(n: &Vector3<f64>) -> Matrix3<f64> {
    let b = tangent_basis(n);
    Matrix3::from_columns(&[
        b.column(0).into_owned(),
        b.column(1).into_owned(),
        Vector3::zeros(),
    ])
}

impl ParallelPlanes {
    /// The error of the unit normals `first` and `second`.
    #[inline]
    pub fn error(&self, first: &Vector3<f64>, second: &Vector3<f64>) -> Vector3<f64> {
        first.cross(second)
    }

    /// The error and its Jacobians.
    #[inline]
    pub fn linearize(
        &self,
        first: &Vector3<f64>,
        second: &Vector3<f64>,
    ) -> ParallelPlanesLinearization {
        ParallelPlanesLinearization {
            error: first.cross(second),
            // d(a x b)/da = -[b]x, d(a x b)/db = [a]x.
            d_first: -skew(second) * normal_jacobian(first),
            d_second: skew(first) * normal_jacobian(second),
        }
    }
}

impl PerpendicularPlanes {
    /// The error of the unit normals `first` and `second`.
    #[inline]
    pub fn error(&self, first: &Vector3<f64>, second: &Vector3<f64>) -> f64 {
        first.dot(second)
    }

    /// The error and its Jacobians.
    #[inline]
    pub fn linearize(
        &self,
        first: &Vector3<f64>,
        second: &Vector3<f64>,
    ) -> PerpendicularPlanesLinearization {
        PerpendicularPlanesLinearization {
            error: first.dot(second),
            d_first: second.transpose() * normal_jacobian(first),
            d_second: first.transpose() * normal_jacobian(second),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::residuals::plane_plus;
    use crate::residuals::testing::{SplitMix64, assert_jacobian};
    use nalgebra::Vector1;

    fn moved(n: &Vector3<f64>, step: &Vector3<f64>) -> Vector3<f64> {
        plane_plus(n, 0.7, step).0
    }

    #[test]
    fn jacobians_match_central_differences() {
        let mut rng = SplitMix64::new(23);
        for _ in 0..100 {
            let a = rng.vector3(1.0).normalize();
            let b = rng.vector3(1.0).normalize();
            let par = ParallelPlanes.linearize(&a, &b);
            assert_jacobian(
                |s: &Vector3<f64>| ParallelPlanes.error(&moved(&a, s), &b),
                &par.d_first,
                "parallel planes d_first",
            );
            assert_jacobian(
                |s: &Vector3<f64>| ParallelPlanes.error(&a, &moved(&b, s)),
                &par.d_second,
                "parallel planes d_second",
            );
            let perp = PerpendicularPlanes.linearize(&a, &b);
            assert_jacobian(
                |s: &Vector3<f64>| Vector1::new(PerpendicularPlanes.error(&moved(&a, s), &b)),
                &perp.d_first,
                "perpendicular planes d_first",
            );
            assert_jacobian(
                |s: &Vector3<f64>| Vector1::new(PerpendicularPlanes.error(&a, &moved(&b, s))),
                &perp.d_second,
                "perpendicular planes d_second",
            );
        }
    }

    #[test]
    fn errors_are_the_sine_and_cosine_of_the_angle() {
        let floor = Vector3::new(0.0, -1.0, 0.0);
        let angle = 87f64.to_radians();
        let wall = Vector3::new(angle.sin(), -angle.cos(), 0.0);
        assert!((PerpendicularPlanes.error(&floor, &wall) - angle.cos()).abs() < 1e-12);
        // Facing walls: opposite normals are parallel.
        let tilt = 2f64.to_radians();
        let facing = Vector3::new(-tilt.cos(), tilt.sin(), 0.0);
        let e = ParallelPlanes.error(&wall, &facing).norm();
        let between = wall.dot(&facing).clamp(-1.0, 1.0).acos();
        assert!((e - between.sin()).abs() < 1e-12, "{e}");
    }
}
