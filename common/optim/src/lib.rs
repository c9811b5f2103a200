//! Pose optimisation and local bundle adjustment of GFS-VO (paper section III-C,
//! eq. 6-14): the nonlinear least squares behind tracking and local mapping.
//!
//! # Model
//!
//! Tracking ([`optimize_pose`]) estimates one `camera_from_world` pose `T` against fixed
//! map points `P` and map lines `[S, E]`:
//!
//! ```text
//! T* = argmin_T  sum_points rho(|e_P|^2_Omega) + sum_lines rho(|e_L|^2_Omega)
//! e_P = uv - pi(T P)                                   (eq. 6, or the RGB-D form)
//! e_L = [l . (pi(T S), 1), l . (pi(T E), 1)]           (eq. 7, l = (a, b, c), a^2+b^2 = 1)
//! ```
//!
//! with the Huber kernel `rho`, Levenberg-Marquardt on SE(3) and ORB-SLAM2's rounds of
//! chi-square outlier rejection. Local mapping ([`LocalBundleAdjuster`]) also moves the
//! covisible keyframe poses, the points and the lines, and adds the structural terms
//! of MSC-VO (eq. 10-14): `|d_i x d_j|` for parallel pairs, `d_i . d_j` for
//! perpendicular pairs, `|d x a|` for a line and its Manhattan axis `a`; map planes
//! (unit normal on S2 + offset) add plane-to-plane observations and the same three
//! structural forms on their normals (`n_i x n_j`, `n_i . n_j`, `n x a`).
//!
//! Conventions (see `gfs_core::se3`): optimisers estimate `camera_from_world` and
//! perturb it on the left, `T ⊕ delta = exp(delta) T`, `delta = [rho; phi]`; pixels
//! are undistorted; a line is its two world endpoints. Points with a measured depth add
//! a virtual disparity `bf / depth` to the 2D error, which fixes depth and scale; the
//! local BA weighs it by the sensor's inverse-depth sigma.
//!
//! Loop closure ([`PoseGraph`]) optimises keyframe poses `T_wc` alone over relative-pose
//! edges `e = log(Z^-1 T_i^-1 T_j)` with the same left perturbation and sparse solver.
//!
//! The error terms live in [`residuals`], one per file, each with analytic Jacobians
//! checked against numeric differences. The local BA solves each LM step exactly by
//! the Schur complement (points and unpaired lines eliminated, structurally paired
//! lines kept with the poses) and faer's sparse Cholesky; see [`LocalBundleAdjuster`].
//!
//! # Example
//!
//! ```
//! use gfs_core::camera::PinholeCamera;
//! use gfs_optim::{optimize_pose, PointObservation, PoseOptimizerConfig, PoseResult};
//! use nalgebra::{Isometry3, Point3, Translation3, Vector3};
//!
//! let camera = PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480);
//! let truth = Isometry3::translation(0.1, 0.0, 0.0);
//! let points: Vec<PointObservation> = (0..40)
//!     .map(|i| {
//!         let p_w = Vector3::new((i % 8) as f64 * 0.3 - 1.0, (i / 8) as f64 * 0.3 - 0.6, 3.0 + (i % 3) as f64);
//!         let uv = camera.project(&(truth * Point3::from(p_w))).expect("in front").coords;
//!         PointObservation { point_in_world: p_w, uv, inv_sigma2: 1.0, depth: 0.0 }
//!     })
//!     .collect();
//! let initial = Translation3::new(0.03, -0.02, 0.05) * truth;
//! let mut result = PoseResult::default();
//! optimize_pose(&camera, &initial, &points, &[], &PoseOptimizerConfig::default(), &mut result);
//! let error = (result.camera_from_world.translation.vector - truth.translation.vector).norm();
//! assert!(result.converged && error < 1e-6 && result.num_point_inliers == 40);
//! ```
#![warn(missing_docs)]

mod ba;
mod block_cholesky;
mod degeneracy;
mod lm;
mod pose;
mod pose_graph;
pub mod residuals;
pub mod robust;

pub use ba::{
    BaConfig, BaError, BaFlags, BaLineObservation, BaLinePrior, BaManhattan, BaPlaneAxis,
    BaPlaneObservation, BaPointObservation, BaPose, BaProblem, BaResult, LocalBundleAdjuster,
    ONE_DEGREE_INFORMATION,
};
pub use degeneracy::{PoseConstraint, analyse_constraint, map_eigenvalues};
pub use pose::{
    DepthObservation, LineObservation, PhotometricObservation, PhotometricScratch, PhotometricTerm,
    PlaneObservation, PointObservation, PoseOptimizerConfig, PoseResult, SurfaceObservations,
    optimize_pose, optimize_pose_with_depth,
};
pub use pose_graph::{
    CHI2_6DOF_95, PoseGraph, PoseGraphConfig, PoseGraphError, PoseGraphKernel, PoseGraphReport,
};
