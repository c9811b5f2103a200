//! Map points against keypoints (paper eq. 6): the 2D reprojection error, or with a
//! measured depth the RGB-D error whose virtual disparity `bf / depth` fixes depth and
//! scale. The two have their own degrees of freedom, so their own threshold and kernel.

use super::{Block, Gate, flag_within_gate, flagged, sum_costs};
use crate::pose::lm::Normal;
use crate::pose::{PointObservation, PoseOptimizerConfig};
use crate::residuals::{PointReprojection, StereoPointReprojection};
use crate::robust::Huber;
use gfs_core::camera::PinholeCamera;
use nalgebra::Isometry3;

/// The point observations with their kernels and thresholds.
pub(crate) struct PointBlock<'a> {
    camera: &'a PinholeCamera,
    observations: &'a [PointObservation],
    /// Virtual stereo `baseline x fx`, metres x pixels.
    bf: f64,
    /// 2 dof, without depth.
    chi2: f64,
    huber: Huber,
    /// 3 dof, with depth.
    depth_chi2: f64,
    depth_huber: Huber,
}

impl<'a> PointBlock<'a> {
    pub(crate) fn new(
        camera: &'a PinholeCamera,
        observations: &'a [PointObservation],
        config: &PoseOptimizerConfig,
    ) -> Self {
        Self {
            camera,
            observations,
            bf: config.bf,
            chi2: config.point_chi2,
            huber: Huber::from_chi2(config.point_chi2),
            depth_chi2: config.point_depth_chi2,
            depth_huber: Huber::from_chi2(config.point_depth_chi2),
        }
    }

    /// Squared residual norm of an observation (unweighted) and whether it has depth;
    /// `None` behind the camera.
    fn residual2(&self, pose: &Isometry3<f64>, obs: &PointObservation) -> Option<(f64, bool)> {
        if obs.depth > 0.0 {
            let r = StereoPointReprojection::from_depth(obs.uv, obs.depth, self.bf, 1.0);
            Some((
                r.error(self.camera, pose, &obs.point_in_world)?
                    .norm_squared(),
                true,
            ))
        } else {
            let r = PointReprojection { uv: obs.uv };
            Some((
                r.error(self.camera, pose, &obs.point_in_world)?
                    .norm_squared(),
                false,
            ))
        }
    }

    fn huber(&self, depth: bool) -> &Huber {
        if depth {
            &self.depth_huber
        } else {
            &self.huber
        }
    }
}

impl Block for PointBlock<'_> {
    fn num_observations(&self) -> usize {
        self.observations.len()
    }

    inlier_fields!(point_inliers, num_point_inliers);

    fn cost(&self, pose: &Isometry3<f64>, inliers: &[bool], robust: bool, sum: f64) -> Option<f64> {
        sum_costs(self.observations, inliers, robust, sum, |obs| {
            let (e2, depth) = self.residual2(pose, obs)?;
            Some((obs.inv_sigma2 * e2, self.huber(depth)))
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
            let huber = robust.then_some(self.huber(obs.depth > 0.0));
            if obs.depth > 0.0 {
                let r = StereoPointReprojection::from_depth(obs.uv, obs.depth, self.bf, 1.0);
                if let Some(l) = r.linearize(self.camera, pose, &obs.point_in_world) {
                    normal.add(&l.d_pose, &l.error, obs.inv_sigma2, huber);
                }
            } else {
                let r = PointReprojection { uv: obs.uv };
                if let Some(l) = r.linearize(self.camera, pose, &obs.point_in_world) {
                    normal.add(&l.d_pose, &l.error, obs.inv_sigma2, huber);
                }
            }
        }
    }

    fn classify(&self, pose: &Isometry3<f64>, gate: Gate, inliers: &mut [bool]) {
        flag_within_gate(self.observations, gate, inliers, |obs| {
            if obs.inv_sigma2 <= 0.0 {
                return None;
            }
            let (e2, depth) = self.residual2(pose, obs)?;
            let chi2 = if depth { self.depth_chi2 } else { self.chi2 };
            Some((obs.inv_sigma2 * e2, chi2))
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
            if let Some((e2, depth)) = self.residual2(pose, obs) {
                *sum += e2;
                *components += if depth { 3 } else { 2 };
            }
        }
    }
}
