//! Errors of the planes stage.

use thiserror::Error;

/// A plane extractor could not be built or run.
#[derive(Debug, Error, PartialEq)]
pub enum PlaneError {
    /// A `[planes]` config field is out of range.
    #[error("planes.{field} = {value} is invalid: {reason}")]
    InvalidConfig {
        /// Field name in the `[planes]` table.
        field: &'static str,
        /// The value found.
        value: f64,
        /// What a valid value is.
        reason: &'static str,
    },
    /// The depth image is not the size of the camera it is back-projected with.
    #[error(
        "depth image is {depth_width}x{depth_height} but the camera is {camera_width}x{camera_height}"
    )]
    SizeMismatch {
        /// Depth image width, pixels.
        depth_width: usize,
        /// Depth image height, pixels.
        depth_height: usize,
        /// Camera width, pixels.
        camera_width: usize,
        /// Camera height, pixels.
        camera_height: usize,
    },
}
