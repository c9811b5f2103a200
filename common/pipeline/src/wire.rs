//! The fixed-layout payloads of the per-frame topics: plain `#[repr(C)]` structs that
//! travel as slices in shared memory, read in place by the subscribers. Each has a
//! stable iceoryx2 type name that both ends agree on.

use gfs_core::ids::{FrameId, KeyFrameId};
use gfs_core::stamp::Stamp;
use gfs_ipc::ZeroCopySend;
use gfs_lines::{DetectedLine, Line3, Segment};
use gfs_odometry::{FrameAnchor, FramePose, TrackingStatus};
use gfs_planes::ManhattanAxes;
use gfs_points::{Descriptor, KeyPoint};
use nalgebra::{Isometry3, Matrix3, Matrix6, Quaternion, Rotation3, Translation3, UnitQuaternion};

mod imu;
mod tracked;
pub use imu::WireImuSample;
pub use tracked::WireTrackedFeature;

/// One ORB keypoint with its descriptor (`points` topic).
#[derive(Clone, Copy, Debug, Default, PartialEq, ZeroCopySend)]
#[type_name("gfsvo::WireKeyPoint")]
#[repr(C)]
pub struct WireKeyPoint {
    /// rBRIEF descriptor.
    pub descriptor: Descriptor,
    /// Column, undistorted pixels.
    pub u: f32,
    /// Row, undistorted pixels.
    pub v: f32,
    /// Pyramid level.
    pub level: u32,
    /// Orientation, radians.
    pub angle: f32,
    /// FAST score.
    pub response: f32,
    /// Depth, metres (0 = none).
    pub depth: f32,
}

impl WireKeyPoint {
    /// The wire form of a keypoint and its descriptor.
    pub fn new(kp: &KeyPoint, descriptor: &Descriptor) -> Self {
        Self {
            descriptor: *descriptor,
            u: kp.u,
            v: kp.v,
            level: kp.level,
            angle: kp.angle,
            response: kp.response,
            depth: kp.depth,
        }
    }

    /// The keypoint.
    pub fn keypoint(&self) -> KeyPoint {
        KeyPoint {
            u: self.u,
            v: self.v,
            level: self.level,
            angle: self.angle,
            response: self.response,
            depth: self.depth,
        }
    }
}

/// One homogenised line with its LBD descriptor and 3D line (`lines` topic).
#[derive(Clone, Copy, Debug, Default, PartialEq, ZeroCopySend)]
#[type_name("gfsvo::WireLine")]
#[repr(C)]
pub struct WireLine {
    /// LBD descriptor.
    pub descriptor: Descriptor,
    /// 2D start (u, v), pixels.
    pub start: [f32; 2],
    /// 2D end (u, v), pixels.
    pub end: [f32; 2],
    /// Mean gradient along the segment.
    pub mean_gradient: f32,
    /// 3D start, camera frame, metres.
    pub start3: [f32; 3],
    /// 3D end, camera frame, metres.
    pub end3: [f32; 3],
    /// 1 when the 3D line is valid.
    pub valid3: u32,
}

impl WireLine {
    /// The wire form of a line, its descriptor and its 3D line.
    pub fn new(line: &DetectedLine, descriptor: &Descriptor, line3: &Line3) -> Self {
        Self {
            descriptor: *descriptor,
            start: line.segment.start,
            end: line.segment.end,
            mean_gradient: line.mean_gradient,
            start3: line3.start,
            end3: line3.end,
            valid3: line3.valid,
        }
    }

    /// The 2D line.
    pub fn line(&self) -> DetectedLine {
        DetectedLine {
            segment: Segment {
                start: self.start,
                end: self.end,
            },
            mean_gradient: self.mean_gradient,
        }
    }

    /// The 3D line.
    pub fn line3(&self) -> Line3 {
        Line3 {
            start: self.start3,
            end: self.end3,
            valid: self.valid3,
        }
    }
}

/// The Manhattan axes of a frame (`manhattan` topic: a slice of one, or empty when the
/// frame showed no structure).
#[derive(Clone, Copy, Debug, Default, PartialEq, ZeroCopySend)]
#[type_name("gfsvo::WireManhattan")]
#[repr(C)]
pub struct WireManhattan {
    /// `camera_from_manhattan`, column-major.
    pub rotation: [f64; 9],
    /// 1 where axis `i` was observed.
    pub observed: [u32; 3],
    /// Vote support of each axis.
    pub support: [f32; 3],
    /// Confidence in [0, 1].
    pub confidence: f32,
    /// Explicit padding (the layout has no implicit holes).
    pub reserved: u32,
}

