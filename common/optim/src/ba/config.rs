//! Parameters of the local bundle adjustment.

use crate::robust::{CHI2_1DOF_95, CHI2_2DOF_95, CHI2_3DOF_95, DEFAULT_RGBD_BF};
use serde::Deserialize;

/// Default sigma of a measured inverse depth, 1/m (see [`BaConfig::inverse_depth_sigma`]).
pub const DEFAULT_INVERSE_DEPTH_SIGMA: f64 = 0.01;

/// Information of a structural / Manhattan error of one degree, `1 / sin^2(1 deg)`:
/// a pair 1 degree off costs as much as a 1-sigma pixel error.
pub const ONE_DEGREE_INFORMATION: f64 = 3_283.139_703_653_888;

/// Parameters of [`crate::LocalBundleAdjuster`] (the odometry's TOML table `[mapping.ba]`).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BaConfig {
    /// LM iterations before the outlier check; default 5 (ORB-SLAM2 local BA).
    pub first_pass_iterations: usize,
    /// LM iterations on the inliers after it; default 10 (ORB-SLAM2 local BA).
    pub second_pass_iterations: usize,
    /// A pass has converged once a step moves no free keyframe by this translation
    /// (metres, the step of its left perturbation) or [`Self::settled_step_rad`];
    /// default 3e-5. The poses are what the BA gives the trajectory, and the steps after
    /// such a step move them less still: on TUM fr1 it spares 40 % of the LM iterations
    /// without a change in accuracy (`docs/record/depth-and-planes.md`). 0 iterates
    /// until the cost stops falling.
    pub settled_step_m: f64,
    /// The rotation of [`Self::settled_step_m`]'s test, radians; default 3e-5.
    pub settled_step_rad: f64,
    /// Chi-square threshold (and Huber `sqrt`) of a point observation; default 5.991
    /// (2 dof, 95 %, ORB-SLAM2).
    pub point_chi2: f64,
    /// Chi-square threshold (and Huber `sqrt`) of a point observation with depth;
    /// default 7.815 (3 dof, 95 %, ORB-SLAM2).
    pub point_depth_chi2: f64,
    /// Virtual stereo `baseline x fx` turning depth into a right coordinate, metres x
    /// pixels; default 40.0 (ORB-SLAM2 TUM `Camera.bf`).
    pub bf: f64,
    /// Sigma of a measured inverse depth, 1/m, which weighs the depth part of a point
    /// observation (see [`crate::StereoPointReprojection::disparity_scale`]); 0 weighs
    /// it as a pixel coordinate. Default 0.01: about 3x a Kinect v1's disparity noise,
    /// for the registration and timing errors of real RGB-D frames (0.005 and 0.008
    /// did as well on synthetic sequences and no better on TUM fr1 and 7-Scenes; 0.002
    /// was worse on both real ones).
    pub inverse_depth_sigma: f64,
    /// Chi-square threshold (and Huber `sqrt`) of a line observation; default 5.991 (two
    /// endpoint distances of the same pixel sigma: 2 dof, 95 %).
    pub line_chi2: f64,
    /// Information of a parallel pair's `|sin|`; default 3283 = 1/sin^2(1 deg); 0 turns
    /// the term off.
    pub parallel_weight: f64,
    /// Information of a perpendicular pair's `cos`; default 3283 = 1/sin^2(1 deg); 0
    /// turns the term off.
    pub perpendicular_weight: f64,
    /// Information of a line-axis `|sin|`; default 3283 = 1/sin^2(1 deg); 0 turns the
    /// term off.
    pub manhattan_weight: f64,
    /// Chi-square threshold (and Huber `sqrt`) of a parallel pair; default 5.991 (the
    /// cross product has 2 dof): about 2.4 deg at the default weight.
    pub parallel_chi2: f64,
    /// Chi-square threshold (and Huber `sqrt`) of a perpendicular pair; default 3.841
    /// (1 dof, 95 %): about 1.96 deg at the default weight.
    pub perpendicular_chi2: f64,
    /// Chi-square threshold (and Huber `sqrt`) of a line-axis term; default 5.991.
    pub manhattan_chi2: f64,
    /// Chi-square threshold (and Huber `sqrt`) of a whitened plane-to-plane error of a
    /// keyframe (3 dof, 95 %); default 7.815.
    pub plane_chi2: f64,
    /// Sigma of the structural terms of map planes, degrees: the angle of a parallel
    /// or perpendicular plane pair, or of a plane and its Manhattan axis, weighs as
    /// much as this many degrees of error; default 0.5 (walls and floors are built
    /// closer to square than one keyframe's plane fit, about 1 degree, measures them);
    /// 0 turns the terms off. Their
    /// outlier thresholds are the 95 % chi-square of their degrees of freedom (2 for a
    /// parallel pair or an axis, 1 for a perpendicular pair).
    pub plane_structure_sigma_deg: f64,
}

impl BaConfig {
    /// Information of a plane structural error, `1 / sin^2(sigma)`; 0 when off.
    pub fn plane_structure_information(&self) -> f64 {
        if self.plane_structure_sigma_deg > 0.0 {
            self.plane_structure_sigma_deg.to_radians().sin().powi(-2)
        } else {
            0.0
        }
    }
}

impl Default for BaConfig {
    fn default() -> Self {
        Self {
            first_pass_iterations: 5,
            second_pass_iterations: 10,
            settled_step_m: 3e-5,
            settled_step_rad: 3e-5,
            point_chi2: CHI2_2DOF_95,
            point_depth_chi2: CHI2_3DOF_95,
            bf: DEFAULT_RGBD_BF,
            inverse_depth_sigma: DEFAULT_INVERSE_DEPTH_SIGMA,
            line_chi2: CHI2_2DOF_95,
            parallel_weight: ONE_DEGREE_INFORMATION,
            perpendicular_weight: ONE_DEGREE_INFORMATION,
            manhattan_weight: ONE_DEGREE_INFORMATION,
            parallel_chi2: CHI2_2DOF_95,
            perpendicular_chi2: CHI2_1DOF_95,
            manhattan_chi2: CHI2_2DOF_95,
            plane_chi2: CHI2_3DOF_95,
            plane_structure_sigma_deg: 0.5,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_degree_information_and_toml_table() {
        let s = 1f64.to_radians().sin();
        assert!((ONE_DEGREE_INFORMATION - 1.0 / (s * s)).abs() < 1e-6);
        let c: BaConfig = toml::from_str("manhattan_weight = 0.0\nsecond_pass_iterations = 3")
            .expect("valid table");
        assert_eq!(c.manhattan_weight, 0.0);
        assert_eq!(c.second_pass_iterations, 3);
        assert_eq!(c.first_pass_iterations, 5);
        assert!(toml::from_str::<BaConfig>("unknown = 1").is_err());
    }
}
