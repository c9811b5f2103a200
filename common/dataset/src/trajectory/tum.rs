//! A timestamped trajectory and the TUM text format `timestamp tx ty tz qx qy qz qw`.

use gfs_core::stamp::Stamp;
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};
use std::io::Write;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// A trajectory file could not be read or written.
#[derive(Debug, Error)]
pub enum TrajectoryError {
    /// The file could not be opened, read or written.
    #[error("{path}: {source}", path = path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A line is not `timestamp tx ty tz qx qy qz qw` with finite numbers and a non-zero
    /// quaternion.
    #[error("{path}:{line}: {reason}: {text:?}", path = path.display())]
    Malformed {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        reason: &'static str,
        /// The line as read.
        text: String,
    },
    /// A timestamp is smaller than the one of the line before.
    #[error("{path}:{line}: timestamp {timestamp} goes backwards (previous {previous})", path = path.display())]
    Backwards {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// The timestamp of this line.
        timestamp: Stamp,
        /// The timestamp of the line before.
        previous: Stamp,
    },
}

/// Timestamped camera poses `T_wc` (`world_from_camera`), stamps non-decreasing.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trajectory {
    stamps: Vec<Stamp>,
    poses: Vec<Isometry3<f64>>,
}

impl Trajectory {
    /// An empty trajectory.
    pub fn new() -> Self {
        Self::default()
    }

    /// Appends a pose. The caller keeps stamps in non-decreasing order (the evaluation
    /// searches them by bisection).
    pub fn push(&mut self, timestamp: Stamp, world_from_camera: Isometry3<f64>) {
        debug_assert!(self.stamps.last().is_none_or(|&t| t <= timestamp));
        self.stamps.push(timestamp);
        self.poses.push(world_from_camera);
    }

    /// Number of poses.
    pub fn len(&self) -> usize {
        self.stamps.len()
    }

    /// True when there is no pose.
    pub fn is_empty(&self) -> bool {
        self.stamps.is_empty()
    }

    /// Capture stamps, in order.
    pub fn timestamps(&self) -> &[Stamp] {
        &self.stamps
    }

    /// The stamps in seconds ([`Stamp::secs`]), for the evaluation's arithmetic.
    pub fn seconds(&self) -> Vec<f64> {
        self.stamps.iter().map(|s| s.secs()).collect()
    }

    /// Poses `T_wc`, one per timestamp.
    pub fn poses(&self) -> &[Isometry3<f64>] {
        &self.poses
    }

    /// `(timestamp, T_wc)` pairs in order.
    pub fn iter(&self) -> impl Iterator<Item = (Stamp, &Isometry3<f64>)> {
        self.stamps.iter().copied().zip(&self.poses)
    }

    /// The poses at `indices`, in that order.
    pub fn select(&self, indices: impl IntoIterator<Item = usize>) -> Trajectory {
        let mut out = Trajectory::new();
        for i in indices {
            out.stamps.push(self.stamps[i]);
            out.poses.push(self.poses[i]);
        }
        out
    }

    /// Every pose left-multiplied by `new_world_from_world` (a change of world frame).
    pub fn transformed(&self, new_world_from_world: &Isometry3<f64>) -> Trajectory {
        Trajectory {
            stamps: self.stamps.clone(),
            poses: self
                .poses
                .iter()
                .map(|p| new_world_from_world * p)
                .collect(),
        }
    }

    /// Reads a TUM trajectory file. Blank lines and `#` comments are skipped; fields may
    /// be separated by spaces, tabs or commas; quaternions are normalised. Stamps in
    /// decimal are read exactly; another number form (`1.3e9`) through its `f64`.
    ///
    /// # Errors
    /// [`TrajectoryError::Io`] when the file cannot be read; [`TrajectoryError::Malformed`]
    /// or [`TrajectoryError::Backwards`] naming the line.
    pub fn read_tum(path: &Path) -> Result<Trajectory, TrajectoryError> {
        let text = std::fs::read_to_string(path).map_err(|source| TrajectoryError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::parse_tum(&text, path)
    }

    /// Parses the text of a TUM trajectory file; `origin` names it in errors.
    ///
    /// # Errors
    /// [`TrajectoryError::Malformed`] or [`TrajectoryError::Backwards`] naming the line.
    pub fn parse_tum(text: &str, origin: &Path) -> Result<Trajectory, TrajectoryError> {
        let mut out = Trajectory::new();
        for (i, raw) in text.lines().enumerate() {
            let line = i + 1;
            let trimmed = raw.trim();
            if trimmed.is_empty() || trimmed.starts_with('#') {
                continue;
            }
            let malformed = |reason| TrajectoryError::Malformed {
                path: origin.to_path_buf(),
                line,
                reason,
                text: trimmed.to_owned(),
            };
            let mut v = [0.0f64; 8];
            let mut stamp = None;
            let mut count = 0;
            for field in trimmed
                .split(|c: char| c.is_whitespace() || c == ',')
                .filter(|f| !f.is_empty())
            {
                if count == 8 {
                    return Err(malformed("more than 8 fields"));
                }
                v[count] = field
                    .parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| malformed("field is not a finite number"))?;
                if count == 0 {
                    stamp = field.parse().ok().or_else(|| Stamp::from_secs(v[0]));
                }
                count += 1;
            }
            if count != 8 {
                return Err(malformed(
                    "expected 8 fields `timestamp tx ty tz qx qy qz qw`",
                ));
            }
            let q = Quaternion::new(v[7], v[4], v[5], v[6]);
            if q.norm() < 1e-9 {
                return Err(malformed("quaternion has zero norm"));
            }
            let stamp = stamp.ok_or_else(|| malformed("timestamp out of range"))?;
            if let Some(&previous) = out.stamps.last()
                && stamp < previous
            {
                return Err(TrajectoryError::Backwards {
                    path: origin.to_path_buf(),
                    line,
                    timestamp: stamp,
                    previous,
                });
            }
            out.push(
                stamp,
                Isometry3::from_parts(
                    Translation3::new(v[1], v[2], v[3]),
                    UnitQuaternion::from_quaternion(q),
                ),
            );
        }
        Ok(out)
    }

