//! Shared foundations of GFS-VO.
//!
//! Every algorithm crate stands on these few types:
//!
//! - [`Image`] / [`ImageView`]: a size plus a contiguous row-major buffer. Algorithms take
//!   views so that they read memory they do not own (a decoded file, or a shared-memory
//!   sample in the pipeline) without copying it.
//! - [`camera`]: the pinhole model with the lens models of ROS 2 drivers (plumb_bob,
//!   rational_polynomial, equidistant), point undistortion and a precomputed
//!   [`camera::UndistortMap`] for whole images.
//! - [`se3`]: the Lie-group helpers (exp / log / skew) with the one perturbation
//!   convention used by every optimiser of the project.
//! - [`align`]: least-squares rigid alignment of 3D point pairs (Kabsch).
//! - [`ids`]: typed ids, so that a frame id never indexes a map point.
//! - [`descriptor`]: 256-bit binary descriptors and their Hamming distance.
//! - [`rng`]: a deterministic PRNG (SplitMix64) for sampling and fixtures.
//! - [`stamp::Stamp`]: capture stamps as integer nanoseconds, exact from source to outputs.
//! - [`scene`]: a map as a viewer draws it (points, segments, plane patches, keyframes).
//!
//! Conventions (see DESIGN.md): poses are `T_wc` (`world_from_camera`,
//! `nalgebra::Isometry3<f64>`), camera optical frame x right, y down, z forward;
//! pixels are (u, v) = (column, row) with pixel centres at integer coordinates;
//! depth is metres as `f32`, 0.0 = missing.
//!
//! ```
//! use gfs_core::{camera::PinholeCamera, Image};
//! let cam = PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480);
//! let p = cam.back_project(100.0, 50.0, 2.0);
//! let uv = cam.project(&p).expect("in front of the camera");
//! assert!((uv.x - 100.0).abs() < 1e-9 && (uv.y - 50.0).abs() < 1e-9);
//! let depth: Image<f32> = Image::new(640, 480);
//! assert_eq!(depth.view().get(3, 4), Some(0.0));
//! ```
#![warn(missing_docs)]

pub mod align;
pub mod camera;
pub mod descriptor;
pub mod fields;
pub mod ids;
mod image;
pub mod le_bytes;
pub mod rng;
pub mod scene;
pub mod se3;
pub mod stamp;
pub mod throttle;

pub use image::{DepthImage, GrayImage, Image, ImageError, ImageView, RgbImage};
