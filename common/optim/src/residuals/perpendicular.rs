//! Perpendicular-lines structural error (paper eq. 11-12, as MSC-VO):
//! `e = d_i . d_j` with unit directions, i.e. `cos` of the angle; its square equals the
//! square of the paper's `|cos|`, without the kink of the absolute value.

use super::direction::{linearize_direction, unit_direction};
use nalgebra::{RowVector6, Vector3};

/// A pair of map lines that should be perpendicular (no measurement: the target is 0).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PerpendicularLines;

/// Error and Jacobians of [`PerpendicularLines`] at one estimate.
#[derive(Clone, Copy, Debug)]
pub struct PerpendicularLinearization {
    /// `d_i . d_j`, the cosine of the angle between the lines.
    pub error: f64,
    /// d(error)/d([S_i; E_i]), 1x6.
    pub d_first: RowVector6<f64>,
    /// d(error)/d([S_j; E_j]), 1x6.
    pub d_second: RowVector6<f64>,
}

impl PerpendicularLines {
    /// The error; `None` when a line is degenerate (zero length).
    #[inline]
    pub fn error(&self, first: &[Vector3<f64>; 2], second: &[Vector3<f64>; 2]) -> Option<f64> {
        Some(unit_direction(first)?.dot(&unit_direction(second)?))
    }

    /// The error and its Jacobians; `None` when a line is degenerate.
    #[inline]
    pub fn linearize(
        &self,
        first: &[Vector3<f64>; 2],
        second: &[Vector3<f64>; 2],
    ) -> Option<PerpendicularLinearization> {
        let di = linearize_direction(first)?;
        let dj = linearize_direction(second)?;
        Some(PerpendicularLinearization {
            error: di.direction.dot(&dj.direction),
            d_first: dj.direction.transpose() * di.jacobian,
            d_second: di.direction.transpose() * dj.jacobian,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::residuals::testing::{SplitMix64, assert_jacobian};
    use nalgebra::{Vector1, Vector6};

    #[test]
    fn jacobians_match_central_differences() {
        let mut rng = SplitMix64::new(4);
        for _ in 0..100 {
            let a = [rng.vector3(3.0), rng.vector3(3.0)];
            let b = [rng.vector3(3.0), rng.vector3(3.0)];
            let lin = PerpendicularLines
                .linearize(&a, &b)
                .expect("non-degenerate");
            let moved = |l: &[Vector3<f64>; 2], d: &Vector6<f64>| {
                [l[0] + d.fixed_rows::<3>(0), l[1] + d.fixed_rows::<3>(3)]
            };
            assert_jacobian(
                |d: &Vector6<f64>| {
                    Vector1::new(PerpendicularLines.error(&moved(&a, d), &b).expect("line"))
                },
                &lin.d_first,
                "perpendicular d_first",
            );
            assert_jacobian(
                |d: &Vector6<f64>| {
                    Vector1::new(PerpendicularLines.error(&a, &moved(&b, d)).expect("line"))
                },
                &lin.d_second,
                "perpendicular d_second",
            );
        }
    }

    #[test]
    fn error_is_the_cosine_of_the_angle() {
        let a = [Vector3::zeros(), Vector3::new(0.0, 0.0, 3.0)];
        let angle = 80f64.to_radians();
        let b = [
            Vector3::new(1.0, 1.0, 1.0),
            Vector3::new(1.0 + angle.sin(), 1.0, 1.0 + angle.cos()),
        ];
        let e = PerpendicularLines.error(&a, &b).expect("lines");
        assert!((e - angle.cos()).abs() < 1e-12, "{e}");
    }
}
