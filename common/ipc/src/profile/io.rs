//! Reading and writing a profile as JSON.

use std::fs::File;
use std::io::{BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};

use thiserror::Error;

use super::record::Profile;

/// A profile file could not be written or read.
#[derive(Debug, Error)]
pub enum ProfileError {
    /// The file could not be created, written, opened or read.
    #[error("{path}: {action} the profile: {source}", path = path.display())]
    Io {
        /// The profile file.
        path: PathBuf,
        /// What was being done ("cannot write", "cannot read").
        action: &'static str,
        /// The file system's error.
        source: std::io::Error,
    },
    /// The file is not a profile: malformed or truncated JSON, or missing fields (the
    /// message gives line and column).
    #[error("{path}: not a GFS-VO profile: {source}", path = path.display())]
    Parse {
        /// The profile file.
        path: PathBuf,
        /// The JSON decoder's error.
        source: serde_json::Error,
    },
}

impl Profile {
    /// Writes the profile as pretty-printed JSON to `path` (replacing the file).
    ///
    /// # Errors
    /// [`ProfileError::Io`] naming `path` when it cannot be created or written.
    pub fn write_json(&self, path: &Path) -> Result<(), ProfileError> {
        let io = |source| ProfileError::Io {
            path: path.to_path_buf(),
            action: "cannot write",
            source,
        };
        let mut out = BufWriter::new(File::create(path).map_err(io)?);
        serde_json::to_writer_pretty(&mut out, self).map_err(|e| io(e.into()))?;
        out.write_all(b"\n").map_err(io)?;
        out.flush().map_err(io)
    }

    /// Reads a profile written by [`Profile::write_json`].
    ///
    /// # Errors
    /// [`ProfileError::Io`] when `path` cannot be opened or read, [`ProfileError::Parse`]
    /// when it is not a profile (both name the file).
    pub fn read_json(path: &Path) -> Result<Profile, ProfileError> {
        let file = File::open(path).map_err(|source| ProfileError::Io {
            path: path.to_path_buf(),
            action: "cannot read",
            source,
        })?;
        serde_json::from_reader(BufReader::new(file)).map_err(|source| {
            if source.is_io() {
                ProfileError::Io {
                    path: path.to_path_buf(),
                    action: "cannot read",
                    source: source.into(),
                }
            } else {
                ProfileError::Parse {
                    path: path.to_path_buf(),
                    source,
                }
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::header::{MsgHeader, Stage, StageStamp};
    use gfs_core::ids::FrameId;
    use gfs_core::stamp::Stamp;

    fn temp(name: &str) -> PathBuf {
        std::env::temp_dir().join(format!("gfs_profile_{}_{name}", std::process::id()))
    }

    fn sample() -> Profile {
        let mut profile = Profile::new("lockstep");
        for k in 0..4u64 {
            let mut h = MsgHeader::new(
                FrameId(k),
                Stamp::from_nanos(1_500_000_000 + k as i64 * 33_333_333),
            );
            let t = 1_000_000 * (k + 1);
            *h.stamp_mut(Stage::Source) = StageStamp {
                received_ns: t,
                started_ns: t + 10,
                finished_ns: t + 2_000,
            };
            *h.stamp_mut(Stage::Tracker) = StageStamp {
                received_ns: t + 3_000,
                started_ns: t + 3_500,
                finished_ns: t + 9_000 + k,
            };
            profile.record(&h, if k == 2 { "lost" } else { "ok" });
        }
        profile
    }

    #[test]
    fn json_round_trip_keeps_everything() {
        let profile = sample();
        let path = temp("round_trip.json");
        profile.write_json(&path).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        // Readable form: stage names as keys, absent stages omitted.
        assert!(text.contains("\"tracker\": {"), "{text}");
        assert!(text.contains("\"started_ns\": 1000010"));
        assert!(!text.contains("\"points\""));
        let back = Profile::read_json(&path).unwrap();
        assert_eq!(back, profile);
        assert_eq!(back.frames[3].end_to_end_ns, Some(8_993));
        assert_eq!(back.frames[2].status, "lost");
        std::fs::remove_file(&path).unwrap();
    }

    #[test]
    fn bad_files_are_errors_naming_the_path() {
        let path = temp("truncated.json");
        sample().write_json(&path).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        std::fs::write(&path, &text[..text.len() / 2]).unwrap();
        let err = Profile::read_json(&path).unwrap_err();
        assert!(matches!(err, ProfileError::Parse { .. }));
        assert!(err.to_string().contains(&*path.to_string_lossy()), "{err}");

        for bad in [
            "",
            "[]",
            "{\"mode\": 3, \"frames\": []}",
            "{\"mode\": \"x\", \"frames\": [{\"frame_id\": -1, \"capture_time_s\": 0}]}",
            "{\"mode\": \"x\", \"frames\": [{\"frame_id\": 1, \"capture_time_s\": 0, \"stages\": {\"warp\": {}}}]}",
        ] {
            std::fs::write(&path, bad).unwrap();
            let err = Profile::read_json(&path).unwrap_err();
            assert!(matches!(err, ProfileError::Parse { .. }), "{bad}: {err}");
        }
        std::fs::remove_file(&path).unwrap();

        let missing = temp("missing.json");
        let err = Profile::read_json(&missing).unwrap_err();
        assert!(matches!(err, ProfileError::Io { .. }));
        assert!(err.to_string().contains("missing.json"), "{err}");
        let unwritable = Path::new("/nonexistent/dir/profile.json");
        let err = sample().write_json(unwritable).unwrap_err();
        assert!(err.to_string().starts_with("/nonexistent/dir/profile.json"));
    }
}
