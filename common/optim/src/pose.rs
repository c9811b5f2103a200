//! Pose-only optimisation for tracking (paper eq. 6-9): the camera pose that minimises
//! the Huber-robustified point reprojection and line endpoint-to-line errors against
//! fixed map points and lines, by Levenberg-Marquardt on SE(3) (6x6 normal equations),
//! in several rounds with chi-square outlier rejection (ORB-SLAM2
//! `PoseOptimization`: 4 rounds x 10 iterations, every observation re-classified at the
//! end of each round, the kernel dropped after the second round).

use crate::lm::Damping;
use crate::residuals::{
    IntensityGrid, LineReprojection, Photometric, PlaneToPlane, PointReprojection, PointToPlane,
    PosePrior, StereoPointReprojection,
};
use crate::robust::{CHI2_1DOF_95, CHI2_2DOF_95, CHI2_3DOF_95, DEFAULT_RGBD_BF, Huber};
use gfs_core::camera::PinholeCamera;
use gfs_core::se3::retract;
use nalgebra::{Isometry3, Matrix6, SMatrix, SVector, Vector2, Vector3, Vector4, Vector6};
use serde::Deserialize;

/// A map point matched to a keypoint of the frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointObservation {
    /// The map point, world frame, metres (held fixed).
    pub point_in_world: Vector3<f64>,
    /// The keypoint, undistorted pixels (u, v).
    pub uv: Vector2<f64>,
    /// Information of the keypoint, 1/px^2 (see [`crate::robust::inv_sigma2_for_level`]).
    pub inv_sigma2: f64,
    /// Measured depth of the keypoint, metres; `0.0` (or any value <= 0) when there is
    /// none or it is not trusted (ORB-SLAM2 keeps depth for points closer than 40
    /// baselines): the error is then the 2D reprojection only, else the RGB-D error
    /// of [`StereoPointReprojection`].
    pub depth: f64,
}

/// A map line matched to a 2D line of the frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineObservation {
    /// The map line's endpoints `[S, E]`, world frame, metres (held fixed).
    pub endpoints_in_world: [Vector3<f64>; 2],
    /// The observed line `(a, b, c)`, `a^2 + b^2 = 1`, pixels (see [`LineReprojection`]).
    pub coeffs: Vector3<f64>,
    /// Information of the endpoint distances, 1/px^2.
    pub inv_sigma2: f64,
}

/// A depth point of the frame associated with a reference surface element (projective
/// point-to-plane alignment, see [`PointToPlane`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthObservation {
    /// The frame's depth point, camera frame, metres.
    pub point_in_camera: Vector3<f64>,
    /// The reference surface point, world frame, metres (held fixed).
    pub surface_in_world: Vector3<f64>,
    /// The reference surface's unit normal, world frame.
    pub normal_in_world: Vector3<f64>,
    /// Information of the point-to-plane distance, 1/m^2 (the depth noise of both ends).
    pub inv_sigma2: f64,
}

/// A reference surface point with its intensity, for the frame's intensity grid (see
/// [`Photometric`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhotometricObservation {
    /// The reference point, world frame, metres (held fixed).
    pub point_in_world: Vector3<f64>,
    /// Its intensity in the reference, gray levels.
    pub intensity: f64,
    /// Information of the intensity difference, 1/gray level^2.
    pub inv_sigma2: f64,
}

/// The photometric term of a pose optimisation: reference points and the frame's
/// intensity grid they are read in. The exposure may differ between the two: the frame's
/// intensity is compared with the reference's times the gain that fits the inliers best
/// at the pose evaluated, `g = sum I_c I_r / sum I_r^2` (the gain eliminated in closed
/// form: at its optimum the gradient of the reduced cost is `sum J^T e` with the gain
/// held, so the pose's steps need no gain derivative). A gain estimated once before the
/// optimisation would absorb part of the motion: a shading ramp looks like a change of
/// exposure.
#[derive(Clone, Copy, Debug)]
pub struct PhotometricTerm<'a> {
    /// The frame's intensities.
    pub image: IntensityGrid<'a>,
    /// The reference points.
    pub observations: &'a [PhotometricObservation],
}