impl WireManhattan {
    /// The wire form of a frame's axes.
    pub fn new(axes: &ManhattanAxes) -> Self {
        let mut rotation = [0.0; 9];
        rotation.copy_from_slice(axes.rotation.matrix().as_slice());
        Self {
            rotation,
            observed: axes.observed.map(u32::from),
            support: axes.support,
            confidence: axes.confidence,
            reserved: 0,
        }
    }

    /// The axes, or `None` when the matrix is not a rotation (a corrupt message).
    pub fn axes(&self) -> Option<ManhattanAxes> {
        let m = Matrix3::from_column_slice(&self.rotation);
        let orthonormal = (m.transpose() * m - Matrix3::identity()).amax() < 1e-6;
        if !self.rotation.iter().all(|v| v.is_finite()) || !orthonormal || m.determinant() < 0.0 {
            return None;
        }
        Some(ManhattanAxes {
            // Taken as sent (bit for bit): re-orthonormalising would make the pipeline
            // differ from the in-process run in the last digits.
            rotation: Rotation3::from_matrix_unchecked(m),
            observed: self.observed.map(|o| o != 0),
            support: self.support,
            confidence: self.confidence,
        })
    }
}

/// The pose of a frame (`pose` topic: a slice of one).
#[derive(Clone, Copy, Debug, Default, PartialEq, ZeroCopySend)]
#[type_name("gfsvo::WirePose")]
#[repr(C)]
pub struct WirePose {
    /// Frame id.
    pub frame_id: u64,
    /// Capture stamp, integer nanoseconds since the epoch ([`Stamp::nanos`]).
    pub stamp_ns: i64,
    /// `world_from_camera` translation, metres.
    pub translation: [f64; 3],
    /// `world_from_camera` rotation as a unit quaternion (x, y, z, w).
    pub rotation: [f64; 4],
    /// The motion model's rotation `current_from_previous` (x, y, z, w), which the
    /// planes stage uses to keep the Manhattan axes' identity; all zero when unknown.
    pub predicted_rotation: [f64; 4],
    /// 0 tracked, 1 degraded, 2 predicted, 3 relocalised.
    pub status: u32,
    /// 1 when the frame became a keyframe.
    pub keyframe: u32,
    /// Upper triangle (row by row) of the pose's 6x6 covariance from its optimisation
    /// (camera-frame translation then rotation); all zero when unknown (predicted).
    pub covariance: [f64; 21],
    /// The loop corrections so far, `map_from_odom` (REP 105 `map -> odom`): translation
    /// x y z then quaternion x y z w; all zero for the identity (no loop closed). The
    /// pose above is the continuous `odom` pose.
    pub map_from_odom: [f64; 7],
    /// The frame's reference keyframe id plus one; 0 before the first keyframe. With
    /// `anchor_correction`, what the final trajectory needs to give the frame the loop
    /// corrections that keyframe receives later ([`FrameAnchor`]).
    pub anchor_keyframe: u64,
    /// The reference keyframe's loop correction when the frame was tracked, laid out
    /// as `map_from_odom` (all zero for the identity).
    pub anchor_correction: [f64; 7],
    /// The IMU samples the tracker took in before the frame.
    pub imu_samples: u32,
}

impl WirePose {
    /// The wire form of a pose.
    pub fn new(pose: &FramePose, predicted: Option<&UnitQuaternion<f64>>, keyframe: bool) -> Self {
        let t = pose.world_from_camera.translation.vector;
        let q = pose.world_from_camera.rotation.coords;
        let p = predicted.map_or([0.0; 4], |r| [r.i, r.j, r.k, r.w]);
        Self {
            frame_id: pose.id.0,
            stamp_ns: pose.timestamp.nanos(),
            translation: [t.x, t.y, t.z],
            rotation: [q.x, q.y, q.z, q.w],
            predicted_rotation: p,
            status: match pose.status {
                TrackingStatus::Tracked => 0,
                TrackingStatus::Degraded => 1,
                TrackingStatus::Predicted => 2,
                TrackingStatus::Relocalised => 3,
            },
            keyframe: u32::from(keyframe),
            covariance: [0.0; 21],
            map_from_odom: [0.0; 7],
            anchor_keyframe: 0,
            anchor_correction: [0.0; 7],
            imu_samples: 0,
        }
    }

    /// The same pose with the number of IMU samples taken in before it.
    pub fn with_imu_samples(mut self, samples: usize) -> Self {
        self.imu_samples = u32::try_from(samples).unwrap_or(u32::MAX);
        self
    }

