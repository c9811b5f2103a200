//! ATE and RPE with evo's definitions (`evo_ape tum GT EST --align`, `evo_rpe tum GT EST`),
//! plus the per-second RPE of the TUM benchmark tool `evaluate_rpe.py --fixed_delta`.

use super::Trajectory;
use super::align::{AlignError, umeyama_se3};
use super::associate::{associate, closest_index};
use nalgebra::{Isometry3, Point3, UnitQuaternion};
use serde::Serialize;
use thiserror::Error;

/// Trajectories could not be evaluated against each other.
#[derive(Debug, Error)]
pub enum EvalError {
    /// No pose of the estimate has a ground-truth pose within `max_diff`.
    #[error(
        "no matching timestamps between ground truth ({gt_len} poses) and estimate \
         ({est_len} poses) within {max_diff} s"
    )]
    NoMatches {
        /// Ground-truth poses.
        gt_len: usize,
        /// Estimated poses.
        est_len: usize,
        /// The association window, s.
        max_diff: f64,
    },
    /// The matched positions could not be aligned.
    #[error("alignment failed: {0}")]
    Align(#[from] AlignError),
}

/// Summary statistics of a list of errors, as evo prints them (`std` is the population
/// standard deviation, `median` averages the two middle values of an even count).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Stats {
    /// Root mean square.
    pub rmse: f64,
    /// Mean.
    pub mean: f64,
    /// Median.
    pub median: f64,
    /// Population standard deviation.
    pub std: f64,
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
    /// Number of values.
    pub count: usize,
}

impl Stats {
    /// Statistics of `values`; `None` when there is none.
    pub fn from_values(values: &[f64]) -> Option<Stats> {
        if values.is_empty() {
            return None;
        }
        let n = values.len() as f64;
        let mean = values.iter().sum::<f64>() / n;
        let rmse = (values.iter().map(|v| v * v).sum::<f64>() / n).sqrt();
        let std = (values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n).sqrt();
        let mut sorted = values.to_vec();
        sorted.sort_by(f64::total_cmp);
        let mid = sorted.len() / 2;
        let median = if sorted.len().is_multiple_of(2) {
            0.5 * (sorted[mid - 1] + sorted[mid])
        } else {
            sorted[mid]
        };
        Some(Stats {
            rmse,
            mean,
            median,
            std,
            min: sorted[0],
            max: sorted[sorted.len() - 1],
            count: values.len(),
        })
    }
}

/// Absolute trajectory error after rigid alignment.
#[derive(Clone, Debug)]
pub struct Ate {
    /// `gt_world_from_est_world`: the Umeyama alignment applied to the estimate.
    pub alignment: Isometry3<f64>,
    /// Translation error of each matched pose after alignment, m.
    pub errors_m: Vec<f64>,
    /// Statistics of `errors_m`.
    pub stats: Stats,
}

/// Relative pose error over pairs of matched poses.
#[derive(Clone, Debug)]
pub struct Rpe {
    /// The pairs `(i, j)` of matched-pose indices compared.
    pub pairs: Vec<(usize, usize)>,
    /// Translation error of each pair, m.
    pub trans_errors_m: Vec<f64>,
    /// Rotation error of each pair, degrees.
    pub rot_errors_deg: Vec<f64>,
    /// Statistics of the translation errors, m.
    pub trans_m: Stats,
    /// Statistics of the rotation errors, degrees.
    pub rot_deg: Stats,
}

/// Everything `gfsvo eval` reports.
#[derive(Clone, Debug)]
pub struct Evaluation {
    /// Poses in the ground truth file.
    pub gt_poses: usize,
    /// Poses in the estimate.
    pub est_poses: usize,
    /// Association window used, s.
    pub max_diff: f64,
    /// The ground-truth poses that were matched, in estimate order.
    pub gt_matched: Trajectory,
    /// The matched estimated poses, moved into the ground-truth frame by `ate.alignment`.
    pub est_aligned: Trajectory,
    /// ATE (`evo_ape tum GT EST --align`).
    pub ate: Ate,
    /// RPE between consecutive matched poses (`evo_rpe tum GT EST`, delta 1 frame);
    /// `None` with fewer than 2 matches.
    pub rpe_frame: Option<Rpe>,
    /// RPE between matched poses about 1 s apart (TUM `evaluate_rpe.py --fixed_delta`);
    /// `None` when the matches span less than about a second.
    pub rpe_second: Option<Rpe>,
}

impl Evaluation {
    /// Number of matched poses.
    pub fn matched(&self) -> usize {
        self.gt_matched.len()
    }
}

/// Evaluates `est` against `gt`: association within `max_diff` seconds (evo's rule),
/// ATE after SE(3) Umeyama alignment, RPE per frame and per second.
///
/// # Errors
/// [`EvalError::NoMatches`] when nothing associates; [`EvalError::Align`] when the
/// positions are not finite.
pub fn evaluate(gt: &Trajectory, est: &Trajectory, max_diff: f64) -> Result<Evaluation, EvalError> {
    let pairs = associate(gt, est, max_diff);
    if pairs.is_empty() {
        return Err(EvalError::NoMatches {
            gt_len: gt.len(),
            est_len: est.len(),
            max_diff,
        });
    }
    let gt_matched = gt.select(pairs.iter().map(|p| p.0));
    let est_matched = est.select(pairs.iter().map(|p| p.1));
    let ate = ate(&gt_matched, &est_matched)?;
    Ok(Evaluation {
        gt_poses: gt.len(),
        est_poses: est.len(),
        max_diff,
        est_aligned: est_matched.transformed(&ate.alignment),
        rpe_frame: rpe_per_frame(&gt_matched, &est_matched),
        rpe_second: rpe_per_second(&gt_matched, &est_matched),
        gt_matched,
        ate,
    })
}

