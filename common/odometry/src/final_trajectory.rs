//! The final best estimate of every frame, kept beside the live odometry: each frame is
//! tied to its reference keyframe ([`FrameAnchor`]) when it is tracked, and at the end
//! it gets the loop corrections that keyframe received after it.

use crate::odometry::{FrameAnchor, Odometry};
use crate::session::FramePose;
use nalgebra::Isometry3;

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

    /// Records the frame `odometry` just processed, published as `pose`.
    pub fn record(&mut self, odometry: &Odometry, pose: &FramePose) {
        self.anchors.push(match odometry.anchor(pose) {
            Some(anchor) => Anchor::KeyFrame(anchor),
            None => Anchor::Map(odometry.map_from_odom() * pose.world_from_camera),
        });
    }

    /// The final poses of the recorded frames, `published` being their live poses in the
    /// same order (extra ones on either side are left out).
    pub fn finish(&self, odometry: &Odometry, published: &[FramePose]) -> Vec<FramePose> {
        published
            .iter()
            .zip(&self.anchors)
            .map(|(pose, anchor)| FramePose {
                world_from_camera: match anchor {
                    Anchor::KeyFrame(a) => odometry.final_pose(a),
                    Anchor::Map(p) => *p,
                },
                ..*pose
            })
            .collect()
    }
}
