//! A keyframe: a frame kept in the map with its pose, features and landmark links.

use crate::frontend::features::FrameFeatures;
use gfs_core::ids::{KeyFrameId, MapLineId, MapPlaneId, MapPointId};
use nalgebra::Isometry3;

/// A frame kept in the map.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct KeyFrame {
    /// Its id.
    pub id: KeyFrameId,
    /// `camera_from_world` (T_cw): the tracked pose, refined by the local BAs of the
    /// newer keyframes it is a neighbour of (its own BA holds it fixed).
    pub camera_from_world: Isometry3<f64>,
    /// The features of the frame.
    pub features: FrameFeatures,
    /// For each keypoint, the map point it observes.
    pub point_ids: Vec<Option<MapPointId>>,
    /// For each line, the map line it observes.
    pub line_ids: Vec<Option<MapLineId>>,
    /// For each plane of the frame, the map plane it observes.
    #[serde(default)]
    pub plane_ids: Vec<Option<MapPlaneId>>,
    /// The loop corrections it received (`new_from_old`, world frame, composed):
    /// identity until a loop closes.
    #[serde(default = "Isometry3::identity")]
    pub loop_correction: Isometry3<f64>,
}

impl KeyFrame {
    /// `world_from_camera` (T_wc).
    pub fn world_from_camera(&self) -> Isometry3<f64> {
        self.camera_from_world.inverse()
    }

    /// The distance between this keyframe's camera centre and `world_from_camera`'s
    /// when the two share a view: centres within `radius_m`, optical axes at most
    /// `angle_rad` apart; `None` otherwise.
    pub fn view_distance(
        &self,
        world_from_camera: &Isometry3<f64>,
        radius_m: f64,
        angle_rad: f64,
    ) -> Option<f64> {
        let own = self.world_from_camera();
        let distance = (own.translation.vector - world_from_camera.translation.vector).norm();
        let axis = |pose: &Isometry3<f64>| pose.rotation * nalgebra::Vector3::z();
        let facing = axis(&own).dot(&axis(world_from_camera));
        (distance <= radius_m && facing >= angle_rad.cos()).then_some(distance)
    }

    /// Number of keypoints linked to a map point.
    pub fn tracked_points(&self) -> usize {
        self.point_ids.iter().flatten().count()
    }

    /// Number of lines linked to a map line.
    pub fn tracked_lines(&self) -> usize {
        self.line_ids.iter().flatten().count()
    }
}
