//! The motion model's prediction as a prior on the pose: it holds the directions the
//! data leave weak. It is no observation: no kernel, never an outlier, no inlier flags,
//! and not in [`PoseResult::information`], which says what the data constrain (the
//! covariance is the posterior's and keeps it).

use super::{Block, Gate, InlierFlags};
use crate::pose::PoseResult;
use crate::pose::lm::Normal;
use crate::residuals::PosePrior;
use nalgebra::{Isometry3, Matrix6};

/// The prior, when any.
pub(crate) struct PriorBlock {
    prior: Option<PosePrior>,
}

impl PriorBlock {
    pub(crate) fn new(prior: Option<PosePrior>) -> Self {
        Self { prior }
    }

    /// The prior's information at `pose` (zero without a prior), to take out of the
    /// posterior's.
    pub(crate) fn information_at(&self, pose: &Isometry3<f64>) -> Matrix6<f64> {
        self.prior
            .map_or_else(Matrix6::zeros, |p| p.information_at(pose))
    }
}

impl Block for PriorBlock {
    fn num_observations(&self) -> usize {
        0
    }

    fn inliers<'r>(&self, _result: &'r PoseResult) -> &'r [bool] {
        &[]
    }

    fn inlier_flags<'r>(&self, _result: &'r mut PoseResult) -> Option<InlierFlags<'r>> {
        None
    }

    fn cost(
        &self,
        pose: &Isometry3<f64>,
        _inliers: &[bool],
        _robust: bool,
        sum: f64,
    ) -> Option<f64> {
        Some(
            self.prior
                .as_ref()
                .map_or(sum, |prior| sum + prior.cost(pose)),
        )
    }

    fn linearize(
        &self,
        pose: &Isometry3<f64>,
        _inliers: &[bool],
        _robust: bool,
        normal: &mut Normal,
    ) {
        if let Some(prior) = &self.prior {
            let l = prior.linearize(pose);
            let jt_w = l.d_pose.transpose() * prior.information;
            normal.h += jt_w * l.d_pose;
            normal.g += jt_w * l.error;
        }
    }

    fn classify(&self, _pose: &Isometry3<f64>, _gate: Gate, _inliers: &mut [bool]) {}
}

#[cfg(test)]
mod tests {
    use crate::pose::{
        DepthObservation, PoseOptimizerConfig, PoseResult, SurfaceObservations,
        optimize_pose_with_depth,
    };
    use crate::residuals::PosePrior;
    use nalgebra::{Isometry3, Vector3};

    #[test]
    fn a_prior_holds_what_one_wall_leaves_free_and_stays_out_of_the_information() {
        // A wall (z = 3) seen by depth only, 1 mm sigma: it fixes the distance and the
        // two tilts, not the slide along it nor the turn about its normal. The true pose
        // is 2 cm nearer than the prediction and 1.5 cm aside.
        let camera = crate::residuals::testing::vga_camera();
        let truth = Isometry3::translation(0.015, 0.0, 0.02);
        let predicted = Isometry3::identity();
        let mut depth = Vec::new();
        for i in 0..10 {
            for j in 0..10 {
                let s = Vector3::new(-1.0 + 0.2 * i as f64, -0.8 + 0.16 * j as f64, 3.0);
                depth.push(DepthObservation {
                    point_in_camera: (truth * nalgebra::Point3::from(s)).coords,
                    surface_in_world: s,
                    normal_in_world: Vector3::new(0.0, 0.0, -1.0),
                    inv_sigma2: 1e6,
                    normal_tilt_variance: 0.0,
                });
            }
        }
        let mut result = PoseResult::default();
        optimize_pose_with_depth(
            &camera,
            &predicted,
            &[],
            &[],
            SurfaceObservations {
                depth: &depth,
                prior: Some(PosePrior::isotropic(predicted, 0.005, 0.01)),
                ..SurfaceObservations::default()
            },
            &PoseOptimizerConfig::default(),
            &mut result,
        );
        let t = result.camera_from_world.translation.vector;
        // The depth moves the camera 2 cm along the normal, to 0.1 mm; along the wall the
        // pose stays at the prediction.
        assert!((t.z - 0.02).abs() < 1e-4, "{t}");
        assert!(t.x.abs() < 1e-4 && t.y.abs() < 1e-4, "{t}");
        assert!(result.camera_from_world.rotation.angle() < 1e-4);
        // The information is the wall's alone: three directions free.
        let constraint = crate::analyse_constraint(&result.information, 2.0, 0.01);
        assert_eq!(constraint.unconstrained.len(), 3, "{constraint:?}");
        // The covariance is the posterior's: every direction bounded by the prior.
        let covariance = result.covariance.expect("covariance with the prior");
        assert!((covariance[(0, 0)].sqrt() - 0.005).abs() < 1e-4);
    }
}
