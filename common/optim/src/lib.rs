//! gfs-optim (in progress).
#![warn(missing_docs)]

mod ba;
mod lm;
mod pose;
pub mod residuals;
pub mod robust;

pub use ba::{
    BaConfig, BaError, BaFlags, BaLineObservation, BaManhattan, BaPointObservation, BaPose,
    BaProblem, BaResult, LocalBundleAdjuster, ONE_DEGREE_INFORMATION,
};
pub use pose::{LineObservation, PointObservation, PoseOptimizerConfig, PoseResult, optimize_pose};