/// A plane of the frame associated with a map plane (see [`PlaneToPlane`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneObservation {
    /// The map plane's unit normal, world frame (held fixed).
    pub normal_in_world: Vector3<f64>,
    /// The map plane's offset, metres (`n_w . p + d_w = 0`, held fixed).
    pub offset_in_world: f64,
    /// The frame's measurement of it, camera frame.
    pub measured: PlaneToPlane,
    /// Information of the normal's difference, 1/rad^2.
    pub inv_sigma2_normal: f64,
    /// Information of the offset's difference, 1/m^2.
    pub inv_sigma2_offset: f64,
}

impl PlaneObservation {
    /// The pose Jacobian of the whitened error.
    pub fn whitened_d_pose(&self, d_pose: &SMatrix<f64, 4, 6>) -> SMatrix<f64, 4, 6> {
        let mut j = *d_pose;
        j.fixed_rows_mut::<3>(0)
            .scale_mut(self.inv_sigma2_normal.sqrt());
        j.row_mut(3).scale_mut(self.inv_sigma2_offset.sqrt());
        j
    }

    /// The whitened error (each row times the square root of its information).
    pub fn whitened_error(&self, pose: &Isometry3<f64>) -> Vector4<f64> {
        let e = self
            .measured
            .error(pose, &self.normal_in_world, self.offset_in_world);
        self.whiten(e)
    }

    /// Each row of an error (or a Jacobian column) times the square root of its
    /// information.
    pub fn whiten(&self, mut e: Vector4<f64>) -> Vector4<f64> {
        let (wn, wd) = (self.inv_sigma2_normal.sqrt(), self.inv_sigma2_offset.sqrt());
        e.fixed_rows_mut::<3>(0).scale_mut(wn);
        e[3] *= wd;
        e
    }
}

/// The terms of a pose optimisation besides points and lines: depth point-to-plane
/// pairs, plane-to-plane observations, the photometric term and a prior on the pose.
#[derive(Clone, Copy, Debug, Default)]
pub struct SurfaceObservations<'a> {
    /// Depth points paired with reference surface elements.
    pub depth: &'a [DepthObservation],
    /// Frame planes associated with map planes.
    pub planes: &'a [PlaneObservation],
    /// Reference intensities read in the frame's image, when any.
    pub photometric: Option<PhotometricTerm<'a>>,
    /// The motion model's prediction, when the pose is drawn towards it: it holds the
    /// directions the data leave weak. Not robustified, not counted as an inlier, not
    /// in [`PoseResult::information`] (which says what the data constrain).
    pub prior: Option<PosePrior>,
}

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
        }
    }
}

/// Output of [`optimize_pose`]; reuse one value across frames to keep its buffers.
#[derive(Clone, Debug, Default)]
pub struct PoseResult {
    /// The estimated `camera_from_world` (the last estimate when not converged).
    pub camera_from_world: Isometry3<f64>,
    /// Per point observation (same order as the input): inlier at the final pose.
    pub point_inliers: Vec<bool>,
    /// Per line observation (same order as the input): inlier at the final pose.
    pub line_inliers: Vec<bool>,
    /// Number of `true` in `point_inliers`.
    pub num_point_inliers: usize,
    /// Number of `true` in `line_inliers`.
    pub num_line_inliers: usize,
    /// Per depth observation (same order as the input): inlier at the final pose.
    pub depth_inliers: Vec<bool>,
    /// Number of `true` in `depth_inliers`.
    pub num_depth_inliers: usize,
    /// Per plane observation (same order as the input): inlier at the final pose.
    pub plane_inliers: Vec<bool>,
    /// Number of `true` in `plane_inliers`.
    pub num_plane_inliers: usize,
    /// Per photometric observation (same order as the input): inlier at the final pose.
    pub photometric_inliers: Vec<bool>,
    /// Number of `true` in `photometric_inliers`.
    pub num_photometric_inliers: usize,
    /// Information matrix `J^T Omega J` of the inliers at the final pose (no kernel,
    /// no prior), in the left perturbation `[rho; phi]`: which directions the data
    /// constrain.
    pub information: Matrix6<f64>,
    /// RMS of the inliers' residual components (point u / v / disparity errors, line
    /// endpoint distances), pixels, unweighted; 0 without inliers.
    pub rms_error_px: f64,
    /// LM iterations run over all rounds.
    pub iterations: usize,
    /// True when the last round's LM converged (small relative cost decrease or no
    /// further decrease possible) with at least one inlier; false otherwise, with
    /// the last estimate still in `camera_from_world` (the tracker may mark the frame
    /// degraded).
    pub converged: bool,
    /// Covariance of the converged pose: the inverse of the information `J^T W J` of
    /// the final inliers at the solution (no robust weights) and the prior, over the left
    /// perturbation `exp(delta) * camera_from_world`, `delta` = (translation, rotation)
    /// in the camera frame. `None` when not converged or the information is singular.
    pub covariance: Option<Matrix6<f64>>,
}

