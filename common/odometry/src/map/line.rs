//! A map line: a 3D segment in the world seen by one or more keyframes.

use super::KeyFrame;
use super::landmark::Described;
use crate::frontend::features::Descriptor;
use gfs_core::ids::KeyFrameId;
use nalgebra::{Point3, Vector3};

/// A landmark segment with its observations and its Manhattan axis.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct MapLine {
    /// First endpoint in the world, metres.
    pub start: Point3<f64>,
    /// Second endpoint in the world, metres.
    pub end: Point3<f64>,
    /// The endpoints as the creating keyframe's depth measured them, world frame; the
    /// local BA holds the line near them (see `gfs_optim::BaLinePrior`).
    pub measured: [Point3<f64>; 2],
    /// Depth of each measured endpoint in the creating keyframe, metres.
    pub measured_depth: [f64; 2],
    /// Representative LBD descriptor.
    pub descriptor: Descriptor,
    /// Keyframes that see it, with the line index in each.
    pub observations: Vec<(KeyFrameId, u32)>,
    /// The world Manhattan axis (0, 1, 2) it is parallel to, if any.
    pub axis: Option<u8>,
    /// The keyframe that created it.
    pub first_kf: KeyFrameId,
    /// Frames in whose view it was predicted to be.
    pub visible: u32,
    /// Frames in which it was matched.
    pub found: u32,
}

impl MapLine {
    /// Unit direction from `start` to `end` (zero for a degenerate line).
    pub fn direction(&self) -> Vector3<f64> {
        (self.end - self.start)
            .try_normalize(1e-12)
            .unwrap_or_else(Vector3::zeros)
    }

    /// Midpoint, world.
    pub fn midpoint(&self) -> Point3<f64> {
        nalgebra::center(&self.start, &self.end)
    }

    /// Fraction of the frames that should have seen it in which it was matched.
    pub fn found_ratio(&self) -> f64 {
        if self.visible == 0 {
            1.0
        } else {
            f64::from(self.found) / f64::from(self.visible)
        }
    }
}

impl Described for MapLine {
    fn descriptor_mut(&mut self) -> &mut Descriptor {
        &mut self.descriptor
    }

    fn feature_descriptor(keyframe: &KeyFrame, index: usize) -> Option<Descriptor> {
        keyframe.features.line_descriptors.get(index).copied()
    }
}
