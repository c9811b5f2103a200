//! The parameters of the pose optimiser: rounds, iterations and one chi-square threshold
//! per term kind (its Huber kernel is the threshold's square root).

use crate::robust::{CHI2_1DOF_95, CHI2_2DOF_95, CHI2_3DOF_95, DEFAULT_RGBD_BF};
use serde::Deserialize;

#[cfg(doc)]
use super::optimize_pose;

/// Parameters of [`optimize_pose`] (the odometry's TOML table `[tracking.pose]`).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PoseOptimizerConfig {
    /// Outlier-rejection rounds; default 4 (ORB-SLAM2).
    pub rounds: usize,
    /// LM iterations per round; default 10 (ORB-SLAM2).
    pub iterations_per_round: usize,
    /// Rounds that use the Huber kernel, after which the inliers are weighted plainly;
    /// default 2 (ORB-SLAM2).
    pub robust_rounds: usize,
    /// Chi-square threshold of a point observation (2 dof, 95 %); also the Huber
    /// threshold as `sqrt`; default 5.991 (ORB-SLAM2).
    pub point_chi2: f64,
    /// Chi-square threshold (and Huber `sqrt`) of a point observation with depth (3 dof,
    /// 95 %); default 7.815 (ORB-SLAM2).
    pub point_depth_chi2: f64,
    /// Virtual stereo `baseline x fx` turning depth into a right coordinate, metres x
    /// pixels; default 40.0 (ORB-SLAM2 TUM `Camera.bf`).
    pub bf: f64,
    /// Chi-square threshold of a line observation; default 5.991: its two endpoint
    /// distances are two pixel errors of the same sigma, 2 dof at 95 % as for points.
    pub line_chi2: f64,
    /// Chi-square threshold (and Huber `sqrt`) of a depth point-to-plane distance;
    /// default 3.841 (1 dof, 95 %).
    pub depth_chi2: f64,
    /// Chi-square threshold (and Huber `sqrt`) of a whitened plane-to-plane error;
    /// default 7.815 (3 dof, 95 %: two of the normal, one of the offset).
    pub plane_chi2: f64,
    /// Chi-square threshold (and Huber `sqrt`) of a whitened photometric error;
    /// default 3.841 (1 dof, 95 %).
    pub photometric_chi2: f64,
    /// Side of the square image tiles over which the dense terms' (photometric, depth
    /// pairs) scores are summed to see how far their errors move together, pixels
    /// ([`crate::PoseResult::correlated_excess`]); 0 counts their pixels as
    /// independent. Default 160: at VGA, 12 tiles, each about as wide as the
    /// wavelengths of a structured-light sensor's smooth disparity error (64-192 px);
    /// 80 px tiles left slow seed 4's frames on a bare wall most of their information
    /// (mean NEES 42.7 against 29.9).
    pub correlation_tile_px: f64,
}

impl Default for PoseOptimizerConfig {
    fn default() -> Self {
        Self {
            rounds: 4,
            iterations_per_round: 10,
            robust_rounds: 2,
            point_chi2: CHI2_2DOF_95,
            point_depth_chi2: CHI2_3DOF_95,
            bf: DEFAULT_RGBD_BF,
            line_chi2: CHI2_2DOF_95,
            depth_chi2: CHI2_1DOF_95,
            plane_chi2: CHI2_3DOF_95,
            photometric_chi2: CHI2_1DOF_95,
            correlation_tile_px: 160.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn config_reads_a_toml_table_and_rejects_unknown_fields() {
        let c: PoseOptimizerConfig = toml::from_str("rounds = 2\nline_chi2 = 7.0").expect("valid");
        assert_eq!(
            (c.rounds, c.line_chi2, c.iterations_per_round),
            (2, 7.0, 10)
        );
        assert!(toml::from_str::<PoseOptimizerConfig>("round = 2").is_err());
    }
}
