//! What a dense term (the photometric term, the depth pairs) lends the pose beyond what
//! its errors support when they are correlated across the image.
//!
//! Its information `H = sum J^T w J` counts every pixel as an independent measurement.
//! A smooth error (a vignetting estimate not yet converged, a sensor's low-frequency
//! disparity error) moves whole regions of the image together: the pose fits it as
//! motion, and `H` says nothing of it. The term's scores `w J^T e`, summed over image
//! tiles larger than most of that error's wavelengths, show it (the cluster-robust or
//! "sandwich" covariance of the estimate, `H^-1 M H^-1` with `M` the sum of the tiles'
//! score products): in `H`'s whitened axes (`H = L L^T`) the spread `S = L^-1 M L^-T`
//! is the identity for independent errors, and a direction along which it exceeds 1 is
//! known only `1 / s` as well as `H` says. The excess `L (I - 1 / max(S, 1)) L^T` is
//! what the pose's information loses; the term never lends more than `H` (a spread
//! below 1, a lucky draw of few tiles, is not taken as more information).

use crate::map_eigenvalues;
use gfs_core::camera::PinholeCamera;
use nalgebra::{Matrix6, Point2, Vector6};

/// The scores of one term's observations summed over square tiles of the image.
pub(crate) struct TileScores<'s> {
    tile_px: f64,
    columns: usize,
    rows: usize,
    scores: &'s mut Vec<Vector6<f64>>,
}

impl<'s> TileScores<'s> {
    /// Zeroed tiles of `tile_px` pixels over `camera`'s image, in the reused `scores`.
    pub(crate) fn new(
        camera: &PinholeCamera,
        tile_px: f64,
        scores: &'s mut Vec<Vector6<f64>>,
    ) -> Self {
        let tile_px = tile_px.max(1.0);
        let columns = ((camera.width as f64 / tile_px).ceil() as usize).max(1);
        let rows = ((camera.height as f64 / tile_px).ceil() as usize).max(1);
        scores.clear();
        scores.resize(columns * rows, Vector6::zeros());
        Self {
            tile_px,
            columns,
            rows,
            scores,
        }
    }

    /// Adds the score `J^T w e` of an observation at pixel `uv` (clamped to the image).
    pub(crate) fn add(&mut self, uv: &Point2<f64>, score: &Vector6<f64>) {
        let tile = |x: f64, n: usize| ((x / self.tile_px).max(0.0) as usize).min(n - 1);
        let (i, j) = (tile(uv.x, self.columns), tile(uv.y, self.rows));
        self.scores[j * self.columns + i] += score;
    }

    /// The information `information` (the term's `H`) lends beyond what the spread of
    /// the tiles' scores supports (module doc); zero where it supports all of it.
    pub(crate) fn excess(&self, information: &Matrix6<f64>) -> Matrix6<f64> {
        let spread: Matrix6<f64> = self.scores.iter().map(|g| g * g.transpose()).sum();
        excess_over(information, &spread)
    }
}

/// `L (I - 1 / max(S, 1)) L^T` with `H = L L^T`, `S = L^-1 M L^-T`. `H` is made
/// positive definite by a relative `1e-12` of its trace: a direction it leaves free
/// lends nothing to lose.
fn excess_over(information: &Matrix6<f64>, spread: &Matrix6<f64>) -> Matrix6<f64> {
    let trace = information.trace();
    if trace.is_nan() || trace <= 0.0 {
        return Matrix6::zeros();
    }
    let regularised = information + Matrix6::identity() * (1e-12 * trace);
    let Some(l) = regularised.cholesky().map(|c| c.l()) else {
        return Matrix6::zeros();
    };
    let Some(l_inv) = l.try_inverse() else {
        return Matrix6::zeros();
    };
    let whitened = l_inv * spread * l_inv.transpose();
    let lost = map_eigenvalues(&whitened, |s| 1.0 - 1.0 / s.max(1.0));
    l * lost * l.transpose()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::residuals::testing::SplitMix64;

    /// A term of 4800 unit-weight observations on a 640 x 480 image, each with the
    /// Jacobian of a slide along x scaled by `lever`, and errors `noise` (white, unit
    /// variance) plus `smooth` (one value per 160 px block: correlated over the block).
    fn excess_of(smooth: f64, seed: u64) -> (Matrix6<f64>, Matrix6<f64>) {
        let camera = PinholeCamera::new(500.0, 500.0, 320.0, 240.0, 640, 480);
        let mut rng = SplitMix64::new(seed);
        let mut gaussian = || (0..12).map(|_| rng.uniform(0.0, 1.0)).sum::<f64>() - 6.0;
        let blocks: Vec<f64> = (0..12).map(|_| smooth * gaussian()).collect();
        let mut buffer = Vec::new();
        let mut tiles = TileScores::new(&camera, 80.0, &mut buffer);
        let mut information = Matrix6::zeros();
        for j in 0..60 {
            for i in 0..80 {
                let uv = Point2::new(i as f64 * 8.0 + 4.0, j as f64 * 8.0 + 4.0);
                // Two directions measured: a slide along x and a tilt's share.
                let jacobian = Vector6::new(1.0, 0.0, 0.0, 0.0, (uv.x - 320.0) / 320.0, 0.0);
                let block = blocks[(j * 8 / 160) * 4 + i * 8 / 160];
                let e = gaussian() + block;
                information += jacobian * jacobian.transpose();
                tiles.add(&uv, &(jacobian * e));
            }
        }
        (information, tiles.excess(&information))
    }

    #[test]
    fn independent_errors_keep_nearly_all_their_information() {
        // White errors: the tiles' spread is the information, up to the draw of 48
        // tiles; at most a third of the slide's information is lost.
        for seed in 0..5 {
            let (information, excess) = excess_of(0.0, seed);
            let kept = 1.0 - excess[(0, 0)] / information[(0, 0)];
            assert!(kept > 0.67, "seed {seed}: kept {kept}");
        }
    }

    #[test]
    fn a_smooth_error_leaves_the_information_of_its_blocks() {
        // An error of 1 (the white noise's sigma) shared by 400 observations of a block:
        // the slide is known as from about 12 blocks, not 4800 pixels; a tenth of its
        // information or less is kept.
        for seed in 0..5 {
            let (information, excess) = excess_of(1.0, seed);
            let kept = 1.0 - excess[(0, 0)] / information[(0, 0)];
            assert!(kept < 0.1, "seed {seed}: kept {kept}");
            // Unmeasured directions lose nothing.
            assert!(
                excess[(1, 1)].abs() < 1e-6 * information[(0, 0)],
                "{excess}"
            );
        }
    }
}
