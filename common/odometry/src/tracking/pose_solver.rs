//! Builds the pose-only problem of a frame from its matches (paper eq. 6-9) and applies
//! the result: the optimised pose, and outlier matches unlinked.

use crate::depth::grid::IntensityLevel;
use crate::frontend::features::FrameFeatures;
use crate::map::Map;
use crate::tracking::matching::ScalePyramid;
use crate::tracking::observation::{KeypointMeasurement, LINE_INV_SIGMA2, observed_line};
use gfs_core::camera::PinholeCamera;
use gfs_core::ids::{MapLineId, MapPointId};
use gfs_optim::residuals::PosePrior;
use gfs_optim::{
    DepthObservation, LineObservation, PhotometricObservation, PhotometricScratch, PhotometricTerm,
    PlaneObservation, PointObservation, PoseOptimizerConfig, PoseResult, SurfaceObservations,
    optimize_pose_with_depth,
};
use nalgebra::{Isometry3, Matrix6};

/// Inlier counts of a pose optimisation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Inliers {
    /// Map points whose reprojection error passed the chi-square test.
    pub points: usize,
    /// Map lines whose endpoint-to-line errors passed it.
    pub lines: usize,
    /// Depth point-to-plane pairs that passed it (0 without the depth alignment).
    #[serde(default)]
    pub depth: usize,
    /// Plane-to-plane observations that passed it (0 without `use_planes`).
    #[serde(default)]
    pub planes: usize,
    /// Photometric observations that passed it (0 without the photometric term).
    #[serde(default)]
    pub photometric: usize,
}

impl Inliers {
    /// Points plus lines.
    pub fn total(&self) -> usize {
        self.points + self.lines
    }
}

/// The pose optimisation of a frame, with its reusable buffers.
#[derive(Debug)]
pub struct PoseSolver {
    config: PoseOptimizerConfig,
    camera: PinholeCamera,
    scale: ScalePyramid,
    points: Vec<PointObservation>,
    point_index: Vec<usize>,
    lines: Vec<LineObservation>,
    line_index: Vec<usize>,
    depth: Vec<DepthObservation>,
    planes: Vec<PlaneObservation>,
    photometric: Vec<PhotometricObservation>,
    photometric_scratch: PhotometricScratch,
    /// The frame's intensities `photometric` is read in.
    photometric_level: IntensityLevel,
    prior: Option<PosePrior>,
    result: PoseResult,
}

impl PoseSolver {
    /// A solver for `camera` whose keypoints come from the pyramid `scale`.
    pub fn new(config: PoseOptimizerConfig, camera: PinholeCamera, scale: ScalePyramid) -> Self {
        Self {
            config,
            camera,
            scale,
            points: Vec::new(),
            point_index: Vec::new(),
            lines: Vec::new(),
            line_index: Vec::new(),
            depth: Vec::new(),
            planes: Vec::new(),
            photometric: Vec::new(),
            photometric_scratch: PhotometricScratch::default(),
            photometric_level: IntensityLevel::Cells,
            prior: None,
            result: PoseResult::default(),
        }
    }

    /// The depth pairs the next [`Self::solve`] adds (none until set).
    pub fn set_depth(&mut self, observations: &[DepthObservation]) {
        self.depth.clear();
        self.depth.extend_from_slice(observations);
    }

    /// The plane observations the next [`Self::solve`] adds (none until set).
    pub fn set_planes(&mut self, observations: &[PlaneObservation]) {
        self.planes.clear();
        self.planes.extend_from_slice(observations);
    }

    /// The reference intensities the next [`Self::solve`] reads in the frame's
    /// intensities at `level` (none until set; unused when the frame has none there).
    pub fn set_photometric(
        &mut self,
        observations: &[PhotometricObservation],
        level: IntensityLevel,
    ) {
        self.photometric.clear();
        self.photometric.extend_from_slice(observations);
        self.photometric_level = level;
    }

    /// The prediction the next [`Self::solve`] draws the pose towards (none until
    /// set).
    pub fn set_prior(&mut self, prior: Option<PosePrior>) {
        self.prior = prior;
    }

    /// Per plane observation of the last solve: inlier at its pose.
    pub fn plane_inliers(&self) -> &[bool] {
        &self.result.plane_inliers
    }

    /// Per depth observation of the last solve: inlier at its pose.
    pub fn depth_inliers(&self) -> &[bool] {
        &self.result.depth_inliers
    }

