//! The visual odometry of GFS-VO (paper section III-C).
//!
//! **What.** Frames come in as [`FrameFeatures`] (ORB keypoints with depth, homogenised
//! lines with LBD descriptors and 3D lines, the frame's Manhattan axes); a pose comes
//! out for every frame ([`FramePose`], `T_wc` with a [`TrackingStatus`]).
//!
//! **Model.** The [`map::Map`] holds keyframes and landmarks (map points, map lines
//! with their Manhattan axis) in id-keyed arenas; covisibility is derived from shared
//! observations. The [`Tracker`] predicts with a constant-velocity model, matches points
//! by projection in a keypoint grid and lines through the line grid (with the extension
//! search of Fig. 6), optimises the pose on point reprojection and line
//! endpoint-to-line errors (eq. 6-9), then tracks the local map. The [`Mapper`] turns
//! keyframes (chosen on points **and** lines) into landmarks, fuses duplicates, runs the
//! local BA with reprojection, structural and Manhattan terms (eq. 10-14) and culls
//! keyframes redundant in both points and lines. The map is bounded, so memory and
//! time stay flat over long runs. A lost frame is relocalised against the map, or gets
//! the predicted pose; a long outage starts a new local map at the predicted pose, in
//! the same world frame.
//!
//! **Use.** [`Odometry::process`] runs tracking and mapping in the caller's thread; the
//! pipeline runs the two halves of [`session`] as two services that exchange keyframe
//! requests and map snapshots (the same messages the in-process path passes by value). [`Frontend`]
//! extracts the features of a frame in-process.
#![warn(missing_docs)]

mod config;
mod frame;
mod frontend;
mod keyframe_policy;
mod local_ba;
mod manhattan;
pub mod map;
mod mapper;
pub mod matching;
mod motion;
mod observation;
mod odometry;
mod pose_solver;
mod ransac;
mod relocalise;
mod rolling_shutter;
pub mod session;
mod sightings;
mod status;
#[cfg(test)]
mod testing;
mod tracker;

pub use config::{KeyframeConfig, MappingConfig, OdometryConfig, TrackingConfig};
pub use frame::{FeatureError, FrameFeatures};
pub use frontend::{Frontend, FrontendError, FrontendTimings, StructureExtractor};
pub use keyframe_policy::{KeyframeContext, needs_keyframe};
pub use manhattan::WorldManhattan;
pub use mapper::Mapper;
pub use motion::MotionModel;
pub use odometry::{Odometry, OdometryTimings};
pub use pose_solver::Inliers;
pub use relocalise::{Relocalisation, relocalise};
pub use session::FramePose;
pub use sightings::{SightingCount, Sightings};
pub use status::TrackingStatus;
pub use tracker::{Strategy, TrackedFrame, Tracker};
