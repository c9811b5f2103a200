//! The pose of one frame as the tracking half publishes it.

use crate::tracking::status::TrackingStatus;
use crate::tracking::tracker::TrackedFrame;
use gfs_core::ids::FrameId;
use gfs_core::stamp::Stamp;
use nalgebra::Isometry3;
use serde::{Deserialize, Serialize};

/// The pose of one frame, as published.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FramePose {
    /// The frame.
    pub id: FrameId,
    /// Its capture stamp, as the source gave it.
    pub timestamp: Stamp,
    /// `world_from_camera` (T_wc) in the odometry frame (REP 105 `odom`): continuous,
    /// loop corrections never move it; the map pose is `map_from_odom * this`
    /// ([`TrackingSession::map_from_odom`]). Equal to the map pose until a loop closes.
    pub world_from_camera: Isometry3<f64>,
    /// How the pose was obtained.
    pub status: TrackingStatus,
}

impl FramePose {
    /// The pose of a tracked frame.
    pub fn of(frame: &TrackedFrame) -> Self {
        Self {
            id: frame.features.id,
            timestamp: frame.features.timestamp,
            world_from_camera: frame.camera_from_world.inverse(),
            status: frame.status,
        }
    }
}
