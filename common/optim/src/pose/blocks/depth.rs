//! Depth points against reference surface elements: the projective point-to-plane
//! distance of dense RGB-D alignment, which holds the pose where the features are weak.

use super::{Block, Gate, flagged};
use crate::pose::lm::Normal;
use crate::pose::{DepthObservation, PoseOptimizerConfig};
use crate::residuals::PointToPlane;
use crate::robust::Huber;
use nalgebra::{Isometry3, Vector1};

/// The depth pairs with their kernel and threshold.
pub(crate) struct DepthBlock<'a> {
    observations: &'a [DepthObservation],
    chi2: f64,
    huber: Huber,
}

impl<'a> DepthBlock<'a> {
    pub(crate) fn new(observations: &'a [DepthObservation], config: &PoseOptimizerConfig) -> Self {
        Self {
            observations,
            chi2: config.depth_chi2,
            huber: Huber::from_chi2(config.depth_chi2),
        }
    }
}

/// Point-to-plane distance of a depth observation at `pose`, metres.
fn error(pose: &Isometry3<f64>, obs: &DepthObservation) -> f64 {
    PointToPlane {
        point_in_camera: obs.point_in_camera,
    }
    .error(pose, &obs.surface_in_world, &obs.normal_in_world)
}

impl Block for DepthBlock<'_> {
    fn num_observations(&self) -> usize {
        self.observations.len()
    }

    inlier_fields!(depth_inliers, num_depth_inliers);

    fn cost(
        &self,
        pose: &Isometry3<f64>,
        inliers: &[bool],
        robust: bool,
        mut sum: f64,
    ) -> Option<f64> {
        for obs in flagged(self.observations, inliers) {
            let e = error(pose, obs);
            let s = obs.inv_sigma2 * e * e;
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
            let l = PointToPlane {
                point_in_camera: obs.point_in_camera,
            }
            .linearize(pose, &obs.surface_in_world, &obs.normal_in_world);
            normal.add(
                &l.d_pose,
                &Vector1::new(l.error),
                obs.inv_sigma2,
                robust.then_some(&self.huber),
            );
        }
    }

    fn classify(&self, pose: &Isometry3<f64>, gate: Gate, inliers: &mut [bool]) {
        let threshold = gate.threshold(self.chi2);
        for (flag, obs) in inliers.iter_mut().zip(self.observations) {
            let e = error(pose, obs);
            *flag = obs.inv_sigma2 > 0.0 && obs.inv_sigma2 * e * e <= threshold;
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::pose::{
        DepthObservation, PoseOptimizerConfig, PoseResult, SurfaceObservations,
        optimize_pose_with_depth,
    };
    use gfs_core::se3::retract;
    use nalgebra::{Vector3, Vector6};

    #[test]
    fn depth_on_three_planes_alone_finds_the_pose_and_its_information_is_full() {
        // A floor (y = 1) and two walls (x = 2, z = 4) seen by depth only, 1 mm sigma;
        // one wall point is 20 cm off its plane (an outlier).
        let truth = gfs_core::se3::exp(&Vector6::new(0.1, -0.05, 0.2, 0.05, -0.1, 0.02));
        let mut depth = Vec::new();
        for i in 0..8 {
            for j in 0..8 {
                let (a, b) = (-1.5 + 0.4 * i as f64, 0.5 + 0.4 * j as f64);
                for (s, n) in [
                    (Vector3::new(a, 1.0, b), Vector3::new(0.0, -1.0, 0.0)),
                    (Vector3::new(2.0, a * 0.5, b), Vector3::new(-1.0, 0.0, 0.0)),
                    (
                        Vector3::new(a, a * 0.3 + b * 0.2, 4.0),
                        Vector3::new(0.0, 0.0, -1.0),
                    ),
                ] {
                    depth.push(DepthObservation {
                        point_in_camera: (truth * nalgebra::Point3::from(s)).coords,
                        surface_in_world: s,
                        normal_in_world: n,
                        inv_sigma2: 1e6,
                    });
                }
            }
        }
        depth[1].point_in_camera += truth.rotation * Vector3::new(-0.2, 0.0, 0.0);
        let camera = crate::residuals::testing::vga_camera();
        let start = retract(&truth, &Vector6::new(0.03, -0.02, 0.02, 0.02, -0.03, 0.01));
        let mut result = PoseResult::default();
        let config = PoseOptimizerConfig::default();
        optimize_pose_with_depth(
            &camera,
            &start,
            &[],
            &[],
            SurfaceObservations {
                depth: &depth,
                ..SurfaceObservations::default()
            },
            &config,
            &mut result,
        );
        let error = result.camera_from_world * truth.inverse();
        assert!(result.converged);
        assert!(error.translation.vector.norm() < 1e-6, "{error}");
        assert!(error.rotation.angle() < 1e-6);
        assert!(!result.depth_inliers[1] && result.num_depth_inliers == depth.len() - 1);
        let constraint = crate::analyse_constraint(&result.information, 2.0, 0.001);
        assert!(constraint.is_determined(), "{constraint:?}");
    }
}
