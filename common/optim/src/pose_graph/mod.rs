//! Pose-graph optimisation over SE(3) keyframe poses (the loop closure's essential
//! graph: spanning tree, strong covisibility and loop edges).
//!
//! ```text
//! T* = argmin_T  sum_edges rho(e_ij^T Omega_ij e_ij),   e_ij = log(Z_ij^-1 T_i^-1 T_j)
//! ```
//!
//! with `T_i` the `world_from_camera` poses, `Z_ij = i_from_j` the measured relative
//! poses, `rho` an optional robust kernel; some nodes are fixed (at least one: the
//! gauge). Levenberg-Marquardt with analytic Jacobians on the left perturbation, the
//! normal equations block-sparse and solved by faer's sparse Cholesky.

mod config;
mod edge;
mod graph;
mod system;

pub use config::{CHI2_6DOF_95, PoseGraphConfig, PoseGraphError, PoseGraphKernel, PoseGraphReport};
pub use graph::PoseGraph;
