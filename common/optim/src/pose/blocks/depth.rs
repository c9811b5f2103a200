//! Depth points against reference surface elements: the projective point-to-plane
//! distance of dense RGB-D alignment, which holds the pose where the features are weak.
//! A pair's cost is less what its reference normal's noise adds on average as the point
//! slides along the surface ([`DepthObservation::normal_tilt_variance`]).

use super::{Block, Gate, flag_within_gate, flagged};
use crate::pose::correlation::TileScores;
use crate::pose::lm::Normal;
use crate::pose::{DepthObservation, PoseOptimizerConfig};
use crate::residuals::PointToPlane;
use crate::robust::Huber;
use gfs_core::camera::PinholeCamera;
use nalgebra::{Isometry3, Matrix6, Point3, Vector1, Vector6};

/// The depth pairs with their kernel and threshold.
pub(crate) struct DepthBlock<'a> {
    camera: &'a PinholeCamera,
    observations: &'a [DepthObservation],
    chi2: f64,
    huber: Huber,
}

impl<'a> DepthBlock<'a> {
    pub(crate) fn new(
        camera: &'a PinholeCamera,
        observations: &'a [DepthObservation],
        config: &PoseOptimizerConfig,
    ) -> Self {
        Self {
            camera,
            observations,
            chi2: config.depth_chi2,
            huber: Huber::from_chi2(config.depth_chi2),
        }
    }

    /// The inliers' pairs added to `normal`; with `tiles`, each pair's score (its share
    /// of the gradient, the tilt's average taken out) also goes to its pixel's tile, and
    /// a pair that does not project is left out.
    fn add_pairs(
        &self,
        pose: &Isometry3<f64>,
        inliers: &[bool],
        robust: bool,
        normal: &mut Normal,
        mut tiles: Option<&mut TileScores>,
    ) {
        for obs in flagged(self.observations, inliers) {
            let uv = if tiles.is_some() {
                let Some(uv) = self.camera.project(&Point3::from(obs.point_in_camera)) else {
                    continue;
                };
                Some(uv)
            } else {
                None
            };
            let pair = PointToPlane {
                point_in_camera: obs.point_in_camera,
            };
            let l = pair.linearize(pose, &obs.surface_in_world, &obs.normal_in_world);
            let before = normal.g;
            let w = normal.add(
                &l.d_pose,
                &Vector1::new(l.error),
                obs.inv_sigma2,
                robust.then_some(&self.huber),
            );
            // The tilt's average cost out of the cost and the gradient; the Hessian
            // keeps it, so that it stays positive (the tracker discounts it from the
            // information on its own, `normal_noise_information`).
            let tilt = l.offset_gradient * (w * obs.normal_tilt_variance);
            if let (Some(tiles), Some(uv)) = (tiles.as_deref_mut(), uv) {
                tiles.add(&uv, &(normal.g - before - tilt));
            }
            if obs.normal_tilt_variance > 0.0 {
                normal.g -= tilt;
            }
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
            let pair = PointToPlane {
                point_in_camera: obs.point_in_camera,
            };
            let (e, t) = pair.error_and_offset(pose, &obs.surface_in_world, &obs.normal_in_world);
            let s = obs.inv_sigma2 * e * e;
            let (cost, weight) = if robust {
                (self.huber.cost(s), self.huber.weight(s))
            } else {
                (s, 1.0)
            };
            sum += cost - weight * obs.inv_sigma2 * obs.normal_tilt_variance * t.norm_squared();
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
        self.add_pairs(pose, inliers, robust, normal, None);
    }

    fn correlated_excess(
        &self,
        pose: &Isometry3<f64>,
        inliers: &[bool],
        tile_px: f64,
        tile_scores: &mut Vec<Vector6<f64>>,
    ) -> Matrix6<f64> {
        let mut tiles = TileScores::new(self.camera, tile_px, tile_scores);
        let mut own = Normal::zeros();
        self.add_pairs(pose, inliers, false, &mut own, Some(&mut tiles));
        tiles.excess(&own.h)
    }

    fn classify(&self, pose: &Isometry3<f64>, gate: Gate, inliers: &mut [bool]) {
        flag_within_gate(self.observations, gate, inliers, |obs| {
            let e = error(pose, obs);
            (obs.inv_sigma2 > 0.0).then_some((obs.inv_sigma2 * e * e, self.chi2))
        });
    }
}

#[cfg(test)]
mod tests {
    use crate::pose::{
        DepthObservation, PoseOptimizerConfig, PoseResult, SurfaceObservations,
        optimize_pose_with_depth,
    };
    use crate::residuals::PosePrior;
    use crate::residuals::testing::SplitMix64;
    use gfs_core::se3::retract;
    use nalgebra::{Isometry3, Point3, Vector3, Vector6};

