//! The tracker's input: everything the front-end stages extracted from one frame.

use crate::depth::grid::DepthGrid;
use gfs_core::ids::FrameId;
use gfs_core::stamp::Stamp;
use gfs_lines::{DetectedLine, Line3};
use gfs_planes::{ManhattanAxes, Plane};
use gfs_points::KeyPoint;

/// 256-bit binary descriptors (ORB rBRIEF and binary LBD share the layout) and their
/// distance.
pub use gfs_points::{Descriptor, hamming};

/// Features of one frame, as the points, lines and planes stages deliver them.
/// Parallel vectors: `point_descriptors[i]` describes `keypoints[i]`, and
/// `line_descriptors[j]`, `lines3d[j]` belong to `lines[j]`.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct FrameFeatures {
    /// Input frame id.
    pub id: FrameId,
    /// Capture stamp, as the source gave it.
    pub timestamp: Stamp,
    /// ORB keypoints in undistorted pixels, with depth (0 = none).
    pub keypoints: Vec<KeyPoint>,
    /// rBRIEF descriptors of `keypoints`.
    pub point_descriptors: Vec<Descriptor>,
    /// Homogenised line segments in undistorted pixels.
    pub lines: Vec<DetectedLine>,
    /// LBD descriptors of `lines`.
    pub line_descriptors: Vec<Descriptor>,
    /// 3D lines in the camera frame (invalid where depth did not support one).
    pub lines3d: Vec<Line3>,
    /// Manhattan axes of the frame, in the camera frame, if the scene showed structure.
    pub manhattan: Option<ManhattanAxes>,
    /// The frame's BFS planes, camera frame (empty unless `[tracking] use_planes`).
    #[serde(default)]
    pub planes: Vec<Plane>,
    /// The frame's depth, sub-sampled points and normals (empty when the planes stage
    /// did not run or does not deliver it).
    #[serde(default)]
    pub depth: DepthGrid,
}

/// The parts of [`FrameFeatures`] that only the depth and plane terms use: what the
/// pipeline's planes stage sends beside the Manhattan axes when they are switched on.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FrameSurfaces {
    /// The frame's BFS planes (empty unless `[tracking] use_planes`).
    pub planes: Vec<Plane>,
    /// The frame's depth grid (empty unless `[tracking] use_depth_alignment`).
    pub depth: DepthGrid,
}

impl FrameFeatures {
    /// A copy without the depth grid, which serves the tracker's next frame only (the
    /// map's keyframes do not keep it).
    pub fn without_depth(&self) -> Self {
        Self {
            id: self.id,
            timestamp: self.timestamp,
            keypoints: self.keypoints.clone(),
            point_descriptors: self.point_descriptors.clone(),
            lines: self.lines.clone(),
            line_descriptors: self.line_descriptors.clone(),
            lines3d: self.lines3d.clone(),
            manhattan: self.manhattan,
            planes: self.planes.clone(),
            depth: DepthGrid::default(),
        }
    }

    /// Checks that the parallel vectors have matching lengths.
    ///
    /// # Errors
    /// [`FeatureError`] naming the frame and the vectors that disagree.
    pub fn validate(&self) -> Result<(), FeatureError> {
        let check = |what: &'static str, got: usize, want: usize| {
            if got == want {
                Ok(())
            } else {
                Err(FeatureError {
                    frame: self.id,
                    what,
                    got,
                    want,
                })
            }
        };
        check(
            "point_descriptors",
            self.point_descriptors.len(),
            self.keypoints.len(),
        )?;
        check(
            "line_descriptors",
            self.line_descriptors.len(),
            self.lines.len(),
        )?;
        check("lines3d", self.lines3d.len(), self.lines.len())
    }
}

/// Feature vectors of a frame that do not line up.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
#[error("frame {frame}: {what} has {got} entries, expected {want}")]
pub struct FeatureError {
    /// The frame.
    pub frame: FrameId,
    /// The vector that has the wrong length.
    pub what: &'static str,
    /// Its length.
    pub got: usize,
    /// The length it should have.
    pub want: usize,
}

#[cfg(test)]
mod tests {
    use crate::testing::{Scene, pose};

    #[test]
    fn vectors_that_do_not_line_up_are_named() {
        let mut features = Scene::new(10, 3).features(4, &pose(0.0, 0.0));
        assert_eq!(features.validate(), Ok(()));
        features.lines3d.pop();
        let e = features.validate().unwrap_err();
        assert_eq!((e.what, e.got, e.want), ("lines3d", 2, 3));
        assert_eq!(e.to_string(), "frame 4: lines3d has 2 entries, expected 3");
        features.point_descriptors.clear();
        assert_eq!(features.validate().unwrap_err().what, "point_descriptors");
    }
}