impl PoseResult {
    /// Inliers of every kind.
    pub fn inlier_count(&self) -> usize {
        self.num_point_inliers
            + self.num_line_inliers
            + self.num_depth_inliers
            + self.num_plane_inliers
            + self.num_photometric_inliers
    }
}

/// Point-to-plane distance of a depth observation at `pose`, metres.
fn depth_error(pose: &Isometry3<f64>, obs: &DepthObservation) -> f64 {
    PointToPlane {
        point_in_camera: obs.point_in_camera,
    }
    .error(pose, &obs.surface_in_world, &obs.normal_in_world)
}

/// Relative cost decrease below which LM has converged.
const RELATIVE_COST_TOLERANCE: f64 = 1e-9;
/// Step norm below which LM has converged (metres / radians).
const STEP_TOLERANCE: f64 = 1e-10;

/// Optimises the pose of a frame against fixed map points and lines.
///
/// Starts from `initial_camera_from_world`, writes the pose, the inlier flags and the
/// statistics into `result` (its vectors are reused). Never fails: observations behind
/// the camera or with non-finite values are outliers, and with no usable observation the
/// initial pose comes back with `converged == false`.
pub fn optimize_pose(
    camera: &PinholeCamera,
    initial_camera_from_world: &Isometry3<f64>,
    points: &[PointObservation],
    lines: &[LineObservation],
    config: &PoseOptimizerConfig,
    result: &mut PoseResult,
) {
    optimize_pose_with_depth(
        camera,
        initial_camera_from_world,
        points,
        lines,
        SurfaceObservations::default(),
        config,
        result,
    );
}

/// [`optimize_pose`] with depth point-to-plane and plane-to-plane observations as
/// further residual blocks, robustified and outlier-rejected like the others
/// (`depth_chi2`, `plane_chi2`).
pub fn optimize_pose_with_depth(
    camera: &PinholeCamera,
    initial_camera_from_world: &Isometry3<f64>,
    points: &[PointObservation],
    lines: &[LineObservation],
    surfaces: SurfaceObservations<'_>,
    config: &PoseOptimizerConfig,
    result: &mut PoseResult,
) {
    let SurfaceObservations {
        depth,
        planes,
        photometric,
        prior,
    } = surfaces;
    let problem = PoseProblem {
        camera,
        points,
        lines,
        depth,
        planes,
        photometric,
        prior,
        plane_huber: Huber::from_chi2(config.plane_chi2),
        photometric_huber: Huber::from_chi2(config.photometric_chi2),
        depth_huber: Huber::from_chi2(config.depth_chi2),
        point_huber: Huber::from_chi2(config.point_chi2),
        point_depth_huber: Huber::from_chi2(config.point_depth_chi2),
        bf: config.bf,
        line_huber: Huber::from_chi2(config.line_chi2),
    };
    let mut pose = *initial_camera_from_world;
    result.point_inliers.clear();
    result.point_inliers.resize(points.len(), true);
    result.line_inliers.clear();
    result.line_inliers.resize(lines.len(), true);
    result.depth_inliers.clear();
    result.depth_inliers.resize(depth.len(), true);
    result.plane_inliers.clear();
    result.plane_inliers.resize(planes.len(), true);
    result.photometric_inliers.clear();
    result
        .photometric_inliers
        .resize(photometric.map_or(0, |p| p.observations.len()), true);
    result.iterations = 0;
    result.converged = false;
    // Every observation that can be evaluated starts as an inlier (ORB-SLAM2).
    let unbounded = Thresholds {
        point: f64::INFINITY,
        point_depth: f64::INFINITY,
        line: f64::INFINITY,
        depth: f64::INFINITY,
        plane: f64::INFINITY,
        photometric: f64::INFINITY,
    };
    problem.classify(&pose, &unbounded, result);
    let thresholds = Thresholds {
        point: config.point_chi2,
        point_depth: config.point_depth_chi2,
        line: config.line_chi2,
        depth: config.depth_chi2,
        plane: config.plane_chi2,
        photometric: config.photometric_chi2,
    };
    for round in 0..config.rounds {
        if result.inlier_count() == 0 {
            break;
        }
        let robust = round < config.robust_rounds;
        let (estimate, iterations, converged) =
            problem.run_lm(pose, result, robust, config.iterations_per_round);
        pose = estimate;
        result.iterations += iterations;
        result.converged = converged;
        problem.classify(&pose, &thresholds, result);
    }
    result.converged &= result.inlier_count() > 0;
    result.camera_from_world = pose;
    let posterior = problem.linearize(&pose, result, false).h;
    result.information = posterior - prior.map_or_else(Matrix6::zeros, |p| p.information_at(&pose));
    result.rms_error_px = problem.inlier_rms(&pose, result);
    result.covariance = if result.converged {
        posterior.cholesky().map(|c| c.inverse())
    } else {
        None
    };
}

