//! A map point: a 3D point in the world seen by one or more keyframes.

use super::KeyFrame;
use super::landmark::Described;
use crate::frontend::features::Descriptor;
use gfs_core::ids::KeyFrameId;
use nalgebra::{Point3, Vector3};

/// A landmark point with its observations and the statistics used to cull it.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct MapPoint {
    /// Position in the world, metres.
    pub position: Point3<f64>,
    /// Representative descriptor (the observation closest to all others).
    pub descriptor: Descriptor,
    /// Keyframes that see it, with the keypoint index in each.
    pub observations: Vec<(KeyFrameId, u32)>,
    /// Mean viewing direction (unit, world), from the point towards the cameras.
    pub normal: Vector3<f64>,
    /// Farthest distance at which the ORB pyramid can still detect it, metres.
    pub max_distance: f64,
    /// Closest such distance, metres.
    pub min_distance: f64,
    /// The keyframe that created it.
    pub first_kf: KeyFrameId,
    /// Frames in whose view it was predicted to be.
    pub visible: u32,
    /// Frames in which it was matched.
    pub found: u32,
}

impl MapPoint {
    /// The pyramid level at which a point at `distance` metres should be detected.
    pub fn predict_level(&self, distance: f64, log_scale: f64, levels: u8) -> u8 {
        if distance <= 0.0 || log_scale <= 0.0 {
            return 0;
        }
        let level = ((self.max_distance / distance).ln() / log_scale).ceil();
        level.clamp(0.0, f64::from(levels.saturating_sub(1))) as u8
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

impl Described for MapPoint {
    fn descriptor_mut(&mut self) -> &mut Descriptor {
        &mut self.descriptor
    }

    fn feature_descriptor(keyframe: &KeyFrame, index: usize) -> Option<Descriptor> {
        keyframe.features.point_descriptors.get(index).copied()
    }
}
