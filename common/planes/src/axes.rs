//! The Manhattan axes of a frame, their projection onto SO(3) and their labelling
//! (which axis is which, with which sign) against a predicted set of axes.

use nalgebra::{Matrix3, Rotation3, SVD, Vector3};

/// The three Manhattan axes of a frame.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ManhattanAxes {
    /// `camera_from_manhattan`: column `i` is axis `i` in the camera frame. Axis `i`
    /// keeps its identity and sign from frame to frame (see
    /// [`crate::ManhattanEstimator::estimate`]).
    pub rotation: Rotation3<f64>,
    /// Whether axis `i` is supported by this frame's planes or lines. With two observed
    /// axes the third follows by cross product; with one, the other two are carried
    /// over from the previous frame or, without history, arbitrary.
    pub observed: [bool; 3],
    /// Fraction of the frame's vote (planes and lines) within the inlier angle of each
    /// axis.
    pub support: [f32; 3],
    /// Confidence in [0, 1]: the weighted soft inlier fraction of the frame's
    /// directions, divided by 3 when only one axis is observed.
    pub confidence: f32,
}

impl ManhattanAxes {
    /// Axis `i` (0..3) in the camera frame, unit length.
    pub fn axis(&self, i: usize) -> Vector3<f64> {
        self.rotation.matrix().column(i).into_owned()
    }

    /// Number of observed axes.
    pub fn observed_count(&self) -> usize {
        self.observed.iter().filter(|&&o| o).count()
    }

    /// Whether axis `i` is known in this frame: observed, or completed from two observed
    /// axes.
    pub fn is_known(&self, i: usize) -> bool {
        self.observed.get(i).copied().unwrap_or(false) || self.observed_count() >= 2
    }

    /// The first-frame labelling: axes by decreasing support, each with its largest
    /// camera-frame component positive, the weakest flipped if needed for a right-handed
    /// frame.
    pub(crate) fn canonical(&self) -> Self {
        let mut order = [0, 1, 2];
        order.sort_by(|&a, &b| self.support[b].total_cmp(&self.support[a]));
        let mut cols = order.map(|k| {
            let a = self.axis(k);
            if a[a.iamax()] < 0.0 { -a } else { a }
        });
        if Matrix3::from_columns(&cols).determinant() < 0.0 {
            cols[2] = -cols[2];
        }
        Self {
            rotation: Rotation3::from_matrix_unchecked(Matrix3::from_columns(&cols)),
            observed: order.map(|k| self.observed[k]),
            support: order.map(|k| self.support[k]),
            confidence: self.confidence,
        }
    }
}

/// The six permutations of three axes.
const PERMUTATIONS: [[usize; 3]; 6] = [
    [0, 1, 2],
    [0, 2, 1],
    [1, 0, 2],
    [1, 2, 0],
    [2, 0, 1],
    [2, 1, 0],
];

/// Relabels `axes` so that axis `k` is the one closest to `predicted`'s axis `k` (the
/// permutation maximising the sum of |dot|) with the same sign. When that makes the
/// frame left-handed (only when the match is ambiguous, near 45 deg), the worst-matched
/// axis is flipped back.
pub(crate) fn match_to(axes: &ManhattanAxes, predicted: &Rotation3<f64>) -> ManhattanAxes {
    let dots = predicted.matrix().transpose() * axes.rotation.matrix();
    let Some(perm) = PERMUTATIONS.into_iter().max_by(|p, q| {
        let sum = |p: &[usize; 3]| (0..3).map(|k| dots[(k, p[k])].abs()).sum::<f64>();
        sum(p).total_cmp(&sum(q))
    }) else {
        return *axes;
    };
    let mut cols = [0, 1, 2].map(|k| axes.axis(perm[k]) * dots[(k, perm[k])].signum());
    if Matrix3::from_columns(&cols).determinant() < 0.0 {
        let worst = (0..3)
            .min_by(|&a, &b| {
                dots[(a, perm[a])]
                    .abs()
                    .total_cmp(&dots[(b, perm[b])].abs())
            })
            .unwrap_or(2);
        cols[worst] = -cols[worst];
    }
    ManhattanAxes {
        rotation: Rotation3::from_matrix_unchecked(Matrix3::from_columns(&cols)),
        observed: perm.map(|k| axes.observed[k]),
        support: perm.map(|k| axes.support[k]),
        confidence: axes.confidence,
    }
}

