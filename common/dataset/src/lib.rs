//! Datasets and evaluation of GFS-VO.
//!
//! What it holds, and why it is one crate: everything between files on disk and the
//! algorithms (reading RGB-D sequences) and between the algorithms and a number in a
//! paper table (trajectories, ATE / RPE). Nothing here knows about the pipeline; the
//! figures are drawn by `gfs-plot`.
//!
//! - [`Sequence`] opens a TUM RGB-D folder (or an ICL-NUIM / 7-Scenes folder in TUM
//!   layout): `associations.txt` when present, otherwise `rgb.txt` and `depth.txt`
//!   associated by TUM's rule (closest free stamps within 20 ms). [`Sequence::frames`]
//!   decodes ahead on a thread; every [`Frame`] is undistorted (when the camera has
//!   distortion), has its gray image, and depth in metres (0.0 = missing, see
//!   [`DepthConfig`]).
//! - [`trajectory`]: [`Trajectory`] read / write in TUM format (`T_wc` per line), and
//!   [`evaluate`] with the definitions of the `evo` tools: association within 10 ms,
//!   SE(3) Umeyama alignment, ATE (`evo_ape tum GT EST --align`) and RPE per frame
//!   (`evo_rpe tum GT EST`) and per second.
//!
//! Model of the evaluation, for matched poses `k` (ground truth `Q_k`, estimate `P_k`):
//! `ATE_k = |t(Q_k) - t(S P_k)|` with `S = argmin sum_k |t(Q_k) - t(S P_k)|^2` over SE(3);
//! `RPE_ij = (Q_i^-1 Q_j)^-1 (P_i^-1 P_j)`, reported as translation norm and angle.
//!
//! ```
//! use gfs_core::stamp::Stamp;
//! use gfs_dataset::{Trajectory, evaluate, EVO_MAX_DIFF_S};
//! use nalgebra::{Isometry3, Translation3, UnitQuaternion};
//! let mut gt = Trajectory::new();
//! let mut est = Trajectory::new();
//! let moved = Isometry3::from_parts(Translation3::new(1.0, 2.0, 0.5), UnitQuaternion::from_euler_angles(0.1, 0.2, 0.3));
//! for k in 0..50 {
//!     let t = k as f64 / 30.0;
//!     let pose = Isometry3::translation(t.cos(), t.sin(), 0.1 * t);
//!     let stamp = Stamp::from_nanos(k * 33_333_333);
//!     gt.push(stamp, pose);
//!     // The same motion in another world frame, stamped 2 ms later.
//!     est.push(Stamp::from_nanos(stamp.nanos() + 2_000_000), moved * pose);
//! }
//! let eval = evaluate(&gt, &est, EVO_MAX_DIFF_S)?;
//! assert_eq!(eval.matched(), 50);
//! assert!(eval.ate.stats.rmse < 1e-9);
//! # Ok::<(), gfs_dataset::EvalError>(())
//! ```
#![warn(missing_docs)]

mod decode;
mod depth;
mod error;
mod imu;
mod lists;

mod reader;
mod sequence;
pub mod trajectory;

pub use decode::{Frame, gray_bt601};
pub use depth::{DepthConfig, DepthSensor};
pub use error::DatasetError;
pub use imu::{IMU_LIST, ImuList, read_imu};
pub use lists::{TUM_MAX_DIFFERENCE_S, associate_tum};
pub use reader::FrameReader;
pub use sequence::{DEFAULT_READ_AHEAD, Sequence};
pub use trajectory::{
    Ate, CHI2_6DOF_999, Consistency, Covariances, EVO_MAX_DIFF_S, EvalError, Evaluation, Rpe,
    Stats, Trajectory, TrajectoryError, consistency, evaluate,
};
