//! The term kinds of a pose optimisation, one block each. A block holds its borrowed
//! observations with its kernel and chi-square threshold, and knows the three things a
//! round asks of it: its cost, its share of the normal equations and which of its
//! observations are inliers. A new term kind is a new block here, its field and its
//! arm in `problem.rs`, its public input in `observations.rs` and its inlier flags in
//! `result.rs`; the driver and the LM loop do not change.

/// The [`Block`] accessors of a block whose inlier flags and count are the fields
/// `$flags` and `$count` of [`PoseResult`].
macro_rules! inlier_fields {
    ($flags:ident, $count:ident) => {
        fn inliers<'r>(&self, result: &'r $crate::pose::PoseResult) -> &'r [bool] {
            &result.$flags
        }

        fn inlier_flags<'r>(
            &self,
            result: &'r mut $crate::pose::PoseResult,
        ) -> Option<$crate::pose::blocks::InlierFlags<'r>> {
            Some($crate::pose::blocks::InlierFlags {
                flags: &mut result.$flags,
                count: &mut result.$count,
            })
        }
    };
}

mod depth;
mod lines;
mod photometric;
mod planes;
mod points;
mod prior;

pub(crate) use depth::DepthBlock;
pub(crate) use lines::LineBlock;
pub(crate) use photometric::PhotometricBlock;
pub(crate) use planes::PlaneBlock;
pub(crate) use points::PointBlock;
pub(crate) use prior::PriorBlock;

use super::lm::Normal;
use super::result::PoseResult;
use crate::robust::Huber;
use nalgebra::{Isometry3, Matrix6, Vector6};

/// Which observations a classification lets through.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Gate {
    /// Every observation that can be evaluated (the start of the first round, as
    /// ORB-SLAM2).
    Open,
    /// Those within their chi-square threshold.
    ChiSquare,
}

impl Gate {
    /// The threshold on a squared whitened error whose chi-square quantile is `chi2`.
    pub(crate) fn threshold(self, chi2: f64) -> f64 {
        match self {
            Gate::Open => f64::INFINITY,
            Gate::ChiSquare => chi2,
        }
    }
}

/// The inlier flags of one term kind in a [`PoseResult`] and their count.
pub(crate) struct InlierFlags<'r> {
    pub(crate) flags: &'r mut Vec<bool>,
    pub(crate) count: &'r mut usize,
}

/// One term kind of the pose optimisation. `inliers` is always the block's own flags
/// (from [`Block::inliers`]), one per observation in input order; a block only ever
/// evaluates the flagged ones, except in [`Block::classify`].
pub(crate) trait Block {
    /// Observations in the block (the length of its inlier flags).
    fn num_observations(&self) -> usize;

    /// The block's inlier flags in `result`; empty for a block without (the prior).
    fn inliers<'r>(&self, result: &'r PoseResult) -> &'r [bool];

    /// The block's inlier flags and count in `result`; `None` for a block without.
    fn inlier_flags<'r>(&self, result: &'r mut PoseResult) -> Option<InlierFlags<'r>>;

    /// `sum` plus the cost of the inliers at `pose`, Huber-robustified when `robust`;
    /// `None` when one of them cannot be evaluated there and the pose is refused.
    fn cost(&self, pose: &Isometry3<f64>, inliers: &[bool], robust: bool, sum: f64) -> Option<f64>;

    /// Adds the inliers' linearisation at `pose` to `normal`, Huber-weighted when
    /// `robust`.
    fn linearize(&self, pose: &Isometry3<f64>, inliers: &[bool], robust: bool, normal: &mut Normal);

    /// Flags each observation inlier when its chi-square at `pose` passes `gate`
    /// (invalid or non-finite: outlier).
    fn classify(&self, pose: &Isometry3<f64>, gate: Gate, inliers: &mut [bool]);

    /// The information the block's inliers at `pose` lend beyond what their scores'
    /// spread over image tiles of `tile_px` supports, `tile_scores` the tiles' buffer
    /// ([`crate::pose::correlation`]); zero for a block of independent observations.
    fn correlated_excess(
        &self,
        _pose: &Isometry3<f64>,
        _inliers: &[bool],
        _tile_px: f64,
        _tile_scores: &mut Vec<Vector6<f64>>,
    ) -> Matrix6<f64> {
        Matrix6::zeros()
    }

    /// Adds the squared pixel residuals of the inliers at `pose` and their component
    /// count, for [`PoseResult::rms_error_px`]; only the pixel terms (points, lines)
    /// have any.
    fn add_pixel_residuals(
        &self,
        _pose: &Isometry3<f64>,
        _inliers: &[bool],
        _sum: &mut f64,
        _components: &mut usize,
    ) {
    }
}

/// The observations flagged in `inliers`.
pub(crate) fn flagged<'o, T>(
    observations: &'o [T],
    inliers: &'o [bool],
) -> impl Iterator<Item = &'o T> {
    observations
        .iter()
        .zip(inliers)
        .filter(|(_, f)| **f)
        .map(|(obs, _)| obs)
}

/// `sum` plus the cost of each flagged observation: its squared whitened error with its
/// kernel from `whitened2`, Huber-robustified when `robust`; `None` as soon as one
/// cannot be evaluated (the pose is refused). The one accumulation of the blocks whose
/// terms are whitened errors.
pub(crate) fn sum_costs<'h, T>(
    observations: &[T],
    inliers: &[bool],
    robust: bool,
    mut sum: f64,
    whitened2: impl Fn(&T) -> Option<(f64, &'h Huber)>,
) -> Option<f64> {
    for obs in flagged(observations, inliers) {
        let (s, huber) = whitened2(obs)?;
        sum += if robust { huber.cost(s) } else { s };
    }
    Some(sum)
}

/// Flags each observation inlier when its squared whitened error, with the chi-square
/// quantile of its degrees of freedom, from `whitened2` passes `gate`; `None` (not
/// evaluable, or an observation without weight) is an outlier.
pub(crate) fn flag_within_gate<T>(
    observations: &[T],
    gate: Gate,
    inliers: &mut [bool],
    whitened2: impl Fn(&T) -> Option<(f64, f64)>,
) {
    for (flag, obs) in inliers.iter_mut().zip(observations) {
        *flag = whitened2(obs).is_some_and(|(s, chi2)| s <= gate.threshold(chi2));
    }
}
