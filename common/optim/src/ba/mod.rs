//! Local bundle adjustment with structural constraints (paper eq. 10-14).

mod config;
mod linear;
mod normal;
mod problem;
mod solver;
mod terms;

pub use config::{BaConfig, ONE_DEGREE_INFORMATION};
pub use problem::{
    BaError, BaLineObservation, BaLinePrior, BaManhattan, BaPlaneAxis, BaPlaneObservation,
    BaPointObservation, BaPose, BaProblem,
};
pub use solver::{BaResult, LocalBundleAdjuster};
pub use terms::BaFlags;
