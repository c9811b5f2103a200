//! Builds the pose-only problem of a frame from its matches (paper eq. 6-9) and applies
//! the result: the optimised pose, and outlier matches unlinked.

use crate::frame::FrameFeatures;
use crate::map::Map;
use crate::matching::ScalePyramid;
use gfs_core::camera::PinholeCamera;
use gfs_core::ids::{MapLineId, MapPointId};
use gfs_optim::{
    LineObservation, PointObservation, PoseOptimizerConfig, PoseResult, optimize_pose,
};
use nalgebra::{Isometry3, Matrix6, Vector2, Vector3};

/// Inlier counts of a pose optimisation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Inliers {
    /// Map points whose reprojection error passed the chi-square test.
    pub points: usize,
    /// Map lines whose endpoint-to-line errors passed it.
    pub lines: usize,
}

impl Inliers {
    /// Points plus lines.
    pub fn total(&self) -> usize {
        self.points + self.lines
    }
}

/// Reusable buffers of the pose optimisation.
#[derive(Debug, Default)]
pub struct PoseSolver {
    config: PoseOptimizerConfig,
    points: Vec<PointObservation>,
    point_index: Vec<usize>,
    lines: Vec<LineObservation>,
    line_index: Vec<usize>,
    result: PoseResult,
}

impl PoseSolver {
    /// Optimises `camera_from_world` from the matches in `point_ids` / `line_ids`; the
    /// outliers' entries are cleared. Every keypoint with a depth adds the RGB-D depth
    /// error, as ORB-SLAM2's pose optimisation uses the stereo error for every keypoint
    /// with a right coordinate (its inverse-depth form weighs far points little); without
    /// it, distant points leave the rotation-translation ambiguity of a narrow view open.
    /// Returns the inlier counts.
    #[allow(clippy::too_many_arguments)]
    pub fn solve(
        &mut self,
        map: &Map,
        frame: &FrameFeatures,
        camera: &PinholeCamera,
        scale: &ScalePyramid,
        camera_from_world: &mut Isometry3<f64>,
        point_ids: &mut [Option<MapPointId>],
        line_ids: &mut [Option<MapLineId>],
    ) -> Inliers {
        self.result.covariance = None;
        self.points.clear();
        self.point_index.clear();
        for (i, id) in point_ids.iter().enumerate() {
            let (Some(point), Some(kp)) = (id.and_then(|id| map.point(id)), frame.keypoints.get(i))
            else {
                continue;
            };
            self.points.push(PointObservation {
                point_in_world: point.position.coords,
                uv: Vector2::new(f64::from(kp.u), f64::from(kp.v)),
                inv_sigma2: scale.inv_sigma2(kp.level),
                depth: f64::from(kp.depth),
            });
            self.point_index.push(i);
        }
        self.lines.clear();
        self.line_index.clear();
        for (j, id) in line_ids.iter().enumerate() {
            let (Some(line), Some(observed)) = (id.and_then(|id| map.line(id)), frame.lines.get(j))
            else {
                continue;
            };
            let [a, b, c] = observed.segment.line_coefficients();
            if a == 0.0 && b == 0.0 {
                continue;
            }
            self.lines.push(LineObservation {
                endpoints_in_world: [line.start.coords, line.end.coords],
                coeffs: Vector3::new(f64::from(a), f64::from(b), f64::from(c)),
                inv_sigma2: 1.0,
            });
            self.line_index.push(j);
        }
        if self.points.is_empty() && self.lines.is_empty() {
            return Inliers::default();
        }
        optimize_pose(
            camera,
            camera_from_world,
            &self.points,
            &self.lines,
            &self.config,
            &mut self.result,
        );
        *camera_from_world = self.result.camera_from_world;
        for (k, inlier) in self.result.point_inliers.iter().enumerate() {
            if !inlier {
                point_ids[self.point_index[k]] = None;
            }
        }
        for (k, inlier) in self.result.line_inliers.iter().enumerate() {
            if !inlier {
                line_ids[self.line_index[k]] = None;
            }
        }
        Inliers {
            points: self.result.num_point_inliers,
            lines: self.result.num_line_inliers,
        }
    }

    /// The covariance of the last solved pose ([`gfs_optim::PoseResult::covariance`]).
    pub fn covariance(&self) -> Option<Matrix6<f64>> {
        self.result.covariance
    }
}
