//! The `Frame` message: gray (u8), depth (f32, metres) and optionally RGB images of one
//! frame in a single `[u8]` payload, read in place by every stage.
//!
//! Fixed layout (native endian, all header fields `u64`):
//!
//! ```text
//! byte 0    magic  FRAME_MAGIC
//! byte 8    gray  plane header: format, width, height, stride (elements), offset (bytes)
//! byte 48   depth plane header
//! byte 88   rgb   plane header (format 0 = absent)
//! byte 128  planes, each starting at a multiple of 64 bytes (cache line)
//! ```
//!
//! A plane of `height` rows needs `stride * (height - 1) + width` elements from its offset.
//! [`FrameView::parse`] checks every field against the payload length and alignment and
//! returns a [`FrameError`] for a malformed sample; it never panics and never copies.

mod error;
mod layout;
mod read;
mod write;

#[cfg(test)]
mod tests;

pub use error::FrameError;
pub use layout::{FRAME_HEADER_BYTES, FRAME_MAGIC, FrameLayout, PixelFormat, PlaneHeader};
pub use read::FrameView;
pub use write::{FrameImages, FrameViewMut};
