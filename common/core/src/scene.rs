//! What a viewer draws of a map: points, segments, bounded plane patches and keyframe
//! poses in the world frame, as plain data; and of a tracked frame ([`FrameView`]): its
//! matched keypoints and lines. The odometry builds them; the figures and the ROS 2
//! visualisation messages draw them.

use nalgebra::{Isometry3, Point3, Vector3};

/// A 3D segment of the map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneLine {
    /// Endpoints, world frame, metres.
    pub ends: [Point3<f64>; 2],
    /// The Manhattan axis (0, 1, 2) it is parallel to, if any.
    pub axis: Option<u8>,
}

/// A bounded patch of a map plane: a rectangle in the plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScenePlane {
    /// Corners in order around the rectangle, world frame, metres.
    pub corners: [Point3<f64>; 4],
    /// Unit normal, world frame.
    pub normal: Vector3<f64>,
    /// The Manhattan axis (0, 1, 2) its normal is parallel to, if any.
    pub axis: Option<u8>,
}

/// A map as a viewer draws it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Scene {
    /// Map points, world frame, metres.
    pub points: Vec<Point3<f64>>,
    /// Map lines.
    pub lines: Vec<SceneLine>,
    /// Map planes as patches around what was seen of them.
    pub planes: Vec<ScenePlane>,
    /// Keyframe poses (`world_from_camera`) in the order they were made.
    pub keyframes: Vec<Isometry3<f64>>,
    /// Unit directions of the Manhattan axes in the world frame, when known.
    pub axes: Option<[Vector3<f64>; 3]>,
}

impl Scene {
    /// True when there is nothing to draw.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
            && self.lines.is_empty()
            && self.planes.is_empty()
            && self.keyframes.is_empty()
    }
}

/// A keypoint of a tracked frame that was matched to a map point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FramePoint {
    /// Undistorted pixel (u, v).
    pub uv: [f32; 2],
    /// Depth, metres (0 = none).
    pub depth: f32,
    /// True when an inlier of the frame's pose, false when its optimisation rejected it.
    pub inlier: bool,
}

/// A line of a tracked frame that was matched to a map line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameLine {
    /// Undistorted pixel endpoints.
    pub ends: [[f32; 2]; 2],
    /// As [`FramePoint::inlier`].
    pub inlier: bool,
}

/// A tracked frame as a viewer draws it: its matched keypoints and lines.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameView {
    /// Matched keypoints.
    pub points: Vec<FramePoint>,
    /// Matched lines.
    pub lines: Vec<FrameLine>,
}
