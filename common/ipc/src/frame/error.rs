//! What can be wrong with a frame payload or the images to publish.

use gfs_core::ImageError;
use thiserror::Error;

/// A frame payload is malformed or cannot be laid out.
#[derive(Debug, Error, PartialEq, Eq)]
pub enum FrameError {
    /// The payload is shorter than the header or than a plane needs.
    #[error("frame payload of {got} bytes is truncated: {what} needs {need}")]
    Truncated {
        /// Payload length.
        got: usize,
        /// Bytes needed.
        need: usize,
        /// What needed them ("header", "gray plane", ...).
        what: &'static str,
    },
    /// The first 8 bytes are not [`FRAME_MAGIC`](super::FRAME_MAGIC).
    #[error("frame payload has magic {found:#018x}, not a frame (or another layout version)")]
    BadMagic {
        /// The value found.
        found: u64,
    },
    /// A plane header holds the wrong format code or an impossible value.
    #[error("frame {plane} plane header is invalid: {reason}")]
    BadPlane {
        /// Which plane.
        plane: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// A plane's bytes are not aligned for its pixel type.
    #[error("frame {plane} plane at byte offset {offset} is misaligned for its pixel type")]
    Misaligned {
        /// Which plane.
        plane: &'static str,
        /// Byte offset in the payload.
        offset: usize,
    },
    /// The images to publish do not share one size.
    #[error("frame images differ in size: gray {gray:?}, depth {depth:?}, rgb {rgb:?}")]
    SizeMismatch {
        /// Gray (width, height).
        gray: (usize, usize),
        /// Depth (width, height).
        depth: (usize, usize),
        /// RGB (width, height), if any.
        rgb: Option<(usize, usize)>,
    },
    /// A view over a plane could not be made.
    #[error("frame {plane} plane: {source}")]
    Image {
        /// Which plane.
        plane: &'static str,
        /// The view error.
        #[source]
        source: ImageError,
    },
}
