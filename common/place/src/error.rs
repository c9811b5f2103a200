//! Errors of reading and writing vocabulary files.

use std::path::PathBuf;

/// Why bytes are not a vocabulary.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum VocabularyFormatError {
    /// Fewer bytes than the header or than the sizes it announces.
    #[error("{len} bytes, {need} needed: truncated")]
    Truncated {
        /// Bytes given.
        len: usize,
        /// Bytes the header requires.
        need: usize,
    },
    /// More bytes than the header announces.
    #[error("{len} bytes, the header announces {expected}")]
    TrailingBytes {
        /// Bytes given.
        len: usize,
        /// Bytes the header announces.
        expected: usize,
    },
    /// Not a vocabulary file.
    #[error("not a GFS-VO vocabulary (bad magic)")]
    BadMagic,
    /// A layout this build cannot read.
    #[error("vocabulary format version {0}, this build reads {FORMAT_VERSION}", FORMAT_VERSION = crate::FORMAT_VERSION)]
    Version(u32),
    /// The bytes were altered.
    #[error("checksum {stored:#018x} stored, {computed:#018x} computed: corrupted")]
    Checksum {
        /// Checksum in the file.
        stored: u64,
        /// Checksum of the bytes.
        computed: u64,
    },
    /// The counts do not describe a tree (e.g. more children than nodes).
    #[error("inconsistent vocabulary: {0}")]
    Inconsistent(String),
}

/// A vocabulary file could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum VocabularyFileError {
    /// The file could not be read or written.
    #[error("vocabulary {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The system's error.
        source: std::io::Error,
    },
    /// The file's bytes are not a vocabulary.
    #[error("vocabulary {path}: {source}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong with the bytes.
        source: VocabularyFormatError,
    },
}
