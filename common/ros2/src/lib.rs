//! ROS 2 for GFS-VO without ROS and without DDS: what the ROS 2 stage (`gfsvo-ros2`),
//! `gfsvo run BAG`, `gfsvo run --mcap` and `gfsvo convert` share.
//!
//! **Why a crate of its own.** The messages, their CDR encoding and the conversions to
//! and from the pipeline's frames and poses are plain data and arithmetic, testable
//! without a network; the DDS participant (`ros2-client` / `rustdds`, heavy to build)
//! lives only in `services/ros2`, and MCAP only behind the `bag` feature.
//!
//! **Model.**
//! - [`msg`]: `sensor_msgs/Image`, `CameraInfo`, `nav_msgs/Odometry`, `tf2_msgs/TFMessage`,
//!   `std_msgs/String` (the status) and their parts, as serde structs in `.msg` order.
//! - [`cdr`]: payloads with the 4-byte encapsulation header as bags store them.
//! - [`image::FrameConverter`]: a colour + depth pair into gray and metres (REP 118),
//!   undistorted like the dataset reader; [`camera_info`]: CameraInfo <-> camera.
//! - [`pairing::Pairer`]: approximate-time pairing of colour and depth within a slop.
//! - [`odom::OdometryPublisherState`]: camera poses and their covariance as `/odom`,
//!   `/tf` (REP 105 `odom -> base_link` through the camera-in-base extrinsic), status.
//! - [`diagnostics::DiagnosticsWindow`]: `/diagnostics` over the last second (rates,
//!   latency, share tracked, restarts), on the wall clock live or the camera's in bags.
//! - [`visualisation::Visualiser`]: the map points, lines, planes, keyframes and path
//!   as PointCloud2 / MarkerArray / Path (`/gfsvo/*`).
//! - [`transport`]: images as `image_transport` sends them, raw or compressed (jpeg,
//!   png, compressedDepth png), decoded in the source stage.
//! - [`bag`] (feature `bag`): ROS 2 bags in MCAP (zstd / lz4 chunks), read as frames
//!   with every length checked, and written under a temporary name.
//! - [`config::Ros2Config`]: the `[ros2]` table of a config.
#![warn(missing_docs)]

#[cfg(feature = "bag")]
pub mod bag;
#[cfg(feature = "bag")]
mod bag_records;
#[cfg(feature = "bag")]
mod bag_writer;
pub mod camera_info;
pub mod cdr;
pub mod config;
pub mod diagnostics;
pub mod image;
pub mod imu;
pub mod msg;
pub mod odom;
pub mod pairing;
pub mod schema;
pub mod transport;
pub mod visualisation;

pub use config::{Ros2Config, Transport, WhenLost};
