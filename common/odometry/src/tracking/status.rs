//! What the odometry says about each frame's pose.

use serde::{Deserialize, Serialize};

/// How the pose of a frame was obtained; written beside the trajectory (`status.txt`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TrackingStatus {
    /// Tracked against the map with enough inliers.
    Tracked,
    /// Tracked, but with few inliers or with a feature stream missing: less trustworthy.
    Degraded,
    /// Not tracked: the pose is the motion-model prediction.
    Predicted,
    /// Tracking was lost and the pose was recovered against the local map.
    Relocalised,
}

impl TrackingStatus {
    /// The word written in `status.txt`.
    pub fn as_str(&self) -> &'static str {
        match self {
            Self::Tracked => "tracked",
            Self::Degraded => "degraded",
            Self::Predicted => "predicted",
            Self::Relocalised => "relocalised",
        }
    }

    /// True when the pose came from matched features (not a prediction).
    pub fn is_tracked(&self) -> bool {
        !matches!(self, Self::Predicted)
    }
}

impl std::fmt::Display for TrackingStatus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}