    /// The same pose tied to its reference keyframe.
    pub fn with_anchor(mut self, anchor: Option<&FrameAnchor>) -> Self {
        if let Some(a) = anchor {
            self.anchor_keyframe = a.keyframe.0.saturating_add(1);
            self.anchor_correction = isometry_fields(&a.correction);
        }
        self
    }

    /// The frame's anchor, `None` before the first keyframe or when a field is not
    /// valid; `world_from_camera` is its map pose (`map_from_odom * pose`).
    pub fn anchor(&self, world_from_camera: Isometry3<f64>) -> Option<FrameAnchor> {
        let keyframe = KeyFrameId(self.anchor_keyframe.checked_sub(1)?);
        Some(FrameAnchor {
            keyframe,
            correction: isometry_from_fields(&self.anchor_correction)?,
            world_from_camera,
        })
    }

    /// The same pose with the tracker's loop corrections (`map_from_odom`).
    pub fn with_map_from_odom(mut self, map_from_odom: &Isometry3<f64>) -> Self {
        self.map_from_odom = isometry_fields(map_from_odom);
        self
    }

    /// `map_from_odom`: the identity when none was sent or the field is not valid.
    pub fn map_from_odom(&self) -> Isometry3<f64> {
        isometry_from_fields(&self.map_from_odom).unwrap_or_else(Isometry3::identity)
    }

    /// The same pose with the covariance of its optimisation.
    pub fn with_covariance(mut self, covariance: Option<&Matrix6<f64>>) -> Self {
        if let Some(c) = covariance {
            let upper = (0..6).flat_map(|r| (r..6).map(move |k| (r, k)));
            for (slot, (r, k)) in self.covariance.iter_mut().zip(upper) {
                *slot = c[(r, k)];
            }
        }
        self
    }

    /// The covariance, `None` when unknown or not finite.
    pub fn covariance(&self) -> Option<Matrix6<f64>> {
        if self.covariance.iter().all(|v| *v == 0.0)
            || !self.covariance.iter().all(|v| v.is_finite())
        {
            return None;
        }
        let mut c = Matrix6::zeros();
        let upper = (0..6).flat_map(|r| (r..6).map(move |k| (r, k)));
        for (&v, (r, k)) in self.covariance.iter().zip(upper) {
            c[(r, k)] = v;
            c[(k, r)] = v;
        }
        Some(c)
    }

    /// The pose, or `None` when a field is out of range (a corrupt message).
    pub fn pose(&self) -> Option<FramePose> {
        let status = match self.status {
            0 => TrackingStatus::Tracked,
            1 => TrackingStatus::Degraded,
            2 => TrackingStatus::Predicted,
            3 => TrackingStatus::Relocalised,
            _ => return None,
        };
        let rotation = unit_quaternion(&self.rotation)?;
        if !self.translation.iter().all(|v| v.is_finite()) {
            return None;
        }
        let [x, y, z] = self.translation;
        Some(FramePose {
            id: FrameId(self.frame_id),
            timestamp: Stamp::from_nanos(self.stamp_ns),
            world_from_camera: Isometry3::from_parts(Translation3::new(x, y, z), rotation),
            status,
        })
    }

    /// The predicted rotation, if the tracker knew one.
    pub fn predicted_rotation(&self) -> Option<Rotation3<f64>> {
        unit_quaternion(&self.predicted_rotation).map(|q| q.to_rotation_matrix())
    }
}

/// An isometry as x y z qx qy qz qw; all zero for the identity (a zeroed field reads as
/// no correction).
fn isometry_fields(m: &Isometry3<f64>) -> [f64; 7] {
    if *m == Isometry3::identity() {
        return [0.0; 7];
    }
    let t = m.translation.vector;
    let q = m.rotation.coords;
    [t.x, t.y, t.z, q.x, q.y, q.z, q.w]
}

/// The isometry of [`isometry_fields`]; `None` when a field is not finite or the
/// quaternion not of unit norm.
fn isometry_from_fields(fields: &[f64; 7]) -> Option<Isometry3<f64>> {
    if fields.iter().all(|v| *v == 0.0) {
        return Some(Isometry3::identity());
    }
    let [x, y, z, qx, qy, qz, qw] = *fields;
    let rotation = unit_quaternion(&[qx, qy, qz, qw])?;
    [x, y, z]
        .iter()
        .all(|v| v.is_finite())
        .then(|| Isometry3::from_parts(Translation3::new(x, y, z), rotation))
}

