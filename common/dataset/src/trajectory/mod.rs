//! Trajectories and their evaluation against ground truth, with the definitions of the
//! `evo` tools: association by timestamp, SE(3) Umeyama alignment, ATE and RPE.

mod align;
mod associate;
mod consistency;
mod covariances;
mod metrics;
mod tum;

pub use align::{AlignError, umeyama_se3};
pub use associate::{EVO_MAX_DIFF_S, associate};
pub use consistency::{CHI2_6DOF_999, Consistency, consistency, motion_covariance};
pub use covariances::Covariances;
pub use metrics::{
    Ate, EvalError, Evaluation, Rpe, Stats, ate, evaluate, rpe_per_frame, rpe_per_second,
};
pub use tum::{Trajectory, TrajectoryError};

#[cfg(test)]
mod metrics_tests;