    /// Writes the trajectory in TUM format: stamps exactly, with 6 decimals or as many
    /// more as their nanoseconds need ([`Stamp`]'s display), poses with 9.
    ///
    /// # Errors
    /// [`TrajectoryError::Io`] when the file cannot be created or written.
    pub fn write_tum(&self, path: &Path) -> Result<(), TrajectoryError> {
        let io = |source| TrajectoryError::Io {
            path: path.to_path_buf(),
            source,
        };
        let file = std::fs::File::create(path).map_err(io)?;
        let mut w = std::io::BufWriter::new(file);
        self.write_tum_to(&mut w).map_err(io)?;
        w.flush().map_err(io)
    }

    /// Writes the TUM lines (with a `#` header line) to any writer.
    ///
    /// # Errors
    /// The writer's I/O error.
    pub fn write_tum_to(&self, w: &mut impl Write) -> std::io::Result<()> {
        writeln!(w, "# timestamp tx ty tz qx qy qz qw")?;
        for (t, pose) in self.iter() {
            let p = pose.translation.vector;
            let q = pose.rotation.quaternion();
            writeln!(
                w,
                "{t} {:.9} {:.9} {:.9} {:.9} {:.9} {:.9} {:.9}",
                p.x, p.y, p.z, q.i, q.j, q.k, q.w
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn origin() -> &'static Path {
        Path::new("est.txt")
    }

    #[test]
    fn parses_comments_blank_lines_and_normalises_quaternions() {
        let text = "# header\n\n1.0 1 2 3 0 0 0 2\n1.5\t0 0 0 0 0 1 1\n";
        let t = Trajectory::parse_tum(text, origin()).unwrap();
        assert_eq!(t.len(), 2);
        assert_eq!(t.seconds(), [1.0, 1.5]);
        assert_eq!(t.poses()[0].translation.vector.y, 2.0);
        let angle = t.poses()[1].rotation.angle().to_degrees();
        assert!((angle - 90.0).abs() < 1e-9, "{angle}");
    }

    #[test]
    fn malformed_lines_are_errors_with_their_line_number() {
        let cases = [
            ("1 2 3\n", 1, "expected 8 fields"),
            ("# c\n1 0 0 0 0 0 0 1\n2 0 0 x 0 0 0 1\n", 3, "finite"),
            ("1 0 0 0 0 0 0 1 9\n", 1, "more than 8"),
            ("\n\n1 0 0 0 0 0 0 0\n", 3, "zero norm"),
            ("1 0 0 0 0 0 0 1\n2 0 0 NaN 0 0 0 1\n", 2, "finite"),
        ];
        for (text, want_line, want_reason) in cases {
            match Trajectory::parse_tum(text, origin()) {
                Err(TrajectoryError::Malformed { line, reason, .. }) => {
                    assert_eq!(line, want_line, "{text:?}");
                    assert!(reason.contains(want_reason), "{reason}");
                }
                other => panic!("{text:?}: {other:?}"),
            }
        }
        let err =
            Trajectory::parse_tum("2 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 1\n", origin()).unwrap_err();
        assert!(matches!(err, TrajectoryError::Backwards { line: 2, .. }));
        assert!(err.to_string().starts_with("est.txt:2:"), "{err}");
    }

    #[test]
    fn write_then_read_round_trips_to_the_printed_precision() {
        let mut t = Trajectory::new();
        let q = UnitQuaternion::from_euler_angles(0.3, -0.2, 1.1);
        t.push(
            "1305031229.528748".parse().unwrap(),
            Isometry3::from_parts(Translation3::new(1.25, -0.5, 3.0), q),
        );
        t.push(
            "1305031229.564425789".parse().unwrap(),
            Isometry3::identity(),
        );
        let mut buf = Vec::new();
        t.write_tum_to(&mut buf).unwrap();
        let back = Trajectory::parse_tum(std::str::from_utf8(&buf).unwrap(), origin()).unwrap();
        assert_eq!(back.len(), 2);
        let text = String::from_utf8(buf).unwrap();
        assert!(text.contains("\n1305031229.528748 1.250000000 "), "{text}");
        assert!(
            text.contains("\n1305031229.564425789 0.000000000 "),
            "{text}"
        );
        for (a, b) in t.iter().zip(back.iter()) {
            assert_eq!(a.0, b.0);
            assert!((a.1.translation.vector - b.1.translation.vector).norm() < 1e-9);
            assert!(a.1.rotation.angle_to(&b.1.rotation) < 1e-8);
        }
    }

    #[test]
    fn a_missing_file_is_an_io_error_naming_it() {
        let err = Trajectory::read_tum(Path::new("/nonexistent/gt.txt")).unwrap_err();
        assert!(err.to_string().contains("/nonexistent/gt.txt"), "{err}");
    }
}