/// A unit quaternion from (x, y, z, w) when finite and of unit norm; taken as sent, bit
/// for bit, so that poses through the pipeline equal poses computed in-process.
fn unit_quaternion(c: &[f64; 4]) -> Option<UnitQuaternion<f64>> {
    let q = Quaternion::new(c[3], c[0], c[1], c[2]);
    ((q.norm() - 1.0).abs() < 1e-6).then(|| UnitQuaternion::new_unchecked(q))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn payloads_round_trip_bit_for_bit() {
        let kp = KeyPoint {
            u: 1.5,
            v: 2.5,
            level: 3,
            angle: 0.25,
            response: 40.0,
            depth: 1.25,
        };
        let d: Descriptor = [1, 2, 3, u64::MAX];
        let w = WireKeyPoint::new(&kp, &d);
        assert_eq!((w.keypoint(), w.descriptor), (kp, d));

        let line = DetectedLine {
            segment: Segment::new(1.0, 2.0, 30.0, 40.0),
            mean_gradient: 12.0,
        };
        let l3 = Line3 {
            start: [0.1, 0.2, 1.0],
            end: [0.3, 0.4, 1.5],
            valid: 1,
        };
        let w = WireLine::new(&line, &d, &l3);
        assert_eq!((w.line(), w.line3(), w.descriptor), (line, l3, d));

        let axes = ManhattanAxes {
            rotation: Rotation3::from_euler_angles(0.1, -0.2, 0.3),
            observed: [true, false, true],
            support: [0.5, 0.0, 0.25],
            confidence: 0.75,
        };
        assert_eq!(WireManhattan::new(&axes).axes(), Some(axes));

        let pose = FramePose {
            id: FrameId(7),
            timestamp: Stamp::from_nanos(12_500_000_001),
            world_from_camera: Isometry3::new(
                nalgebra::Vector3::new(1.0, -2.0, 0.5),
                nalgebra::Vector3::new(0.1, 0.2, -0.3),
            ),
            status: TrackingStatus::Relocalised,
        };
        let r = UnitQuaternion::from_euler_angles(0.01, 0.02, 0.03);
        let w = WirePose::new(&pose, Some(&r), true);
        assert_eq!(w.pose(), Some(pose));
        assert_eq!(w.predicted_rotation(), Some(r.to_rotation_matrix()));
        assert_eq!(WirePose::new(&pose, None, false).predicted_rotation(), None);
        assert_eq!(w.covariance(), None);
        // deploy/iceoryx2.toml documents the layout for other languages.
        assert_eq!(std::mem::size_of::<WirePose>(), 408);
        assert_eq!(std::mem::size_of::<WireImuSample>(), 56);
        assert_eq!(w.with_imu_samples(9).imu_samples, 9);
        assert_eq!(w.map_from_odom(), Isometry3::identity());
        let m = Isometry3::new(
            nalgebra::Vector3::new(0.02, 0.0, -0.01),
            nalgebra::Vector3::new(0.0, 0.01, 0.0),
        );
        let corrected = w.with_map_from_odom(&m).map_from_odom();
        assert!(
            (corrected.to_homogeneous() - m.to_homogeneous())
                .abs()
                .max()
                < 1e-12
        );
        assert_eq!(w.anchor(m), None, "no keyframe yet");
        let anchor = FrameAnchor {
            keyframe: KeyFrameId(0),
            correction: m,
            world_from_camera: pose.world_from_camera,
        };
        let anchored = w.with_anchor(Some(&anchor));
        assert_eq!(anchored.anchor(pose.world_from_camera), Some(anchor));
        let mut broken = anchored;
        broken.anchor_correction[6] = 3.0;
        assert_eq!(
            broken.anchor(pose.world_from_camera),
            None,
            "not a unit quaternion"
        );
        let c = Matrix6::from_fn(|r, k| 1.0 / (1.0 + r as f64 + k as f64));
        assert_eq!(w.with_covariance(Some(&c)).covariance(), Some(c));
        let mut bad = w.with_covariance(Some(&c));
        bad.covariance[3] = f64::NAN;
        assert_eq!(bad.covariance(), None);
    }

    #[test]
    fn corrupt_payloads_are_refused() {
        let mut w = WirePose {
            status: 9,
            ..WirePose::default()
        };
        assert!(w.pose().is_none());
        w.status = 0;
        assert!(w.pose().is_none(), "zero quaternion");
        w.rotation = [0.0, 0.0, 0.0, 1.0];
        w.translation[1] = f64::NAN;
        assert!(w.pose().is_none());
        let m = WireManhattan {
            rotation: [f64::INFINITY; 9],
            ..WireManhattan::default()
        };
        assert!(m.axes().is_none());
    }
}
