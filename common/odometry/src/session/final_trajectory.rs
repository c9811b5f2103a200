//! The final best estimate of every frame, kept beside the live odometry: each frame is
//! tied to its reference keyframe ([`FrameAnchor`]) when it is tracked, and at the end
//! it gets the loop corrections that keyframe received after it.

use crate::map::Map;
use crate::session::FramePose;
use gfs_core::ids::KeyFrameId;
use nalgebra::Isometry3;

/// A frame tied to its reference keyframe, so that the loops closed after it was
/// tracked correct it as they correct that keyframe.
///
/// ORB-SLAM2 saves `T_w_kf(final) * T_kf_c`; that also carries the local-BA refinement
/// of the keyframe made after the frame was tracked, which measured worse on TUM
/// fr1_rpy (ATE 0.0122 against 0.0117 m live) with 7-Scenes the same (0.0214 against
/// 0.0215 m). Here only the loop corrections are carried: with no loop the final pose
/// is the live one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameAnchor {
    /// The reference keyframe.
    pub keyframe: KeyFrameId,
    /// Its loop correction when the frame was tracked.
    pub correction: Isometry3<f64>,
    /// The frame's map pose (`world_from_camera`) when it was tracked.
    pub world_from_camera: Isometry3<f64>,
}

impl FrameAnchor {
    /// The frame's best `world_from_camera` in `map` (the mapper's, which holds every
    /// keyframe, retired ones included): its map pose with the loop corrections its
    /// keyframe received since it was tracked.
    pub fn final_pose(&self, map: &Map) -> Isometry3<f64> {
        match map.keyframe_correction(self.keyframe) {
            Some(now) if now != self.correction => {
                now * self.correction.inverse() * self.world_from_camera
            }
            _ => self.world_from_camera,
        }
    }
}

/// What a frame's final pose is taken from.
#[derive(Clone, Copy, Debug)]
enum Anchor {
    /// Its reference keyframe.
    KeyFrame(FrameAnchor),
    /// No keyframe yet: its map pose when it was tracked.
    Map(Isometry3<f64>),
}

/// The frames' anchors, in processing order.
#[derive(Debug, Default)]
pub struct FinalTrajectory {
    anchors: Vec<Anchor>,
}

impl FinalTrajectory {
    /// An empty trajectory with room for `frames` frames.
    pub fn with_capacity(frames: usize) -> Self {
        Self {
            anchors: Vec::with_capacity(frames),
        }
    }

    /// Records the next frame: its anchor, or (before the first keyframe) its map pose.
    pub fn record(&mut self, anchor: Option<FrameAnchor>, map_pose: Isometry3<f64>) {
        self.anchors.push(match anchor {
            Some(anchor) => Anchor::KeyFrame(anchor),
            None => Anchor::Map(map_pose),
        });
    }

    /// The final poses of the recorded frames in `map`, `published` being their live
    /// poses in the same order (extra ones on either side are left out).
    pub fn finish(&self, map: &Map, published: &[FramePose]) -> Vec<FramePose> {
        published
            .iter()
            .zip(&self.anchors)
            .map(|(pose, anchor)| FramePose {
                world_from_camera: match anchor {
                    Anchor::KeyFrame(a) => a.final_pose(map),
                    Anchor::Map(p) => *p,
                },
                ..*pose
            })
            .collect()
    }
}
