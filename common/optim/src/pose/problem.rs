//! The blocks of one pose optimisation in their fixed order: points, lines, depth pairs,
//! planes, photometric, prior. The cost and the normal equations are summed over the
//! blocks in this order, term by term into one running sum, so the order of the
//! floating-point additions, and with it every result, does not depend on how the terms
//! are grouped in code; `for_each_block` is the one place that lists them.

use super::blocks::{
    Block, DepthBlock, Gate, LineBlock, PhotometricBlock, PlaneBlock, PointBlock, PriorBlock,
};
use super::lm::Normal;
use super::{
    LineObservation, PointObservation, PoseOptimizerConfig, PoseResult, SurfaceObservations,
};
use gfs_core::camera::PinholeCamera;
use nalgebra::{Isometry3, Matrix6};

/// The borrowed inputs of one pose optimisation, one block per term kind.
pub(super) struct PoseProblem<'a> {
    points: PointBlock<'a>,
    lines: LineBlock<'a>,
    depth: DepthBlock<'a>,
    planes: PlaneBlock<'a>,
    photometric: PhotometricBlock<'a>,
    prior: PriorBlock,
}

/// Runs `$body` with `$block` bound to each block of `$problem` in turn (statically
/// dispatched: each expansion sees its concrete block). `?` and `return` in `$body`
/// leave the enclosing function. The list of fields is the order of the sums.
macro_rules! for_each_block {
    ($problem:expr, |$block:ident| $body:expr) => {{
        let problem: &PoseProblem<'_> = $problem;
        for_each_block!(@in problem, $block, $body; points, lines, depth, planes, photometric, prior);
    }};
    (@in $problem:ident, $block:ident, $body:expr; $($field:ident),*) => {
        $({
            let $block = &$problem.$field;
            $body
        })*
    };
}

impl<'a> PoseProblem<'a> {
    pub(super) fn new(
        camera: &'a PinholeCamera,
        points: &'a [PointObservation],
        lines: &'a [LineObservation],
        surfaces: SurfaceObservations<'a>,
        config: &PoseOptimizerConfig,
    ) -> Self {
        Self {
            points: PointBlock::new(camera, points, config),
            lines: LineBlock::new(camera, lines, config),
            depth: DepthBlock::new(camera, surfaces.depth, config),
            planes: PlaneBlock::new(surfaces.planes, config),
            photometric: PhotometricBlock::new(camera, surfaces.photometric, config),
            prior: PriorBlock::new(surfaces.prior),
        }
    }

    /// Sizes the inlier flags of `result` to the observations, every one `true`.
    pub(super) fn reset(&self, result: &mut PoseResult) {
        for_each_block!(self, |block| {
            if let Some(inliers) = block.inlier_flags(result) {
                inliers.flags.clear();
                inliers.flags.resize(block.num_observations(), true);
            }
        });
    }

    /// Flags every observation inlier / outlier at `pose` and counts the inliers.
    pub(super) fn classify(&self, pose: &Isometry3<f64>, gate: Gate, result: &mut PoseResult) {
        for_each_block!(self, |block| {
            if let Some(inliers) = block.inlier_flags(result) {
                block.classify(pose, gate, inliers.flags);
                *inliers.count = inliers.flags.iter().filter(|&&f| f).count();
            }
        });
    }

    /// Cost of the inliers (and the prior); `None` when one of them is not valid at
    /// `pose` (a step that pushes an inlier behind the camera is rejected).
    pub(super) fn cost(
        &self,
        pose: &Isometry3<f64>,
        result: &PoseResult,
        robust: bool,
    ) -> Option<f64> {
        let mut cost = 0.0;
        for_each_block!(self, |block| {
            cost = block.cost(pose, block.inliers(result), robust, cost)?;
        });
        cost.is_finite().then_some(cost)
    }

    /// Builds `H = sum J^T w Omega J` and `g = sum J^T w Omega e` at `pose`.
    pub(super) fn linearize(
        &self,
        pose: &Isometry3<f64>,
        result: &PoseResult,
        robust: bool,
    ) -> Normal {
        let mut normal = Normal::zeros();
        for_each_block!(self, |block| {
            block.linearize(pose, block.inliers(result), robust, &mut normal);
        });
        normal
    }

    /// The prior's information at `pose`, to take out of the posterior's.
    pub(super) fn prior_information(&self, pose: &Isometry3<f64>) -> Matrix6<f64> {
        self.prior.information_at(pose)
    }

    /// What the dense blocks' inliers at `pose` lend beyond what their errors'
    /// correlation across the image supports (summed over the blocks); zero with
    /// `tile_px` 0.
    pub(super) fn correlated_excess(
        &self,
        pose: &Isometry3<f64>,
        result: &mut PoseResult,
        tile_px: f64,
    ) -> Matrix6<f64> {
        let mut excess = Matrix6::zeros();
        if tile_px <= 0.0 {
            return excess;
        }
        let mut tile_scores = std::mem::take(&mut result.tile_scores);
        for_each_block!(self, |block| {
            excess +=
                block.correlated_excess(pose, block.inliers(result), tile_px, &mut tile_scores);
        });
        result.tile_scores = tile_scores;
        excess
    }

    /// RMS of the inliers' pixel residual components; 0 without any.
    pub(super) fn inlier_rms(&self, pose: &Isometry3<f64>, result: &PoseResult) -> f64 {
        let mut sum = 0.0;
        let mut components = 0usize;
        for_each_block!(self, |block| {
            block.add_pixel_residuals(pose, block.inliers(result), &mut sum, &mut components);
        });
        if components == 0 {
            0.0
        } else {
            (sum / components as f64).sqrt()
        }
    }
}
