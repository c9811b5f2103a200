//! The camera: ideal pinhole intrinsics ([`PinholeCamera`]), the lens models ROS 2
//! drivers publish ([`Distortion`]: plumb_bob, rational_polynomial, equidistant) with
//! point undistortion, and a precomputed lookup table that undistorts whole images
//! ([`UndistortMap`]).
//!
//! After the `source` stage has applied the [`UndistortMap`], every later stage sees an
//! ideal pinhole image with the same intrinsics ([`Camera::pinhole`]).

mod calibration;
mod distortion;
mod pinhole;
mod undistort_map;

pub use calibration::{Camera, CameraConfig, CameraConfigError};
pub use distortion::{Distortion, DistortionModel};
pub use pinhole::PinholeCamera;
pub use undistort_map::{RemapError, UndistortMap};
