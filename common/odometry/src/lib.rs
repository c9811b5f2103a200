//! The visual odometry of GFS-VO (paper section III-C).
//!
//! **What.** Frames come in as [`FrameFeatures`] (ORB keypoints with depth, homogenised
//! lines with LBD descriptors and 3D lines, the frame's Manhattan axes); a pose comes
//! out for every frame ([`FramePose`], `T_wc` with a [`TrackingStatus`]).
//!
//! **Model.** The [`map::Map`] holds keyframes and landmarks (map points, map lines
//! with their Manhattan axis) in one id-keyed store per landmark kind
//! ([`map::Landmark`]); covisibility is derived from shared observations. The
//! [`Tracker`] reads the map: it predicts with a constant-velocity model, tries the
//! [`Strategy`] list in order (motion model, wide search with RANSAC, reference
//! keyframe), tracks the local map and optimises the pose on point reprojection and
//! line endpoint-to-line errors (eq. 6-9); a frame nothing tracks is relocalised
//! around its reference keyframe, else by the mapping half against the whole map
//! ([`MapRelocaliser`]). What it saw of each landmark goes into [`Sightings`]. The
//! [`Mapper`] turns keyframes (chosen on points **or** lines, [`needs_keyframe`]) into
//! landmarks, fuses duplicates, runs the local BA with reprojection, structural and
//! Manhattan terms (eq. 10-14) and culls keyframes redundant in both points and lines.
//! The map is bounded, so memory and time stay flat over long runs. When the camera
//! comes back to a place, [`loop_closing`] finds it (bag of words and position),
//! verifies it, optimises a pose graph over the keyframes and moves the landmarks; the
//! tracker takes the correction into `map_from_odom` (REP 105 `map -> odom`) so that the
//! poses it publishes stay continuous, and [`FinalTrajectory`] gives every frame the
//! corrections that came after it.
//!
//! **Use.** [`Odometry::process`] runs tracking and mapping in the caller's thread; the
//! pipeline runs the two halves of [`session`] as two services that exchange keyframe
//! requests (with the sightings) and maps (the same messages the in-process path passes
//! by value). The tracking half is a state machine ([`session::TrackingState`]: no map,
//! tracking, lost; a long outage starts a new local map at the predicted pose, in the
//! same world frame) that a restarted tracker resumes from its checkpoint. [`Frontend`]
//! extracts the features of a frame in-process.
#![warn(missing_docs)]

mod config;
mod depth_alignment;
mod depth_grid;
mod final_trajectory;
mod frame;
mod frontend;
mod keyframe_policy;
mod local_ba;
pub mod loop_closing;
mod manhattan;
pub mod map;
mod map_relocalisation;
mod mapper;
pub mod matching;
mod messages_check;
mod motion;
mod motion_prior;
mod observation;
mod odometry;
mod photometric_alignment;
mod plane_association;
mod plane_mapping;
mod pose_solver;
mod ransac;
mod reference_intensity;
mod relocalise;
mod rolling_shutter;
pub mod session;
mod sightings;
mod status;
#[cfg(test)]
mod testing;
mod tracker;
mod validate;

pub use config::{
    KeyframeConfig, LoopClosingConfig, MappingConfig, OdometryConfig, TrackingConfig,
};
pub use depth_alignment::{
    DepthAlignmentConfig, DepthAssociator, kinect_depth_sigma, self_information,
};
pub use depth_grid::DepthGrid;
pub use final_trajectory::{FinalTrajectory, FrameAnchor};
pub use frame::{FeatureError, FrameFeatures, FrameSurfaces};
pub use frontend::{
    DEPTH_GRID_STEP, Frontend, FrontendError, FrontendTimings, StructureExtractor, SurfaceRequest,
};
pub use keyframe_policy::{KeyframeContext, needs_keyframe};
pub use manhattan::WorldManhattan;
pub use map_relocalisation::{MapRelocalisation, MapRelocaliser};
pub use mapper::Mapper;
pub use messages_check::MessageError;
pub use motion::MotionModel;
pub use odometry::{Odometry, OdometryTimings};
pub use plane_association::{PlaneAssociator, PlaneTrackingConfig};
pub use pose_solver::Inliers;
pub use relocalise::{Relocalisation, relocalise};
pub use session::FramePose;
pub use sightings::{SightingCount, Sightings};
pub use status::TrackingStatus;
pub use tracker::{Strategy, TrackedFrame, Tracker};
