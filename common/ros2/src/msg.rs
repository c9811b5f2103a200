//! ROS 2 message types as plain serde structs, fields in the order of their `.msg` files,
//! so that CDR (de)serialisation of a struct is the wire format ROS 2 nodes use.
//! `uint8[]` is `serde_bytes` (one length prefix, then the bytes); fixed arrays longer
//! than 32 go through [`fixed`].

use gfs_core::stamp::Stamp;
use serde::{Deserialize, Serialize};

/// `builtin_interfaces/Time`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Time {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds within the second, 0..1e9.
    pub nanosec: u32,
}

impl Time {
    /// Nanoseconds after the epoch (exact, for ordering and MCAP log times).
    pub fn nanos(&self) -> i64 {
        i64::from(self.sec) * 1_000_000_000 + i64::from(self.nanosec)
    }
}

impl From<Stamp> for Time {
    fn from(stamp: Stamp) -> Self {
        let (sec, nanosec) = stamp.sec_nanosec();
        Self { sec, nanosec }
    }
}

/// The stamp of `sec` and `nanosec`, exact (a `nanosec` of 1e9 or more carries into
/// the seconds).
impl From<Time> for Stamp {
    fn from(time: Time) -> Self {
        Stamp::from_nanos(time.nanos())
    }
}

impl Time {
    /// The stamp, exact; `None` when `nanosec` is not below 1e9.
    pub fn stamp(&self) -> Option<Stamp> {
        Stamp::from_sec_nanosec(self.sec, self.nanosec)
    }
}

/// `std_msgs/Header`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// Capture time.
    pub stamp: Time,
    /// Frame of the data.
    pub frame_id: String,
}

/// `sensor_msgs/Image`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Image {
    /// Stamp and optical frame.
    pub header: Header,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// `rgb8`, `16UC1`, ... (sensor_msgs/image_encodings).
    pub encoding: String,
    /// 1 when the data is big endian.
    pub is_bigendian: u8,
    /// Bytes per row.
    pub step: u32,
    /// `step * height` bytes.
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
}

/// `sensor_msgs/CompressedImage`, as `image_transport`'s `compressed` and
/// `compressedDepth` plugins send it.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CompressedImage {
    /// Stamp and optical frame.
    pub header: Header,
    /// `jpeg`, `png`, or `<encoding>; <codec> compressed <encoding>` (colour),
    /// `<encoding>; compressedDepth png` (depth).
    pub format: String,
    /// The compressed bytes (compressedDepth: a 12-byte header first).
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
}

/// `sensor_msgs/RegionOfInterest`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RegionOfInterest {
    /// Left column.
    pub x_offset: u32,
    /// Top row.
    pub y_offset: u32,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// Rectify the region.
    pub do_rectify: bool,
}

/// `sensor_msgs/CameraInfo`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CameraInfo {
    /// Stamp and optical frame.
    pub header: Header,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// `plumb_bob`, `rational_polynomial`, `equidistant`.
    pub distortion_model: String,
    /// Distortion coefficients (plumb_bob: k1 k2 p1 p2 k3).
    pub d: Vec<f64>,
    /// Intrinsics, row-major 3x3.
    pub k: [f64; 9],
    /// Rectification, row-major 3x3.
    pub r: [f64; 9],
    /// Projection, row-major 3x4.
    pub p: [f64; 12],
    /// Horizontal binning.
    pub binning_x: u32,
    /// Vertical binning.
    pub binning_y: u32,
    /// Region of interest.
    pub roi: RegionOfInterest,
}

/// `geometry_msgs/Point` (also the layout of `Vector3`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

/// `geometry_msgs/Quaternion`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

impl Default for Quaternion {
    fn default() -> Self {
        Self {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 1.0,
        }
    }
}

/// `geometry_msgs/Pose`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Position (`geometry_msgs/Point`).
    pub position: Vector3,
    /// Orientation.
    pub orientation: Quaternion,
}

/// `geometry_msgs/PoseWithCovariance`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovariance {
    /// Pose.
    pub pose: Pose,
    /// Row-major 6x6 over (x, y, z, rotation about x, y, z).
    #[serde(with = "fixed")]
    pub covariance: [f64; 36],
}

/// `geometry_msgs/Twist`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Twist {
    /// m/s.
    pub linear: Vector3,
    /// rad/s.
    pub angular: Vector3,
}

