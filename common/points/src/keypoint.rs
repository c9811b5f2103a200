//! The output of the extractor: plain `#[repr(C)]` keypoints and 256-bit descriptors,
//! laid out so that a message can carry them as slices without conversion.

/// A 256-bit rBRIEF descriptor. Bit `i` (word `i / 64`, bit `i % 64`) is test `i` of the
/// pattern; read as little-endian bytes it is OpenCV's `uchar[32]` layout.
pub use gfs_core::descriptor::Descriptor;

/// One ORB keypoint.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct KeyPoint {
    /// Column in level-0 undistorted pixels (pixel centres at integers).
    pub u: f32,
    /// Row in level-0 undistorted pixels.
    pub v: f32,
    /// Pyramid level it was detected on (0 = full resolution).
    pub level: u32,
    /// Orientation by intensity centroid, radians in `[0, 2π)`, measured from the +u axis
    /// towards +v (image y down).
    pub angle: f32,
    /// FAST score: the largest threshold at which the corner is still detected.
    pub response: f32,
    /// Depth of the keypoint's point in metres ([`crate::keypoint_depth`]); 0 = missing,
    /// out of the valid range, or a T-junction at an occlusion edge.
    pub depth: f32,
}

/// Keypoints and their descriptors, index-aligned. Reused frame to frame: the extractor
/// clears and refills it without giving back its memory.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct OrbFeatures {
    /// Keypoints, grouped by level (level 0 first).
    pub keypoints: Vec<KeyPoint>,
    /// `descriptors[i]` describes `keypoints[i]`.
    pub descriptors: Vec<Descriptor>,
}

impl OrbFeatures {
    /// Number of features.
    pub fn len(&self) -> usize {
        self.keypoints.len()
    }

    /// True when there is no feature.
    pub fn is_empty(&self) -> bool {
        self.keypoints.is_empty()
    }

    /// Removes every feature, keeping the allocations.
    pub fn clear(&mut self) {
        self.keypoints.clear();
        self.descriptors.clear();
    }
}