fn positions(t: &Trajectory) -> Vec<Point3<f64>> {
    t.poses()
        .iter()
        .map(|p| Point3::from(p.translation.vector))
        .collect()
}

/// ATE of already matched trajectories (pose `k` of one with pose `k` of the other):
/// the estimate is aligned onto the ground truth with [`umeyama_se3`] (no scale), then
/// the error of each pose is the distance between the positions.
///
/// # Errors
/// [`EvalError::Align`] for empty, unequal or non-finite input.
pub fn ate(gt_matched: &Trajectory, est_matched: &Trajectory) -> Result<Ate, EvalError> {
    let (p_gt, p_est) = (positions(gt_matched), positions(est_matched));
    let alignment = umeyama_se3(&p_est, &p_gt)?;
    let errors_m: Vec<f64> = p_est
        .iter()
        .zip(&p_gt)
        .map(|(e, g)| (alignment * e - g).norm())
        .collect();
    let stats = Stats::from_values(&errors_m).ok_or(AlignError::BadInput {
        source_len: 0,
        target_len: 0,
    })?;
    Ok(Ate {
        alignment,
        errors_m,
        stats,
    })
}

/// Rotation angle of `q` in radians, accurate for small angles too.
fn angle(q: &UnitQuaternion<f64>) -> f64 {
    2.0 * q.imag().norm().atan2(q.scalar().abs())
}

/// How the relative error of a pair is composed from the relative motions
/// `A = P_i^-1 P_j` (estimate) and `B = Q_i^-1 Q_j` (ground truth). The rotation angle is
/// the same either way; the translation differs to second order in the rotation error.
#[derive(Clone, Copy)]
enum ErrorOrder {
    /// evo: `E = B^-1 A`.
    Evo,
    /// TUM `evaluate_rpe.py`: `E = A B^-1` (its `ominus(ominus(est_j, est_i), ...)`).
    Tum,
}

/// RPE over given pairs, with `Q` the ground truth and `P` the estimate; the errors are
/// `|trans(E)|` and the rotation angle of `E`.
fn rpe_over(
    gt: &Trajectory,
    est: &Trajectory,
    pairs: Vec<(usize, usize)>,
    order: ErrorOrder,
) -> Option<Rpe> {
    let (q, p) = (gt.poses(), est.poses());
    let mut trans_errors_m = Vec::with_capacity(pairs.len());
    let mut rot_errors_deg = Vec::with_capacity(pairs.len());
    for &(i, j) in &pairs {
        let a = p[i].inverse() * p[j];
        let b = q[i].inverse() * q[j];
        let e = match order {
            ErrorOrder::Evo => b.inverse() * a,
            ErrorOrder::Tum => a * b.inverse(),
        };
        trans_errors_m.push(e.translation.vector.norm());
        rot_errors_deg.push(angle(&e.rotation).to_degrees());
    }
    Some(Rpe {
        trans_m: Stats::from_values(&trans_errors_m)?,
        rot_deg: Stats::from_values(&rot_errors_deg)?,
        pairs,
        trans_errors_m,
        rot_errors_deg,
    })
}

/// RPE between consecutive matched poses (evo's default: delta 1 frame, consecutive
/// pairs). `None` with fewer than 2 poses.
pub fn rpe_per_frame(gt_matched: &Trajectory, est_matched: &Trajectory) -> Option<Rpe> {
    let n = gt_matched.len().min(est_matched.len());
    rpe_over(
        gt_matched,
        est_matched,
        (1..n).map(|j| (j - 1, j)).collect(),
        ErrorOrder::Evo,
    )
}

/// RPE over 1 s, as `evaluate_rpe.py --fixed_delta --delta 1 --delta_unit s`: every
/// matched pose `i` is paired with the matched pose whose stamp is closest to `t_i + 1 s`,
/// unless that is the last pose (the search ran off the end) or `i` itself; the error is
/// composed as that tool does (`E = A B^-1`, see `ErrorOrder`). Unlike the tool, which
/// pairs each estimate with the ground truth within two ground-truth periods, the
/// poses are those matched within `max_diff`.
pub fn rpe_per_second(gt_matched: &Trajectory, est_matched: &Trajectory) -> Option<Rpe> {
    const DELTA_S: f64 = 1.0;
    let stamps = est_matched.seconds();
    let n = stamps.len().min(gt_matched.len());
    let stamps = &stamps[..n];
    let pairs = (0..n)
        .filter_map(|i| {
            let j = closest_index(stamps, stamps[i] + DELTA_S)?;
            (j + 1 != n && j > i).then_some((i, j))
        })
        .collect();
    rpe_over(gt_matched, est_matched, pairs, ErrorOrder::Tum)
}
