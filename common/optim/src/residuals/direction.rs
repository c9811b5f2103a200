//! The unit direction of a 3D line given by its two endpoints, and its Jacobian: the
//! shared building block of the structural and Manhattan residuals (eq. 12-14).

use nalgebra::{Matrix3, Matrix3x6, Vector3};

/// Lines shorter than this (metres) have no direction.
const MIN_LINE_LENGTH: f64 = 1e-9;

/// `d = (E - S) / |E - S|` and d(d)/d([S; E]) = `[-P, P]`, `P = (I - d d^T) / |E - S|`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct UnitDirection {
    /// Unit direction from S to E.
    pub(crate) direction: Vector3<f64>,
    /// Jacobian with respect to the stacked endpoints, 3x6.
    pub(crate) jacobian: Matrix3x6<f64>,
}

/// The unit direction alone; `None` for a degenerate line.
#[inline]
pub(crate) fn unit_direction(endpoints: &[Vector3<f64>; 2]) -> Option<Vector3<f64>> {
    let d = endpoints[1] - endpoints[0];
    let length = d.norm();
    (length > MIN_LINE_LENGTH).then(|| d / length)
}

/// The unit direction and its Jacobian; `None` for a degenerate line.
#[inline]
pub(crate) fn linearize_direction(endpoints: &[Vector3<f64>; 2]) -> Option<UnitDirection> {
    let d = endpoints[1] - endpoints[0];
    let length = d.norm();
    if length <= MIN_LINE_LENGTH {
        return None;
    }
    let direction = d / length;
    let p = (Matrix3::identity() - direction * direction.transpose()) / length;
    let mut jacobian = Matrix3x6::zeros();
    jacobian.fixed_view_mut::<3, 3>(0, 0).copy_from(&(-p));
    jacobian.fixed_view_mut::<3, 3>(0, 3).copy_from(&p);
    Some(UnitDirection {
        direction,
        jacobian,
    })
}
