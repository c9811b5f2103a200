//! Frame planes against map planes: the plane-to-plane error (normal difference and
//! offset), whitened by the normal's and the offset's sigmas.

use super::{Block, Gate, flag_within_gate, flagged, sum_costs};
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

    fn cost(&self, pose: &Isometry3<f64>, inliers: &[bool], robust: bool, sum: f64) -> Option<f64> {
        sum_costs(self.observations, inliers, robust, sum, |obs| {
            Some((obs.whitened_error(pose).norm_squared(), &self.huber))
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
            let l = obs
                .measured
                .linearize(pose, &obs.normal_in_world, obs.offset_in_world);
            let j = obs.whitened_d_pose(&l.d_pose);
            normal.add(&j, &obs.whiten(l.error), 1.0, robust.then_some(&self.huber));
        }
    }

    fn classify(&self, pose: &Isometry3<f64>, gate: Gate, inliers: &mut [bool]) {
        flag_within_gate(self.observations, gate, inliers, |obs| {
            let s = obs.whitened_error(pose).norm_squared();
            s.is_finite().then_some((s, self.chi2))
        });
    }
}

#[cfg(test)]
mod tests {
    use crate::pose::{
        PlaneObservation, PoseOptimizerConfig, PoseResult, SurfaceObservations,
        optimize_pose_with_depth,
    };
    use crate::residuals::{PlaneToPlane, PosePrior};
    use nalgebra::{Isometry3, Vector3};

    /// The pose after one pair of a wall (z = 3) with a frame plane whose normal is
    /// tilted by `tilt_deg` about x, the prediction drawing the pose towards identity as
    /// the tracker's prior does (6.7 mm, 0.44 degrees); and whether the pair held.
    fn one_pair(tilt_deg: f64) -> (Isometry3<f64>, bool) {
        let camera = crate::residuals::testing::vga_camera();
        let a = tilt_deg.to_radians();
        let planes = [PlaneObservation {
            normal_in_world: Vector3::new(0.0, 0.0, 1.0),
            offset_in_world: -3.0,
            measured: PlaneToPlane {
                normal_in_camera: Vector3::new(0.0, -a.sin(), a.cos()),
                offset: -3.0,
            },
            inv_sigma2_normal: 1.0f64.to_radians().powi(-2),
            inv_sigma2_offset: 0.01f64.powi(-2),
        }];
        let initial = Isometry3::identity();
        let mut result = PoseResult::default();
        optimize_pose_with_depth(
            &camera,
            &initial,
            &[],
            &[],
            SurfaceObservations {
                planes: &planes,
                prior: Some(PosePrior::isotropic(initial, 0.0067, 0.44f64.to_radians())),
                ..SurfaceObservations::default()
            },
            &PoseOptimizerConfig::default(),
            &mut result,
        );
        (result.camera_from_world, result.plane_inliers[0])
    }

    #[test]
    fn a_lone_pair_rejected_leaves_the_pose_where_it_started() {
        // 8 degrees off, the prior holds the turn: the pair fails its chi-square test,
        // and what it moved goes with it.
        let (pose, inlier) = one_pair(8.0);
        assert!(!inlier);
        assert_eq!(pose, Isometry3::identity());
        // 0.5 degrees off, the pair holds and turns the pose part of the way.
        let (pose, inlier) = one_pair(0.5);
        assert!(inlier);
        let turned = pose.rotation.angle().to_degrees();
        assert!(turned > 0.05 && turned < 0.5, "{turned} degrees");
    }
}
