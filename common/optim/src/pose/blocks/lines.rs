//! Map lines against 2D lines (paper eq. 7): the distances of the projected endpoints
//! to the observed line, two pixel errors of one sigma.

use super::{Block, Gate, flag_within_gate, flagged, sum_costs};
use crate::pose::lm::Normal;
use crate::pose::{LineObservation, PoseOptimizerConfig};
use crate::residuals::LineReprojection;
use crate::robust::Huber;
use gfs_core::camera::PinholeCamera;
use nalgebra::{Isometry3, Vector2};

/// The line observations with their kernel and threshold.
pub(crate) struct LineBlock<'a> {
    camera: &'a PinholeCamera,
    observations: &'a [LineObservation],
    chi2: f64,
    huber: Huber,
}

impl<'a> LineBlock<'a> {
    pub(crate) fn new(
        camera: &'a PinholeCamera,
        observations: &'a [LineObservation],
        config: &PoseOptimizerConfig,
    ) -> Self {
        Self {
            camera,
            observations,
            chi2: config.line_chi2,
            huber: Huber::from_chi2(config.line_chi2),
        }
    }

    /// The endpoint distances, pixels; `None` behind the camera.
    fn error(&self, pose: &Isometry3<f64>, obs: &LineObservation) -> Option<Vector2<f64>> {
        LineReprojection { coeffs: obs.coeffs }.error(self.camera, pose, &obs.endpoints_in_world)
    }
}

impl Block for LineBlock<'_> {
    fn num_observations(&self) -> usize {
        self.observations.len()
    }

    inlier_fields!(line_inliers, num_line_inliers);

    fn cost(&self, pose: &Isometry3<f64>, inliers: &[bool], robust: bool, sum: f64) -> Option<f64> {
        sum_costs(self.observations, inliers, robust, sum, |obs| {
            Some((
                obs.inv_sigma2 * self.error(pose, obs)?.norm_squared(),
                &self.huber,
            ))
        })
    }

    fn linearize(
        &self,
        pose: &Isometry3<f64>,
        inliers: &[bool],
        robust: bool,
        normal: &mut Normal,
    ) {
        for obs in flagged(self.observations, inliers) {
            let r = LineReprojection { coeffs: obs.coeffs };
            if let Some(l) = r.linearize(self.camera, pose, &obs.endpoints_in_world) {
                normal.add(
                    &l.d_pose,
                    &l.error,
                    obs.inv_sigma2,
                    robust.then_some(&self.huber),
                );
            }
        }
    }

    fn classify(&self, pose: &Isometry3<f64>, gate: Gate, inliers: &mut [bool]) {
        flag_within_gate(self.observations, gate, inliers, |obs| {
            if obs.inv_sigma2 <= 0.0 {
                return None;
            }
            Some((
                obs.inv_sigma2 * self.error(pose, obs)?.norm_squared(),
                self.chi2,
            ))
        });
    }

    fn add_pixel_residuals(
        &self,
        pose: &Isometry3<f64>,
        inliers: &[bool],
        sum: &mut f64,
        components: &mut usize,
    ) {
        for obs in flagged(self.observations, inliers) {
            if let Some(e) = self.error(pose, obs) {
                *sum += e.norm_squared();
                *components += 2;
            }
        }
    }
}