/// The borrowed inputs of one pose optimisation.
struct PoseProblem<'a> {
    camera: &'a PinholeCamera,
    points: &'a [PointObservation],
    lines: &'a [LineObservation],
    depth: &'a [DepthObservation],
    planes: &'a [PlaneObservation],
    photometric: Option<PhotometricTerm<'a>>,
    prior: Option<PosePrior>,
    plane_huber: Huber,
    photometric_huber: Huber,
    depth_huber: Huber,
    point_huber: Huber,
    point_depth_huber: Huber,
    bf: f64,
    line_huber: Huber,
}

/// Chi-square thresholds of the observation kinds.
struct Thresholds {
    point: f64,
    point_depth: f64,
    line: f64,
    depth: f64,
    plane: f64,
    photometric: f64,
}

/// The normal equations of one linearisation.
struct Normal {
    h: Matrix6<f64>,
    g: Vector6<f64>,
    cost: f64,
}

impl Normal {
    /// Adds a residual with information `info`, robustified when `huber` is given.
    fn add<const R: usize>(
        &mut self,
        j: &SMatrix<f64, R, 6>,
        e: &SVector<f64, R>,
        info: f64,
        huber: Option<&Huber>,
    ) {
        let s = info * e.norm_squared();
        let (cost, w) = huber.map_or((s, 1.0), |h| (h.cost(s), h.weight(s)));
        let jt_w = j.transpose() * (w * info);
        self.h += jt_w * j;
        self.g += jt_w * e;
        self.cost += cost;
    }
}

