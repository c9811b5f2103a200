//! Tracking (paper section III-C, "Grid-based Tracking"): every frame is posed against
//! the local map. The [`tracker::Tracker`] predicts the pose with the constant-velocity
//! [`motion`] model, re-times a rolling-shutter frame to its middle row
//! ([`rolling_shutter`]), matches points and lines by projection into grids
//! ([`matching`]), tries its strategies in order (motion model, wide search with
//! [`ransac`], reference keyframe) and optimises the pose on the matches
//! ([`pose_solver`], with the measurements of [`observation`]). Where features are too
//! few, the depth alignment (`crate::depth`) and the frame's planes paired with the
//! map's ([`plane_association`]) hold the pose, drawn towards the prediction by
//! [`motion_prior`]. A frame nothing tracks is relocalised ([`relocalisation`]). What the
//! tracker saw of each landmark is counted in [`sightings`]; each pose leaves with a
//! [`status`] and the covariance of [`pose_uncertainty`].

pub mod inertial;
pub mod matching;
pub(crate) mod motion;
pub(crate) mod motion_prior;
pub(crate) mod observation;
pub(crate) mod plane_association;
pub(crate) mod pose_solver;
pub(crate) mod pose_uncertainty;
pub(crate) mod ransac;
pub(crate) mod relocalisation;
pub(crate) mod rolling_shutter;
pub(crate) mod sightings;
pub(crate) mod status;
pub(crate) mod tracker;
