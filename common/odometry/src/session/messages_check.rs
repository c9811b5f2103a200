//! Internal consistency of every message the odometry receives from another process
//! (features, keyframe requests, maps): parallel vectors of equal length, ids that
//! point inside their vectors or map, finite numbers. Checked after decoding and before
//! use, so a well-formed but inconsistent message is dropped with a warning instead of
//! indexing out of bounds or poisoning the map with NaN.

use crate::frontend::features::FrameFeatures;
use crate::session::{KeyFrameRequest, MapRequest, MapUpdate, RelocalisationRequest};
use crate::tracking::tracker::TrackedFrame;
use gfs_core::ids::FrameId;
use nalgebra::Isometry3;

/// Keypoints come from a pyramid of at most this many levels.
const MAX_LEVELS: u32 = 32;

/// What is inconsistent in a message.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("frame {frame}: {what}")]
pub struct MessageError {
    /// The frame the message is about.
    pub frame: FrameId,
    /// What is wrong, naming the field.
    pub what: String,
}

fn finite(values: &[f64]) -> bool {
    values.iter().all(|v| v.is_finite())
}

fn finite_pose(pose: &Isometry3<f64>) -> bool {
    finite(pose.translation.vector.as_slice()) && finite(pose.rotation.coords.as_slice())
}

impl FrameFeatures {
    /// Checks the vector lengths ([`FrameFeatures::validate`]) and that every number
    /// is finite and every keypoint level plausible.
    ///
    /// # Errors
    /// [`MessageError`] naming the first field that is wrong.
    pub fn check(&self) -> Result<(), MessageError> {
        let fail = |what: String| {
            Err(MessageError {
                frame: self.id,
                what,
            })
        };
        if let Err(e) = self.validate() {
            return fail(format!(
                "{} has {} entries, expected {}",
                e.what, e.got, e.want
            ));
        }
        for (i, k) in self.keypoints.iter().enumerate() {
            let numbers = [k.u, k.v, k.angle, k.response, k.depth].map(f64::from);
            if !finite(&numbers) || k.depth < 0.0 || k.level >= MAX_LEVELS {
                return fail(format!("keypoints[{i}] is not a keypoint: {k:?}"));
            }
        }
        for (i, l) in self.lines.iter().enumerate() {
            let s = &l.segment;
            let numbers = [s.start[0], s.start[1], s.end[0], s.end[1], l.mean_gradient];
            if !finite(&numbers.map(f64::from)) {
                return fail(format!("lines[{i}] has a non-finite coordinate"));
            }
        }
        for (i, l) in self.lines3d.iter().enumerate() {
            let finite_ends = l.start.iter().chain(&l.end).all(|v| v.is_finite());
            if l.valid != 0 && !finite_ends {
                return fail(format!("lines3d[{i}] is valid with a non-finite end"));
            }
        }
        if let Some(m) = &self.manhattan
            && !finite(m.rotation.matrix().as_slice())
        {
            return fail("manhattan rotation is not finite".to_owned());
        }
        Ok(())
    }
}

impl TrackedFrame {
    /// Checks the features, one landmark link per keypoint and per line, and the pose.
    ///
    /// # Errors
    /// [`MessageError`] naming the first field that is wrong.
    pub fn check(&self) -> Result<(), MessageError> {
        self.features.check()?;
        let fail = |what: String| {
            Err(MessageError {
                frame: self.features.id,
                what,
            })
        };
        let (points, lines) = (self.features.keypoints.len(), self.features.lines.len());
        if self.point_ids.len() != points {
            return fail(format!(
                "point_ids has {} entries, expected {points} (one per keypoint)",
                self.point_ids.len()
            ));
        }
        if self.line_ids.len() != lines {
            return fail(format!(
                "line_ids has {} entries, expected {lines} (one per line)",
                self.line_ids.len()
            ));
        }
        let planes = self.features.planes.len();
        if self.plane_ids.len() != planes {
            return fail(format!(
                "plane_ids has {} entries, expected {planes} (one per plane)",
                self.plane_ids.len()
            ));
        }
        if let Some(i) = self.features.planes.iter().position(|p| {
            let n = nalgebra::Vector3::from(p.normal.map(f64::from));
            !(p.offset.is_finite() && (n.norm() - 1.0).abs() < 1e-3)
        }) {
            return fail(format!(
                "planes[{i}] has no unit normal or a non-finite offset"
            ));
        }
        if !finite_pose(&self.camera_from_world) {
            return fail("camera_from_world is not finite".to_owned());
        }
        Ok(())
    }
}

impl KeyFrameRequest {
    /// Checks the request number, the frame and the Manhattan axes.
    ///
    /// # Errors
    /// [`MessageError`] naming the first field that is wrong.
    pub fn check(&self) -> Result<(), MessageError> {
        let frame = self.frame.features.id;
        let fail = |what: String| Err(MessageError { frame, what });
        if self.seq == 0 {
            return fail("keyframe request seq 0 (requests count from 1)".to_owned());
        }
        self.frame.check()?;
        if let Some(axes) = self.manhattan.axes()
            && !finite(axes.matrix().as_slice())
        {
            return fail("manhattan axes are not finite".to_owned());
        }
        if let Some(against) = &self.tracked_against
            && !finite_pose(&against.reference_correction)
        {
            return fail("reference_correction is not finite".to_owned());
        }
        Ok(())
    }
}

impl RelocalisationRequest {
    /// Checks the request number and the frame's features.
    ///
    /// # Errors
    /// [`MessageError`] naming the first field that is wrong.
    pub fn check(&self) -> Result<(), MessageError> {
        if self.seq == 0 {
            return Err(MessageError {
                frame: self.features.id,
                what: "relocalisation request seq 0 (requests count from 1)".to_owned(),
            });
        }
        self.features.check()
    }
}

impl MapRequest {
    /// Checks the request it holds.
    ///
    /// # Errors
    /// [`MessageError`] naming the first field that is wrong.
    pub fn check(&self) -> Result<(), MessageError> {
        match self {
            Self::KeyFrame(r) => r.check(),
            Self::Relocalise(r) => r.check(),
        }
    }
}

impl MapUpdate {
    /// Checks that the keyframe it names is in its map and its axes are finite.
    ///
    /// # Errors
    /// [`MessageError`] (about frame 0: a map is about no frame) naming the field.
    pub fn check(&self) -> Result<(), MessageError> {
        let fail = |what: String| {
            Err(MessageError {
                frame: FrameId(0),
                what: format!("map {}: {what}", self.seq),
            })
        };
        if let Some(kf) = self.keyframe
            && self.map.keyframe(kf).is_none()
        {
            return fail(format!("keyframe {kf:?} is not in the map"));
        }
        if let Some(found) = &self.relocalised {
            if self.map.keyframe(found.keyframe).is_none() {
                return fail(format!(
                    "relocalised.keyframe {:?} is not in the map",
                    found.keyframe
                ));
            }
            if !finite_pose(&found.camera_from_world) {
                return fail("relocalised.camera_from_world is not finite".to_owned());
            }
        }
        if let Some(axes) = self.manhattan.axes()
            && !finite(axes.matrix().as_slice())
        {
            return fail("manhattan axes are not finite".to_owned());
        }
        Ok(())
    }
}
