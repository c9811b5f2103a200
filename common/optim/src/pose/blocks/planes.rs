//! Frame planes against map planes: the plane-to-plane error (normal difference and
//! offset), whitened by the normal's and the offset's sigmas.

use super::{Block, Gate, flagged};
use crate::pose::lm::Normal;
use crate::pose::{PlaneObservation, PoseOptimizerConfig};
use crate::robust::Huber;
use nalgebra::Isometry3;

/// The plane pairs with their kernel and threshold.
pub(crate) struct PlaneBlock<'a> {
    observations: &'a [PlaneObservation],
    chi2: f64,
    huber: Huber,
}

impl<'a> PlaneBlock<'a> {
    pub(crate) fn new(observations: &'a [PlaneObservation], config: &PoseOptimizerConfig) -> Self {
        Self {
            observations,
            chi2: config.plane_chi2,
            huber: Huber::from_chi2(config.plane_chi2),
        }
    }
}

impl Block for PlaneBlock<'_> {
    fn num_observations(&self) -> usize {
        self.observations.len()
    }

    inlier_fields!(plane_inliers, num_plane_inliers);

    fn cost(
        &self,
        pose: &Isometry3<f64>,
        inliers: &[bool],
        robust: bool,
        mut sum: f64,
    ) -> Option<f64> {
        for obs in flagged(self.observations, inliers) {
            let s = obs.whitened_error(pose).norm_squared();
            sum += if robust { self.huber.cost(s) } else { s };
        }
        Some(sum)
    }

    fn linearize(
        &self,
        pose: &Isometry3<f64>,
        inliers: &[bool],
        robust: bool,
        normal: &mut Normal,
    ) {
        for obs in flagged(self.observations, inliers) {
            let l = obs
                .measured
                .linearize(pose, &obs.normal_in_world, obs.offset_in_world);
            let j = obs.whitened_d_pose(&l.d_pose);
            normal.add(&j, &obs.whiten(l.error), 1.0, robust.then_some(&self.huber));
        }
    }

    fn classify(&self, pose: &Isometry3<f64>, gate: Gate, inliers: &mut [bool]) {
        let threshold = gate.threshold(self.chi2);
        for (flag, obs) in inliers.iter_mut().zip(self.observations) {
            let s = obs.whitened_error(pose).norm_squared();
            *flag = s.is_finite() && s <= threshold;
        }
    }
}
