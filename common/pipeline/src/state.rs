//! Checkpoint files in the run's state folder: what a restarted stage resumes from.
//! Written to a temporary file and renamed, so a stage killed mid-write leaves the
//! previous checkpoint intact; read with the size limit of every variable message.

use gfs_ipc::{CodecError, MAX_VARIABLE_MESSAGE_BYTES, decode_message, encode_message};
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::path::{Path, PathBuf};

/// The checkpoint of the supervisor: each stage's name and restarts over the run, for
/// the ROS 2 stage's `/diagnostics`.
pub const RESTARTS: &str = "restarts.bin";

/// A checkpoint could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum StateError {
    /// The file system refused.
    #[error("checkpoint {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file does not hold a valid checkpoint.
    #[error("checkpoint {path}: {source}")]
    Codec {
        /// The file.
        path: PathBuf,
        /// Why it could not be decoded or encoded.
        source: CodecError,
    },
}

/// The state folder of one stage run (`None`: no checkpoints, e.g. inline tests).
#[derive(Clone, Debug)]
pub struct StateDir {
    dir: Option<PathBuf>,
}

impl StateDir {
    /// Checkpoints under `dir`, if given (created on first write).
    pub fn new(dir: Option<PathBuf>) -> Self {
        Self { dir }
    }

    /// Writes `bytes` as checkpoint `name`.
    ///
    /// # Errors
    /// [`StateError::Io`] naming the file.
    pub fn write_bytes(&self, name: &str, bytes: &[u8]) -> Result<(), StateError> {
        let Some(dir) = &self.dir else {
            return Ok(());
        };
        let path = dir.join(name);
        let io = |source| StateError::Io {
            path: path.clone(),
            source,
        };
        std::fs::create_dir_all(dir).map_err(io)?;
        let tmp = dir.join(format!(".{name}.tmp"));
        std::fs::write(&tmp, bytes).map_err(io)?;
        std::fs::rename(&tmp, &path).map_err(io)
    }

    /// Encodes `value` (into `scratch`) and writes it as checkpoint `name`.
    ///
    /// # Errors
    /// [`StateError`] naming the file.
    pub fn write<T: Serialize>(
        &self,
        name: &str,
        value: &T,
        scratch: &mut Vec<u8>,
    ) -> Result<(), StateError> {
        if self.dir.is_none() {
            return Ok(());
        }
        encode_message(value, scratch).map_err(|source| StateError::Codec {
            path: self.path(name),
            source,
        })?;
        self.write_bytes(name, scratch)
    }

    /// Reads checkpoint `name`: `Ok(None)` when there is none.
    ///
    /// # Errors
    /// [`StateError`] naming the file when it exists but cannot be read or decoded.
    pub fn read<T: DeserializeOwned>(&self, name: &str) -> Result<Option<T>, StateError> {
        if self.dir.is_none() {
            return Ok(None);
        }
        let path = self.path(name);
        let bytes = match std::fs::read(&path) {
            Ok(bytes) => bytes,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(source) => return Err(StateError::Io { path, source }),
        };
        decode_message(&bytes, MAX_VARIABLE_MESSAGE_BYTES)
            .map(Some)
            .map_err(|source| StateError::Codec { path, source })
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.as_deref().unwrap_or(Path::new("")).join(name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checkpoints_round_trip_and_bad_files_are_errors() {
        let dir = std::env::temp_dir().join(format!("gfs-state-{}", std::process::id()));
        let state = StateDir::new(Some(dir.clone()));
        let mut scratch = Vec::new();
        assert_eq!(state.read::<Vec<u32>>("a.bin").unwrap(), None);
        state
            .write("a.bin", &vec![1u32, 2, 3], &mut scratch)
            .unwrap();
        assert_eq!(
            state.read::<Vec<u32>>("a.bin").unwrap(),
            Some(vec![1, 2, 3])
        );
        std::fs::write(dir.join("b.bin"), [1u8, 2, 3]).unwrap();
        let e = state.read::<Vec<u32>>("b.bin").unwrap_err().to_string();
        assert!(e.contains("b.bin"), "{e}");
        assert_eq!(StateDir::new(None).read::<u32>("a.bin").unwrap(), None);
        std::fs::remove_dir_all(dir).unwrap();
    }
}