/// The rotation closest to `m` in the Frobenius norm (polar decomposition by SVD, with
/// the smallest singular direction flipped when `m` has a negative determinant).
/// `None` when the SVD does not converge or `m` is not finite.
pub(crate) fn closest_rotation(m: &Matrix3<f64>) -> Option<Rotation3<f64>> {
    if !m.iter().all(|x| x.is_finite()) {
        return None;
    }
    let svd = SVD::try_new(*m, true, true, 1e-12, 200)?;
    let (mut u, v_t) = (svd.u?, svd.v_t?);
    if (u * v_t).determinant() < 0.0 {
        let k = svd.singular_values.imin();
        u.column_mut(k).neg_mut();
    }
    Some(Rotation3::from_matrix_unchecked(u * v_t))
}

/// For each direction (camera frame, any sign or length), the index of the known axis
/// of `axes` it is parallel to within `max_angle_rad` (the closest one), or `None`.
/// `out` is cleared and refilled, one entry per direction.
pub fn associate_lines(
    axes: &ManhattanAxes,
    dirs: &[Vector3<f32>],
    max_angle_rad: f32,
    out: &mut Vec<Option<u8>>,
) {
    out.clear();
    let m = axes.rotation.matrix().transpose();
    let cos_max = f64::from(max_angle_rad).cos();
    out.extend(dirs.iter().map(|d| {
        let d = d.cast::<f64>().try_normalize(1e-12)?;
        let c = (m * d).abs();
        let k = c.imax();
        (c[k] >= cos_max && axes.is_known(k)).then_some(k as u8)
    }));
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axes(rotation: Rotation3<f64>, observed: [bool; 3]) -> ManhattanAxes {
        ManhattanAxes {
            rotation,
            observed,
            support: [0.5, 0.3, 0.2],
            confidence: 1.0,
        }
    }

    #[test]
    fn polar_projection_recovers_a_rotation_from_a_scaled_noisy_one() {
        let r = Rotation3::from_euler_angles(0.3, -1.1, 2.0);
        let m = r.matrix() * Matrix3::from_diagonal(&Vector3::new(5.0, 0.2, 0.0))
            + Matrix3::repeat(1e-9);
        let got = closest_rotation(&m).unwrap();
        // Matrix distance, not angle_to: acos of a trace rounded above 3 is NaN.
        let diff = (got.matrix() - r.matrix()).amax();
        assert!(diff < 1e-6, "{diff}");
        assert!(closest_rotation(&Matrix3::repeat(f64::NAN)).is_none());
    }

    #[test]
    fn matching_undoes_permutations_and_sign_flips() {
        let pred = Rotation3::from_euler_angles(0.2, 0.4, -0.3);
        let small = Rotation3::from_euler_angles(0.05, -0.03, 0.02);
        let truth = small * pred;
        let p = truth.matrix();
        // Columns shuffled to (2, 0, 1), with axes 0 and 2 of the result negated (det +1).
        let col = |k: usize| p.column(k).into_owned();
        let shuffled = Matrix3::from_columns(&[-col(2), col(0), -col(1)]);
        let a = axes(
            Rotation3::from_matrix_unchecked(shuffled),
            [true, false, true],
        );
        let m = match_to(&a, &pred);
        assert!((m.rotation.matrix() - truth.matrix()).amax() < 1e-12);
        assert_eq!(m.observed, [false, true, true]);
        assert_eq!(m.support, [0.3, 0.2, 0.5]);
    }

    #[test]
    fn lines_go_to_known_axes_within_the_angle() {
        let a = axes(Rotation3::identity(), [true, false, false]);
        let dirs = [
            Vector3::new(1.0, 0.05, 0.0), // 2.9 deg from x
            Vector3::new(-1.0, 0.0, 0.2), // 11.3 deg from x
            Vector3::new(0.0, 0.0, 3.0),  // z, but z is not known
            Vector3::new(0.0, 0.0, 0.0),  // no direction
        ];
        let mut out = Vec::new();
        associate_lines(&a, &dirs, 6f32.to_radians(), &mut out);
        assert_eq!(out, [Some(0), None, None, None]);
        let b = axes(Rotation3::identity(), [true, true, false]);
        associate_lines(&b, &dirs, 6f32.to_radians(), &mut out);
        assert_eq!(out, [Some(0), None, Some(2), None]);
    }
}