    /// A wall (z = 2 m in the world) whose 2500 surface points' normals are tilted by
    /// noise of 1 degree per direction, each paired with the frame's point 2 cm along
    /// the wall from it (as a projective association made 2 cm off would pair them),
    /// and a prior at the truth of 2 mm and 0.1 degrees. Returns the estimate's error
    /// along the wall, metres, with the pairs' tilt variance given as
    /// `normal_tilt_variance` (or 0).
    fn slide_along_a_wall_with_noisy_normals(tilt_variance_given: bool) -> f64 {
        let truth = gfs_core::se3::exp(&Vector6::new(0.05, -0.02, 0.1, 0.01, 0.02, -0.01));
        let sigma_tilt = 1.0f64.to_radians();
        let mut rng = SplitMix64::new(5);
        // Uniform in +-sqrt(3) sigma: variance sigma^2.
        let mut tilt = || rng.uniform(-1.0, 1.0) * 3.0f64.sqrt() * sigma_tilt;
        let along = Vector3::new(0.02, 0.0, 0.0);
        let mut depth = Vec::new();
        for i in 0..50 {
            for j in 0..50 {
                let s = Vector3::new(-1.0 + 0.04 * i as f64, -0.75 + 0.03 * j as f64, 2.0);
                let normal = Vector3::new(tilt(), tilt(), -1.0).normalize();
                depth.push(DepthObservation {
                    point_in_camera: (truth * Point3::from(s + along)).coords,
                    surface_in_world: s,
                    normal_in_world: normal,
                    inv_sigma2: 1.0 / 0.002f64.powi(2),
                    normal_tilt_variance: if tilt_variance_given {
                        sigma_tilt.powi(2)
                    } else {
                        0.0
                    },
                });
            }
        }
        let camera = crate::residuals::testing::vga_camera();
        let mut result = PoseResult::default();
        optimize_pose_with_depth(
            &camera,
            &truth,
            &[],
            &[],
            SurfaceObservations {
                depth: &depth,
                prior: Some(PosePrior::isotropic(truth, 0.002, 0.1f64.to_radians())),
                ..SurfaceObservations::default()
            },
            &PoseOptimizerConfig::default(),
            &mut result,
        );
        assert!(result.converged);
        let world_error: Isometry3<f64> = result.camera_from_world.inverse() * truth;
        world_error.translation.vector.x
    }

    #[test]
    fn noisy_normals_do_not_hold_the_pose_where_its_pairs_were_made() {
        // Without the correction, the tilts' average cost (2500 pairs x 2.5e5 / m^2 x
        // 3e-4 rad^2 = 1.9e5 / m^2 along the wall, against the prior's 2.5e5) pulls the
        // pose 8.8 mm of the 20 towards where the pairs coincide; with it, 0.5 mm.
        let held = slide_along_a_wall_with_noisy_normals(false);
        assert!(held.abs() > 0.007, "{held}");
        let free = slide_along_a_wall_with_noisy_normals(true);
        assert!(free.abs() < 0.001, "{free}");
    }

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
                        normal_tilt_variance: 0.0,
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
