//! Errors of writing sequences to disk.

use std::path::PathBuf;
use thiserror::Error;

/// A synthetic sequence could not be written.
#[derive(Debug, Error)]
pub enum SynthError {
    /// A file or folder could not be created or written.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A PNG could not be encoded or written.
    #[error("cannot write image {path}: {source}")]
    Encode {
        /// The image file.
        path: PathBuf,
        /// The encoder error.
        source: image::ImageError,
    },
    /// Neither `XDG_CACHE_HOME` nor `HOME` names a folder for the sequence cache.
    #[error("no cache folder: set XDG_CACHE_HOME or HOME")]
    NoCacheDir,
    /// The PNG writer thread ended before all frames were written (it panicked).
    #[error("the image writer thread stopped after {written} of {frames} frames")]
    WriterStopped {
        /// Frames written before it stopped.
        written: usize,
        /// Frames of the sequence.
        frames: usize,
    },
}

/// `Io` error constructor for `map_err`.
pub(crate) fn io(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> SynthError {
    let path = path.into();
    move |source| SynthError::Io { path, source }
}
