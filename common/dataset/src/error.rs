//! What can go wrong while reading a dataset folder, and where.

use std::path::PathBuf;
use thiserror::Error;

/// A dataset folder, list file or image could not be read. Every variant names the file
/// (and the line of the list file when there is one), so that a user can fix the input.
#[derive(Debug, Error)]
pub enum DatasetError {
    /// A list file (`rgb.txt`, `depth.txt`) that the folder needs is not there.
    #[error("{path}: missing (a TUM RGB-D folder needs rgb.txt and depth.txt, or associations.txt)", path = path.display())]
    MissingList {
        /// The file that is missing.
        path: PathBuf,
    },
    /// A file exists but could not be read.
    #[error("{path}: cannot read: {source}", path = path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A line of a list file is not `timestamp path` (or `t_rgb rgb t_depth depth`).
    #[error("{path}:{line}: {reason}: {text:?}", path = path.display())]
    MalformedLine {
        /// The list file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        reason: &'static str,
        /// The line as read.
        text: String,
    },
    /// A timestamp is smaller than or equal to the one of the line before.
    #[error("{path}:{line}: timestamp {timestamp} does not increase (previous {previous})", path = path.display())]
    TimestampNotIncreasing {
        /// The list file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// The timestamp of this line.
        timestamp: gfs_core::stamp::Stamp,
        /// The timestamp of the previous frame.
        previous: gfs_core::stamp::Stamp,
    },
    /// The folder holds no frame: empty lists, or no colour image with a depth image within
    /// the association window.
    #[error("{dir}: no frames ({reason})", dir = dir.display())]
    NoFrames {
        /// The dataset folder.
        dir: PathBuf,
        /// Why there is none.
        reason: String,
    },
    /// An image named by a list file does not exist.
    #[error("{path}: missing image (named at {list}:{line})", path = path.display(), list = list.display())]
    MissingImage {
        /// The image file.
        path: PathBuf,
        /// The list file that names it.
        list: PathBuf,
        /// 1-based line of the list file.
        line: usize,
    },
    /// An image could not be decoded (corrupt file, unsupported format).
    #[error("{path}: cannot decode: {message}", path = path.display())]
    Decode {
        /// The image file.
        path: PathBuf,
        /// The decoder's message.
        message: String,
    },
    /// A depth image is not 16-bit single-channel.
    #[error("{path}: depth must be a 16-bit single-channel PNG, found {found}", path = path.display())]
    DepthNot16Bit {
        /// The image file.
        path: PathBuf,
        /// The pixel format found.
        found: String,
    },
    /// A colour image is not 8-bit gray, RGB or RGBA.
    #[error("{path}: colour must be 8-bit RGB, RGBA or gray, found {found}", path = path.display())]
    ColourFormat {
        /// The image file.
        path: PathBuf,
        /// The pixel format found.
        found: String,
    },
    /// An image does not have the calibrated camera size (colour and depth then differ too).
    #[error("{path}: image is {}x{} but the camera (and the other image of the frame) is {}x{}", got.0, got.1, expected.0, expected.1, path = path.display())]
    SizeMismatch {
        /// The image file.
        path: PathBuf,
        /// Its (width, height).
        got: (usize, usize),
        /// The camera's (width, height).
        expected: (usize, usize),
    },
    /// A frame index past the end of the sequence.
    #[error("frame {index} does not exist: the sequence has {len} frames")]
    IndexOutOfRange {
        /// The index asked for.
        index: usize,
        /// Frames in the sequence.
        len: usize,
    },
    /// The frame reader thread stopped without reporting an error (it panicked).
    #[error("the frame reader thread stopped unexpectedly before frame {index}")]
    ReaderStopped {
        /// The frame that was expected next.
        index: usize,
    },
}
