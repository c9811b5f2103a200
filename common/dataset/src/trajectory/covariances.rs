//! `covariance.txt`: the 6x6 covariance of each published pose, one line per pose,
//! `timestamp c11 c12 ... c66` (36 numbers, row by row), in the order of ROS's
//! `pose.covariance`: x y z (translation, metres) then rx ry rz (rotation vector,
//! radians).
//!
//! The covariance is that of the pose's error in the camera's own axes: with `T_wc` the
//! camera-to-world pose (as in the TUM trajectory of the same run), the true pose is
//! `T_wc exp(e)` with `e ~ N(0, C)`, `e = (x y z rx ry rz)` and `exp` the SE(3)
//! exponential of `gfs_core::se3`. Poses without a covariance (predicted by the motion
//! model) have no line.

use super::tum::TrajectoryError;
use gfs_core::stamp::Stamp;
use nalgebra::Matrix6;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Covariances of poses by timestamp, in time order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Covariances {
    stamps: Vec<Stamp>,
    matrices: Vec<Matrix6<f64>>,
}

impl Covariances {
    /// No covariance.
    pub fn new() -> Self {
        Self::default()
    }

    /// Appends the covariance of the pose at `timestamp` (after the last one).
    pub fn push(&mut self, timestamp: Stamp, covariance: Matrix6<f64>) {
        self.stamps.push(timestamp);
        self.matrices.push(covariance);
    }

    /// Number of covariances.
    pub fn len(&self) -> usize {
        self.stamps.len()
    }

    /// True without any covariance.
    pub fn is_empty(&self) -> bool {
        self.stamps.is_empty()
    }

    /// The covariance of the pose stamped within `max_diff` s of `timestamp`, the
    /// closest one.
    pub fn at(&self, timestamp: Stamp, max_diff: f64) -> Option<&Matrix6<f64>> {
        let i = self.stamps.partition_point(|&t| t < timestamp);
        [i.checked_sub(1), Some(i)]
            .into_iter()
            .flatten()
            .filter(|&k| k < self.stamps.len())
            .map(|k| (k, self.stamps[k].secs_since(timestamp).abs()))
            .filter(|&(_, d)| d <= max_diff)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(k, _)| &self.matrices[k])
    }

    /// Reads a `covariance.txt` (lines starting with `#` and blank lines skipped).
    ///
    /// # Errors
    /// [`TrajectoryError::Io`] when the file cannot be read; `Malformed` naming the
    /// line when it is not a timestamp and 36 finite numbers of a symmetric matrix with
    /// a non-negative diagonal; `Backwards` when the timestamps go back.
    pub fn read(path: &Path) -> Result<Self, TrajectoryError> {
        let text = std::fs::read_to_string(path).map_err(|source| TrajectoryError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let mut out = Self::new();
        for (index, line) in text.lines().enumerate() {
            let trimmed = line.trim();
            if trimmed.is_empty() || trimmed.starts_with('#') {
                continue;
            }
            let malformed = |reason| TrajectoryError::Malformed {
                path: PathBuf::from(path),
                line: index + 1,
                reason,
                text: line.to_owned(),
            };
            let numbers: Vec<f64> = trimmed
                .split_whitespace()
                .map(str::parse::<f64>)
                .collect::<Result<_, _>>()
                .map_err(|_| malformed("not a number"))?;
            let stamp = trimmed
                .split_whitespace()
                .next()
                .and_then(|t| t.parse().ok().or_else(|| Stamp::from_secs(numbers[0])))
                .ok_or_else(|| malformed("timestamp out of range"))?;
            if numbers.len() != 37 {
                return Err(malformed("expected a timestamp and 36 numbers"));
            }
            if numbers.iter().any(|v| !v.is_finite()) {
                return Err(malformed("not finite"));
            }
            let matrix = Matrix6::from_row_slice(&numbers[1..]);
            let asymmetry = (matrix - matrix.transpose()).abs().max();
            if asymmetry > 1e-9 * matrix.abs().max().max(1e-300)
                || (0..6).any(|k| matrix[(k, k)] < 0.0)
            {
                return Err(malformed(
                    "not a covariance (asymmetric or negative variance)",
                ));
            }
            if let Some(&previous) = out.stamps.last()
                && stamp < previous
            {
                return Err(TrajectoryError::Backwards {
                    path: PathBuf::from(path),
                    line: index + 1,
                    timestamp: stamp,
                    previous,
                });
            }
            out.push(stamp, matrix);
        }
        Ok(out)
    }

    /// Writes the covariances as [`Covariances::read`] reads them, with a header that
    /// says what they are.
    ///
    /// # Errors
    /// [`TrajectoryError::Io`] when the file cannot be written.
    pub fn write(&self, path: &Path) -> Result<(), TrajectoryError> {
        let io = |source| TrajectoryError::Io {
            path: path.to_path_buf(),
            source,
        };
        let mut w = std::io::BufWriter::new(std::fs::File::create(path).map_err(io)?);
        writeln!(
            w,
            "# timestamp c11 c12 ... c66: each pose's 6x6 covariance, row by row, over its error\n\
             # e = (x y z rx ry rz) in the camera's axes: true T_wc = T_wc exp(e) (metres, radians)"
        )
        .map_err(io)?;
        for (t, m) in self.stamps.iter().zip(&self.matrices) {
            write!(w, "{t}").map_err(io)?;
            for r in 0..6 {
                for c in 0..6 {
                    write!(w, " {:e}", m[(r, c)]).map_err(io)?;
                }
            }
            writeln!(w).map_err(io)?;
        }
        w.flush().map_err(io)
    }
}