    /// Information matrix of the last solve's inliers (left perturbation `[rho; phi]`).
    pub fn information(&self) -> &Matrix6<f64> {
        &self.result.information
    }

    /// Optimises `camera_from_world` from the matches in `point_ids` / `line_ids`; the
    /// outliers' entries are cleared. Every keypoint with a depth adds the RGB-D depth
    /// error, as ORB-SLAM2's pose optimisation uses the stereo error for every keypoint
    /// with a right coordinate (its inverse-depth form weighs far points little); without
    /// it, distant points leave the rotation-translation ambiguity of a narrow view open.
    /// Returns the inlier counts.
    pub fn solve(
        &mut self,
        map: &Map,
        frame: &FrameFeatures,
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
            let m = KeypointMeasurement::new(kp, &self.scale);
            self.points.push(PointObservation {
                point_in_world: point.position.coords,
                uv: m.uv,
                inv_sigma2: m.inv_sigma2,
                depth: m.depth,
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
            let Some(coeffs) = observed_line(observed) else {
                continue;
            };
            self.lines.push(LineObservation {
                endpoints_in_world: [line.start.coords, line.end.coords],
                coeffs,
                inv_sigma2: LINE_INV_SIGMA2,
            });
            self.line_index.push(j);
        }
        if self.points.is_empty()
            && self.lines.is_empty()
            && self.depth.is_empty()
            && self.planes.is_empty()
        {
            self.result.information = Matrix6::zeros();
            return Inliers::default();
        }
        optimize_pose_with_depth(
            &self.camera,
            camera_from_world,
            &self.points,
            &self.lines,
            SurfaceObservations {
                depth: &self.depth,
                planes: &self.planes,
                photometric: frame
                    .depth
                    .intensity_grid(self.photometric_level)
                    .filter(|_| !self.photometric.is_empty())
                    .map(|image| PhotometricTerm {
                        image,
                        observations: &self.photometric,
                        scratch: &self.photometric_scratch,
                    }),
                prior: self.prior,
            },
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
            depth: self.result.num_depth_inliers,
            planes: self.result.num_plane_inliers,
            photometric: self.result.num_photometric_inliers,
        }
    }

    /// True when the last solve converged with inliers to a pose whose posterior
    /// information is positive definite ([`gfs_optim::PoseResult::covariance`]).
    pub fn converged(&self) -> bool {
        self.result.covariance.is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::OdometryConfig;
    use crate::testing::{Scene, camera, first_keyframe, pose, scale};

    #[test]
    fn the_pose_is_recovered_from_a_wrong_start_and_a_wrong_match_is_unlinked() {
        let scene = Scene::new(150, 10);
        let (map, _, kf) = first_keyframe(&scene, &OdometryConfig::default());
        let truth = pose(0.05, 0.02);
        let frame = scene.features(1, &truth);
        let keyframe = map.keyframe(kf).expect("kf");
        let mut point_ids = keyframe.point_ids.clone();
        let mut line_ids = keyframe.line_ids.clone();
        // Keypoint 0 linked to the point of keypoint 100: an outlier.
        point_ids[0] = keyframe.point_ids[100];
        let mut solver = PoseSolver::new(PoseOptimizerConfig::default(), camera(), scale());
        let mut camera_from_world = pose(0.0, 0.0);
        let inliers = solver.solve(
            &map,
            &frame,
            &mut camera_from_world,
            &mut point_ids,
            &mut line_ids,
        );
        let error = camera_from_world * truth.inverse();
        assert!(error.translation.vector.norm() < 1e-6, "{error}");
        assert!(error.rotation.angle() < 1e-6);
        assert_eq!(point_ids[0], None, "the outlier is unlinked");
        assert_eq!((inliers.points, inliers.lines, inliers.depth), (149, 10, 0));
        assert_eq!(inliers.total(), 159);
    }

    #[test]
    fn no_match_leaves_the_pose_alone() {
        let scene = Scene::new(10, 0);
        let (map, _, _) = first_keyframe(&scene, &OdometryConfig::default());
        let frame = scene.features(1, &pose(0.0, 0.0));
        let mut solver = PoseSolver::new(PoseOptimizerConfig::default(), camera(), scale());
        let start = pose(0.1, 0.0);
        let mut camera_from_world = start;
        let inliers = solver.solve(
            &map,
            &frame,
            &mut camera_from_world,
            &mut [None; 10],
            &mut [],
        );
        assert_eq!((inliers, camera_from_world), (Inliers::default(), start));
    }
}
