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
//!
//! **Layout**, by the paper's parts: `frontend` (the features of a frame),
//! [`tracking`] (every frame against the local map), `depth` (depth and intensity as
//! tracking terms where points are few), `mapping` (keyframes and the local BA),
//! [`map`] (and [`map_file`], a map kept on disk), [`loop_closing`], and [`session`] (the two halves, their messages and the
//! in-process entry point); `config` holds the tables of all of them.
#![warn(missing_docs)]

mod config;
mod depth;
mod frontend;
pub mod loop_closing;
pub mod map;
pub mod map_file;
mod mapping;
pub mod session;
#[cfg(test)]
mod testing;
pub mod tracking;

pub use config::{
    KeyframeConfig, LoopClosingConfig, MappingConfig, OdometryConfig, TrackingConfig,
};
pub use depth::alignment::{DepthAlignmentConfig, DepthAssociator, self_information};
pub use depth::grid::DepthGrid;
pub use depth::noise::DepthNoise;
pub use frontend::features::{FeatureError, FrameFeatures, FrameSurfaces};
pub use frontend::{
    DEPTH_GRID_STEP, Frontend, FrontendError, FrontendTimings, StructureExtractor, SurfaceRequest,
};
pub use map::manhattan::WorldManhattan;
pub use mapping::keyframe_policy::{KeyframeContext, needs_keyframe};
pub use mapping::mapper::Mapper;
pub use session::FramePose;
pub use session::final_trajectory::{FinalTrajectory, FrameAnchor};
pub use session::messages_check::MessageError;
pub use session::odometry::{Odometry, OdometryTimings};
pub use tracking::motion::MotionModel;
pub use tracking::plane_association::{PlaneAssociator, PlaneTrackingConfig};
pub use tracking::pose_solver::Inliers;
pub use tracking::relocalisation::against_map::{MapRelocalisation, MapRelocaliser};
pub use tracking::relocalisation::around_reference::{Relocalisation, relocalise};
pub use tracking::sightings::{SightingCount, Sightings};
pub use tracking::status::TrackingStatus;
pub use tracking::tracker::{FrameMatches, Strategy, TrackedFrame, Tracker};
