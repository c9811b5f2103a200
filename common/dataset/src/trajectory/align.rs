//! Rigid (SE(3), no scale) least-squares alignment of two point sets, after Umeyama
//! (IEEE PAMI 1991), with the same conventions as evo's `geometry.umeyama_alignment`.

use nalgebra::{Isometry3, Matrix3, Point3, Translation3, Vector3};
use thiserror::Error;

/// Two point sets could not be aligned.
#[derive(Debug, Error, PartialEq, Eq)]
pub enum AlignError {
    /// The two sets differ in length, or are empty.
    #[error("cannot align {source_len} points with {target_len} points")]
    BadInput {
        /// Points of the set that is moved.
        source_len: usize,
        /// Points of the fixed set.
        target_len: usize,
    },
    /// The SVD did not converge (non-finite coordinates).
    #[error("the SVD of the cross-covariance did not converge (non-finite points?)")]
    NoConvergence,
}

/// The rigid transform `T` minimising `sum |target_i - T * source_i|^2`.
///
/// Umeyama's closed form: with centroids `mu_s`, `mu_t` and the cross-covariance
/// `C = 1/n sum (t_i - mu_t)(s_i - mu_s)^T = U D V^T`, `R = U S V^T` where `S` flips the
/// axis of the smallest singular value when `det(U) det(V) < 0` (a reflection would fit
/// better otherwise), and `t = mu_t - R mu_s`.
///
/// # Errors
/// [`AlignError::BadInput`] for empty or unequal sets, [`AlignError::NoConvergence`] for
/// non-finite input.
pub fn umeyama_se3(
    source: &[Point3<f64>],
    target: &[Point3<f64>],
) -> Result<Isometry3<f64>, AlignError> {
    if source.is_empty() || source.len() != target.len() {
        return Err(AlignError::BadInput {
            source_len: source.len(),
            target_len: target.len(),
        });
    }
    let n = source.len() as f64;
    let mean = |pts: &[Point3<f64>]| pts.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / n;
    let (mu_s, mu_t) = (mean(source), mean(target));
    let mut cov = Matrix3::zeros();
    for (s, t) in source.iter().zip(target) {
        cov += (t.coords - mu_t) * (s.coords - mu_s).transpose();
    }
    cov /= n;
    let svd = cov
        .try_svd(true, true, f64::EPSILON, 0)
        .ok_or(AlignError::NoConvergence)?;
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(AlignError::NoConvergence);
    };
    let mut s = Matrix3::identity();
    if u.determinant() * v_t.determinant() < 0.0 {
        // Flip the axis of the smallest singular value (nalgebra does not sort them).
        let smallest = svd.singular_values.imin();
        s[(smallest, smallest)] = -1.0;
    }
    let r = u * s * v_t;
    if !r.iter().all(|x| x.is_finite()) {
        return Err(AlignError::NoConvergence);
    }
    let rotation = gfs_core::se3::rotation_from_matrix(&r);
    let t = mu_t - rotation * mu_s;
    Ok(Isometry3::from_parts(Translation3::from(t), rotation))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    #[test]
    fn recovers_a_known_rigid_motion() {
        let truth = Isometry3::from_parts(
            Translation3::new(0.5, -2.0, 1.0),
            UnitQuaternion::from_euler_angles(0.4, -1.2, 2.5),
        );
        let source: Vec<Point3<f64>> = (0..20)
            .map(|i| {
                let f = i as f64;
                Point3::new(f.sin() * 2.0, (0.7 * f).cos(), 0.1 * f)
            })
            .collect();
        let target: Vec<Point3<f64>> = source.iter().map(|p| truth * p).collect();
        let est = umeyama_se3(&source, &target).unwrap();
        assert!((est.translation.vector - truth.translation.vector).norm() < 1e-9);
        assert!(est.rotation.angle_to(&truth.rotation) < 1e-9);
    }

    #[test]
    fn planar_and_degenerate_sets_give_a_proper_rotation() {
        // Coplanar points: one singular value is 0 and the sign fix must keep det = +1.
        let source = [
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
            Point3::new(1.0, 1.0, 0.0),
        ];
        let flip = Isometry3::rotation(Vector3::new(std::f64::consts::PI, 0.0, 0.0));
        let target: Vec<_> = source.iter().map(|p| flip * p).collect();
        let est = umeyama_se3(&source, &target).unwrap();
        for (s, t) in source.iter().zip(&target) {
            assert!((est * s - t).norm() < 1e-9);
        }
        assert!((est.rotation.to_rotation_matrix().matrix().determinant() - 1.0).abs() < 1e-9);
        // A single point: pure translation onto it.
        let one = umeyama_se3(&[Point3::new(1.0, 2.0, 3.0)], &[Point3::origin()]).unwrap();
        assert!((one * Point3::new(1.0, 2.0, 3.0)).coords.norm() < 1e-12);
        assert!(umeyama_se3(&[], &[]).is_err());
        assert!(umeyama_se3(&source, &target[..2]).is_err());
    }
}
