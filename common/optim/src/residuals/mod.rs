//! The error terms of the odometry, one per file, each a small struct holding only its
//! measurement with a `linearize` method returning the error and its Jacobians
//! (paper section III-C, eq. 6-14).
//!
//! Conventions: poses are `camera_from_world` (T_cw) perturbed on the left,
//! `T ⊕ delta = exp(delta) * T` with `delta = [rho; phi]` (see `gfs_core::se3`), so the
//! Jacobian of `p_c = T_cw p_w` with respect to `delta` is `[I, -[p_c]x]`. A 3D line is
//! its two world endpoints `[S, E]` stacked as 6 parameters (S first).

mod direction;
mod line;
mod manhattan;
mod parallel;
mod perpendicular;
mod photometric;
mod plane;
mod plane_axis;
mod plane_pairs;
mod point;
mod point_to_plane;
mod pose_prior;
mod projection;
mod stereo;

pub use line::{LineLinearization, LineReprojection};
pub use manhattan::{ManhattanAxis, ManhattanLinearization};
pub use parallel::{ParallelLinearization, ParallelLines};
pub use perpendicular::{PerpendicularLinearization, PerpendicularLines};
pub use photometric::{IntensityGrid, Photometric, PhotometricLinearization, PhotometricReading};
pub use plane::{PlaneLinearization, PlaneToPlane, plane_plus, tangent_basis};
pub use plane_axis::{PlaneAxis, PlaneAxisLinearization};
pub use plane_pairs::{
    ParallelPlanes, ParallelPlanesLinearization, PerpendicularPlanes,
    PerpendicularPlanesLinearization,
};
pub use point::{PointLinearization, PointReprojection};
pub use point_to_plane::{PointToPlane, PointToPlaneLinearization};
pub use pose_prior::{PosePrior, PosePriorLinearization};
pub use stereo::{StereoPointLinearization, StereoPointReprojection};

#[cfg(test)]
pub(crate) mod testing;
