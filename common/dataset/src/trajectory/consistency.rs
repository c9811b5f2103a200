//! Consistency of reported covariances with the actual error: the normalised estimation
//! error squared (NEES) of each frame-to-frame motion.
//!
//! For consecutive estimated poses `A = T_wc(k-1)`, `B = T_wc(k)` (camera to world)
//! with covariances `Ca`, `Cb` (see [`Covariances`]: true pose `T exp(e)`, `e ~ N(0, C)`
//! in the camera's axes), the estimated motion is `M = A^-1 B` and the true one
//! `M_true = exp(-ea) M exp(eb)`, so its error in frame `k`'s axes, to first order,
//! `d = log(M^-1 M_true) = eb - Ad(M^-1) ea` has the covariance
//! `S = Cb + Ad(M^-1) Ca Ad(M^-1)^T` (the two poses' errors taken as independent), and
//! the NEES of the pair is `d^T S^-1 d` with `d = log(M^-1 G)`, `G` the ground-truth
//! motion between the matched ground-truth poses. For a consistent estimate it follows a
//! chi-square law with 6 degrees of freedom: mean 6, 0.1 % of the pairs beyond 22.46.

use super::associate::associate;
use super::covariances::Covariances;
use super::tum::Trajectory;
use gfs_core::se3;
use nalgebra::{Isometry3, Matrix6};

/// The 99.9 % quantile of the chi-square law with 6 degrees of freedom.
pub const CHI2_6DOF_999: f64 = 22.458;

/// The NEES of each frame-to-frame motion and what they sum up to.
#[derive(Clone, Debug, PartialEq)]
pub struct Consistency {
    /// Consecutive matched pairs (estimated poses next to each other whose ground truth
    /// was found).
    pub pairs: usize,
    /// NEES of each pair whose two poses have a covariance, in time order.
    pub nees: Vec<f64>,
    /// Mean of `nees` (6 for a consistent 6-DoF estimate); `None` without any.
    pub mean_nees: Option<f64>,
    /// Share of `nees` beyond [`CHI2_6DOF_999`] (0.001 for a consistent estimate).
    pub beyond_bound: Option<f64>,
    /// Median translation error of the frame-to-frame motions of all pairs, metres.
    pub median_translation_error_m: Option<f64>,
    /// Median of the standard deviation the covariances give the translation of a pair
    /// (square root of the trace of `S`'s translation block), metres.
    pub median_reported_sigma_m: Option<f64>,
}

/// The NEES of the frame-to-frame motions of `est` against `gt` under `covariances`
/// (poses associated by timestamp within `max_diff` s, as [`super::evaluate`]; a pose
/// whose covariance is missing leaves its two pairs out of the NEES, not out of the
/// translation error).
pub fn consistency(
    gt: &Trajectory,
    est: &Trajectory,
    covariances: &Covariances,
    max_diff: f64,
) -> Consistency {
    let matches = associate(gt, est, max_diff);
    let mut translation_errors = Vec::new();
    let mut reported = Vec::new();
    let mut nees = Vec::new();
    let mut pairs = 0;
    for pair in matches.windows(2) {
        let ((g0, e0), (g1, e1)) = (pair[0], pair[1]);
        if e1 != e0 + 1 {
            continue;
        }
        pairs += 1;
        let (a, b) = (&est.poses()[e0], &est.poses()[e1]);
        let motion = a.inverse() * b;
        let truth = gt.poses()[g0].inverse() * gt.poses()[g1];
        let error = motion.inverse() * truth;
        translation_errors.push(error.translation.vector.norm());
        let stamps = est.timestamps();
        let (Some(ca), Some(cb)) = (
            covariances.at(stamps[e0], max_diff),
            covariances.at(stamps[e1], max_diff),
        ) else {
            continue;
        };
        let s = motion_covariance(&motion, ca, cb);
        let d = se3::log(&error);
        if let Some(inverse) = s.try_inverse() {
            nees.push((d.transpose() * inverse * d)[(0, 0)]);
            reported.push(s.fixed_view::<3, 3>(0, 0).trace().max(0.0).sqrt());
        }
    }
    let mean = |v: &[f64]| (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64);
    let beyond = (!nees.is_empty())
        .then(|| nees.iter().filter(|&&n| n > CHI2_6DOF_999).count() as f64 / nees.len() as f64);
    Consistency {
        pairs,
        mean_nees: mean(&nees),
        beyond_bound: beyond,
        median_translation_error_m: median(&mut translation_errors),
        median_reported_sigma_m: median(&mut reported),
        nees,
    }
}

/// The covariance of the error of the motion `M = A^-1 B` in `B`'s axes for pose
/// covariances `ca` of `A` and `cb` of `B`: `cb + Ad(M^-1) ca Ad(M^-1)^T`.
pub fn motion_covariance(
    motion: &Isometry3<f64>,
    ca: &Matrix6<f64>,
    cb: &Matrix6<f64>,
) -> Matrix6<f64> {
    let ad = se3::adjoint(&motion.inverse());
    cb + ad * ca * ad.transpose()
}

fn median(values: &mut [f64]) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    values.sort_by(f64::total_cmp);
    let n = values.len();
    Some(if n % 2 == 1 {
        values[n / 2]
    } else {
        0.5 * (values[n / 2 - 1] + values[n / 2])
    })
}