impl PoseProblem<'_> {
    /// Squared residual norm of a point observation (unweighted) and whether it has
    /// depth; `None` behind the camera.
    fn point_residual2(
        &self,
        pose: &Isometry3<f64>,
        obs: &PointObservation,
    ) -> Option<(f64, bool)> {
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

    /// Whitened squared photometric error at `gain`; `None` behind the camera or off
    /// the image.
    fn photometric_residual2(
        &self,
        term: &PhotometricTerm<'_>,
        pose: &Isometry3<f64>,
        obs: &PhotometricObservation,
        gain: f64,
    ) -> Option<f64> {
        let e = Photometric {
            intensity: gain * obs.intensity,
        }
        .error(self.camera, &term.image, pose, &obs.point_in_world)?;
        Some(obs.inv_sigma2 * e * e)
    }

    /// The frame's gain over the reference at `pose`, least squares over the
    /// observations flagged in `inliers` that project into the image; 1 without any.
    fn photometric_gain(
        &self,
        term: &PhotometricTerm<'_>,
        pose: &Isometry3<f64>,
        inliers: &[bool],
    ) -> f64 {
        let (mut cross, mut square) = (0.0, 0.0);
        for (obs, _) in term.observations.iter().zip(inliers).filter(|(_, f)| **f) {
            let p_c = pose * nalgebra::Point3::from(obs.point_in_world);
            if let Some(value) = self
                .camera
                .project(&p_c)
                .and_then(|uv| term.image.intensity(uv.x, uv.y))
            {
                cross += obs.inv_sigma2 * value * obs.intensity;
                square += obs.inv_sigma2 * obs.intensity * obs.intensity;
            }
        }
        if square > 0.0 { cross / square } else { 1.0 }
    }

    fn line_error(&self, pose: &Isometry3<f64>, obs: &LineObservation) -> Option<Vector2<f64>> {
        LineReprojection { coeffs: obs.coeffs }.error(self.camera, pose, &obs.endpoints_in_world)
    }

    /// Marks every observation inlier / outlier by its chi-square at `pose` (invalid or
    /// non-finite = outlier).
    fn classify(&self, pose: &Isometry3<f64>, thresholds: &Thresholds, result: &mut PoseResult) {
        for (flag, obs) in result.point_inliers.iter_mut().zip(self.points) {
            *flag = obs.inv_sigma2 > 0.0
                && self.point_residual2(pose, obs).is_some_and(|(e2, depth)| {
                    let threshold = if depth {
                        thresholds.point_depth
                    } else {
                        thresholds.point
                    };
                    obs.inv_sigma2 * e2 <= threshold
                });
        }
        for (flag, obs) in result.line_inliers.iter_mut().zip(self.lines) {
            *flag = obs.inv_sigma2 > 0.0
                && self
                    .line_error(pose, obs)
                    .is_some_and(|e| obs.inv_sigma2 * e.norm_squared() <= thresholds.line);
        }
        for (flag, obs) in result.depth_inliers.iter_mut().zip(self.depth) {
            let e = depth_error(pose, obs);
            *flag = obs.inv_sigma2 > 0.0 && obs.inv_sigma2 * e * e <= thresholds.depth;
        }
        for (flag, obs) in result.plane_inliers.iter_mut().zip(self.planes) {
            let s = obs.whitened_error(pose).norm_squared();
            *flag = s.is_finite() && s <= thresholds.plane;
        }
        if let Some(term) = &self.photometric {
            let gain = self.photometric_gain(term, pose, &result.photometric_inliers);
            for (flag, obs) in result.photometric_inliers.iter_mut().zip(term.observations) {
                *flag = obs.inv_sigma2 > 0.0
                    && self
                        .photometric_residual2(term, pose, obs, gain)
                        .is_some_and(|s| s <= thresholds.photometric);
            }
        }
        result.num_photometric_inliers = result.photometric_inliers.iter().filter(|&&f| f).count();
        result.num_plane_inliers = result.plane_inliers.iter().filter(|&&f| f).count();
        result.num_depth_inliers = result.depth_inliers.iter().filter(|&&f| f).count();
        result.num_point_inliers = result.point_inliers.iter().filter(|&&f| f).count();
        result.num_line_inliers = result.line_inliers.iter().filter(|&&f| f).count();
    }

    fn point_huber(&self, depth: bool) -> &Huber {
        if depth {
            &self.point_depth_huber
        } else {
            &self.point_huber
        }
    }

    /// Robust cost of the active observations; `None` when one of them is not valid at
    /// `pose` (a step that pushes an inlier behind the camera is rejected).
    fn cost(&self, pose: &Isometry3<f64>, result: &PoseResult, robust: bool) -> Option<f64> {
        let mut cost = 0.0;
        for (obs, _) in self
            .points
            .iter()
            .zip(&result.point_inliers)
            .filter(|(_, f)| **f)
        {
            let (e2, depth) = self.point_residual2(pose, obs)?;
            let s = obs.inv_sigma2 * e2;
            cost += if robust {
                self.point_huber(depth).cost(s)
            } else {
                s
            };
        }
        for (obs, _) in self
            .lines
            .iter()
            .zip(&result.line_inliers)
            .filter(|(_, f)| **f)
        {
            let s = obs.inv_sigma2 * self.line_error(pose, obs)?.norm_squared();
            cost += if robust { self.line_huber.cost(s) } else { s };
        }
        for (obs, _) in self
            .depth
            .iter()
            .zip(&result.depth_inliers)
            .filter(|(_, f)| **f)
        {
            let e = depth_error(pose, obs);
            let s = obs.inv_sigma2 * e * e;
            cost += if robust { self.depth_huber.cost(s) } else { s };
        }
        for (obs, _) in self
            .planes
            .iter()
            .zip(&result.plane_inliers)
            .filter(|(_, f)| **f)
        {
            let s = obs.whitened_error(pose).norm_squared();
            cost += if robust { self.plane_huber.cost(s) } else { s };
        }
        if let Some(term) = &self.photometric {
            let gain = self.photometric_gain(term, pose, &result.photometric_inliers);
            for (obs, _) in term
                .observations
                .iter()
                .zip(&result.photometric_inliers)
                .filter(|(_, f)| **f)
            {
                // A point moved off the image costs as one at the rejection threshold:
                // a step is not refused for a border point.
                let s = self
                    .photometric_residual2(term, pose, obs, gain)
                    .unwrap_or(self.photometric_huber.delta.powi(2));
                cost += if robust {
                    self.photometric_huber.cost(s)
                } else {
                    s
                };
            }
        }
        if let Some(prior) = &self.prior {
            cost += prior.cost(pose);
        }
        cost.is_finite().then_some(cost)
    }

    /// Builds `H = sum J^T w Omega J`, `g = sum J^T w Omega e` and the cost at `pose`.
    fn linearize(&self, pose: &Isometry3<f64>, result: &PoseResult, robust: bool) -> Normal {
        let mut n = Normal {
            h: Matrix6::zeros(),
            g: Vector6::zeros(),
            cost: 0.0,
        };
        let camera = self.camera;
        for (obs, _) in self
            .points
            .iter()
            .zip(&result.point_inliers)
            .filter(|(_, f)| **f)
        {
            let huber = robust.then_some(self.point_huber(obs.depth > 0.0));
            if obs.depth > 0.0 {
                let r = StereoPointReprojection::from_depth(obs.uv, obs.depth, self.bf, 1.0);
                if let Some(l) = r.linearize(camera, pose, &obs.point_in_world) {
                    n.add(&l.d_pose, &l.error, obs.inv_sigma2, huber);
                }
            } else {
                let r = PointReprojection { uv: obs.uv };
                if let Some(l) = r.linearize(camera, pose, &obs.point_in_world) {
                    n.add(&l.d_pose, &l.error, obs.inv_sigma2, huber);
                }
            }
        }
        for (obs, _) in self
            .lines
            .iter()
            .zip(&result.line_inliers)
            .filter(|(_, f)| **f)
        {
            let r = LineReprojection { coeffs: obs.coeffs };
            if let Some(l) = r.linearize(camera, pose, &obs.endpoints_in_world) {
                n.add(
                    &l.d_pose,
                    &l.error,
                    obs.inv_sigma2,
                    robust.then_some(&self.line_huber),
                );
            }
        }
        for (obs, _) in self
            .depth
            .iter()
            .zip(&result.depth_inliers)
            .filter(|(_, f)| **f)
        {
            let l = PointToPlane {
                point_in_camera: obs.point_in_camera,
            }
            .linearize(pose, &obs.surface_in_world, &obs.normal_in_world);
            n.add(
                &l.d_pose,
                &nalgebra::Vector1::new(l.error),
                obs.inv_sigma2,
                robust.then_some(&self.depth_huber),
            );
        }
        for (obs, _) in self
            .planes
            .iter()
            .zip(&result.plane_inliers)
            .filter(|(_, f)| **f)
        {
            let l = obs
                .measured
                .linearize(pose, &obs.normal_in_world, obs.offset_in_world);
            let j = obs.whitened_d_pose(&l.d_pose);
            n.add(
                &j,
                &obs.whiten(l.error),
                1.0,
                robust.then_some(&self.plane_huber),
            );
        }
        if let Some(term) = &self.photometric {
            let gain = self.photometric_gain(term, pose, &result.photometric_inliers);
            for (obs, _) in term
                .observations
                .iter()
                .zip(&result.photometric_inliers)
                .filter(|(_, f)| **f)
            {
                let r = Photometric {
                    intensity: gain * obs.intensity,
                };
                if let Some(l) = r.linearize(self.camera, &term.image, pose, &obs.point_in_world) {
                    n.add(
                        &l.d_pose,
                        &nalgebra::Vector1::new(l.error),
                        obs.inv_sigma2,
                        robust.then_some(&self.photometric_huber),
                    );
                }
            }
        }
        if let Some(prior) = &self.prior {
            let l = prior.linearize(pose);
            let jt_w = l.d_pose.transpose() * prior.information;
            n.h += jt_w * l.d_pose;
            n.g += jt_w * l.error;
            n.cost += l.error.dot(&(prior.information * l.error));
        }
        n
    }

    /// One round of LM over the current inliers; returns the estimate, the iterations
    /// run and whether it converged.
    fn run_lm(
        &self,
        mut pose: Isometry3<f64>,
        result: &PoseResult,
        robust: bool,
        max_iterations: usize,
    ) -> (Isometry3<f64>, usize, bool) {
        let mut damping = Damping::new();
        let mut normal = self.linearize(&pose, result, robust);
        // An exact fit: nothing to reduce.
        if normal.cost <= 0.0 {
            return (pose, 0, true);
        }
        for iteration in 1..=max_iterations {
            let mut step = None;
            loop {
                let mut a = normal.h;
                let mut damping_diag = Vector6::zeros();
                for k in 0..6 {
                    damping_diag[k] = damping.diagonal_term(normal.h[(k, k)]);
                    a[(k, k)] += damping_diag[k];
                }
                if let Some(cholesky) = a.cholesky() {
                    let delta = -cholesky.solve(&normal.g);
                    let candidate = retract(&pose, &delta);
                    if let Some(cost) = self.cost(&candidate, result, robust)
                        && cost < normal.cost
                    {
                        let predicted =
                            delta.dot(&damping_diag.component_mul(&delta)) - normal.g.dot(&delta);
                        damping.accept((normal.cost - cost) / predicted.max(f64::MIN_POSITIVE));
                        step = Some((candidate, delta.norm(), cost));
                        break;
                    }
                }
                if !damping.reject() {
                    break;
                }
            }
            // No decrease at any damping: the estimate is a minimum to working precision.
            let Some((candidate, step_norm, cost)) = step else {
                return (pose, iteration, true);
            };
            let decrease = normal.cost - cost;
            pose = candidate;
            if step_norm < STEP_TOLERANCE || decrease <= RELATIVE_COST_TOLERANCE * normal.cost {
                return (pose, iteration, true);
            }
            normal = self.linearize(&pose, result, robust);
        }
        (pose, max_iterations, false)
    }

    fn inlier_rms(&self, pose: &Isometry3<f64>, result: &PoseResult) -> f64 {
        let mut sum = 0.0;
        let mut components = 0usize;
        for (obs, _) in self
            .points
            .iter()
            .zip(&result.point_inliers)
            .filter(|(_, f)| **f)
        {
            if let Some((e2, depth)) = self.point_residual2(pose, obs) {
                sum += e2;
                components += if depth { 3 } else { 2 };
            }
        }
        for (obs, _) in self
            .lines
            .iter()
            .zip(&result.line_inliers)
            .filter(|(_, f)| **f)
        {
            if let Some(e) = self.line_error(pose, obs) {
                sum += e.norm_squared();
                components += 2;
            }
        }
        if components == 0 {
            0.0
        } else {
            (sum / components as f64).sqrt()
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
        let camera = PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480);
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

    #[test]
    fn a_prior_holds_what_one_wall_leaves_free_and_stays_out_of_the_information() {
        // A wall (z = 3) seen by depth only, 1 mm sigma: it fixes the distance and the
        // two tilts, not the slide along it nor the turn about its normal. The true pose
        // is 2 cm nearer than the prediction and 1.5 cm aside.
        let camera = PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480);
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