/// `geometry_msgs/TwistWithCovariance`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TwistWithCovariance {
    /// Twist.
    pub twist: Twist,
    /// Row-major 6x6 over (vx, vy, vz, wx, wy, wz).
    #[serde(with = "fixed")]
    pub covariance: [f64; 36],
}

/// `nav_msgs/Odometry`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Odometry {
    /// Stamp of the image, frame `odom`.
    pub header: Header,
    /// The body frame the pose is of.
    pub child_frame_id: String,
    /// Pose of the child frame in `header.frame_id`.
    pub pose: PoseWithCovariance,
    /// Velocity in the child frame.
    pub twist: TwistWithCovariance,
}

/// `geometry_msgs/Transform`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Transform {
    /// Translation.
    pub translation: Vector3,
    /// Rotation.
    pub rotation: Quaternion,
}

/// `geometry_msgs/TransformStamped`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TransformStamped {
    /// Stamp and parent frame.
    pub header: Header,
    /// Child frame.
    pub child_frame_id: String,
    /// Child in parent.
    pub transform: Transform,
}

/// `tf2_msgs/TFMessage`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TfMessage {
    /// Transforms.
    pub transforms: Vec<TransformStamped>,
}

/// `sensor_msgs/Imu`. Per REP 145, element 0 of a covariance is -1 when the message
/// has no such estimate (an IMU without orientation), and all zero when unknown.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Imu {
    /// Sample stamp and the IMU's frame.
    pub header: Header,
    /// Orientation estimate (none from a camera's IMU).
    pub orientation: Quaternion,
    /// Row-major 3x3.
    pub orientation_covariance: [f64; 9],
    /// rad/s.
    pub angular_velocity: Vector3,
    /// Row-major 3x3, (rad/s)^2.
    pub angular_velocity_covariance: [f64; 9],
    /// Specific force, m/s^2.
    pub linear_acceleration: Vector3,
    /// Row-major 3x3, (m/s^2)^2.
    pub linear_acceleration_covariance: [f64; 9],
}

/// `std_msgs/String`: the tracking status (`tracked`, `degraded`, `predicted`,
/// `relocalised`, `lost`) of each frame, what `ros2 topic echo` shows plainly.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct StringMsg {
    /// The text.
    pub data: String,
}

/// Serde for fixed arrays longer than serde's 32: a tuple of `N` elements (CDR writes
/// no length for a fixed array).
pub mod fixed {
    use serde::de::{Error, SeqAccess, Visitor};
    use serde::ser::SerializeTuple;
    use serde::{Deserializer, Serializer};

    /// Serialises the array as a tuple.
    ///
    /// # Errors
    /// The serialiser's.
    pub fn serialize<S: Serializer, const N: usize>(
        value: &[f64; N],
        serializer: S,
    ) -> Result<S::Ok, S::Error> {
        let mut tuple = serializer.serialize_tuple(N)?;
        for v in value {
            tuple.serialize_element(v)?;
        }
        tuple.end()
    }

    /// Deserialises a tuple of `N` floats.
    ///
    /// # Errors
    /// The deserialiser's, or too few elements.
    pub fn deserialize<'de, D: Deserializer<'de>, const N: usize>(
        deserializer: D,
    ) -> Result<[f64; N], D::Error> {
        struct ArrayVisitor<const N: usize>;
        impl<'de, const N: usize> Visitor<'de> for ArrayVisitor<N> {
            type Value = [f64; N];
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                write!(f, "{N} floats")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
                let mut out = [0.0; N];
                for (i, slot) in out.iter_mut().enumerate() {
                    *slot = seq
                        .next_element()?
                        .ok_or_else(|| A::Error::invalid_length(i, &self))?;
                }
                Ok(out)
            }
        }
        deserializer.deserialize_tuple(N, ArrayVisitor::<N>)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_time_is_its_stamp_exactly_both_ways() {
        let stamp: Stamp = "1305031229.123456789".parse().unwrap();
        let t = Time::from(stamp);
        assert_eq!((t.sec, t.nanosec), (1305031229, 123_456_789));
        assert_eq!((t.stamp(), Stamp::from(t)), (Some(stamp), stamp));
        let early = Time {
            sec: -2,
            nanosec: 500_000_000,
        };
        assert_eq!(early.nanos(), -1_500_000_000);
        assert_eq!(Time::from(Stamp::from(early)), early);
        let carried = Time {
            sec: 1,
            nanosec: 1_500_000_000,
        };
        assert_eq!(
            (carried.stamp(), Stamp::from(carried).nanos()),
            (None, 2_500_000_000)
        );
    }
}
