//! Least-squares rigid alignment of corresponding 3D points (Kabsch / Umeyama without
//! scale): the `T` minimising `sum |dst_i - T src_i|^2`.

use nalgebra::{Isometry3, Matrix3, Point3, Translation3, Vector3};

/// The rigid transform `T` (rotation + translation, no scale) that best maps `src` onto
/// `dst` in the least-squares sense. `None` with fewer than 3 pairs, mismatched lengths,
/// or a degenerate (collinear) configuration.
pub fn rigid_transform(src: &[Point3<f64>], dst: &[Point3<f64>]) -> Option<Isometry3<f64>> {
    if src.len() != dst.len() || src.len() < 3 {
        return None;
    }
    let finite = |p: &Point3<f64>| p.coords.iter().all(|v| v.is_finite());
    if !src.iter().chain(dst).all(finite) {
        return None;
    }
    let n = src.len() as f64;
    let src_mean = src.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / n;
    let dst_mean = dst.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / n;
    let mut cov = Matrix3::zeros();
    for (s, d) in src.iter().zip(dst) {
        cov += (d.coords - dst_mean) * (s.coords - src_mean).transpose();
    }
    let svd = cov.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    // Rank < 2 means the points are collinear: the rotation about that line is unknown.
    let mut singular = svd.singular_values;
    singular.as_mut_slice().sort_by(|a, b| b.total_cmp(a));
    if singular[1] <= 1e-12 * singular[0].max(1e-300) {
        return None;
    }
    let mut s = Matrix3::identity();
    if (u * v_t).determinant() < 0.0 {
        s[(2, 2)] = -1.0;
    }
    let rotation = u * s * v_t;
    let rotation = crate::se3::rotation_from_matrix(&rotation);
    let translation = dst_mean - rotation * src_mean;
    Some(Isometry3::from_parts(
        Translation3::from(translation),
        rotation,
    ))
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_point_with_a_nan_gives_no_transform() {
        let src: Vec<_> = (0..5)
            .map(|i| Point3::new(i as f64, (i * i) as f64, 1.0))
            .collect();
        let mut dst = src.clone();
        dst[3].y = f64::NAN;
        assert!(rigid_transform(&src, &dst).is_none());
    }

    use super::*;
    use nalgebra::UnitQuaternion;

    #[test]
    fn recovers_a_known_transform() {
        let truth = Isometry3::from_parts(
            Translation3::new(0.3, -1.0, 2.0),
            UnitQuaternion::from_euler_angles(0.4, -0.2, 1.3),
        );
        let src: Vec<_> = (0..10)
            .map(|i| Point3::new(i as f64 * 0.3, (i * i) as f64 * 0.1 - 1.0, (i % 3) as f64))
            .collect();
        let dst: Vec<_> = src.iter().map(|p| truth * p).collect();
        let t = rigid_transform(&src, &dst).unwrap();
        assert!((t.translation.vector - truth.translation.vector).norm() < 1e-9);
        assert!(t.rotation.angle_to(&truth.rotation) < 1e-9);
    }

    #[test]
    fn degenerate_inputs_give_none() {
        let line: Vec<_> = (0..5).map(|i| Point3::new(i as f64, 0.0, 0.0)).collect();
        assert!(rigid_transform(&line, &line).is_none());
        assert!(rigid_transform(&line[..2], &line[..2]).is_none());
        assert!(rigid_transform(&line, &line[..4]).is_none());
    }
}
