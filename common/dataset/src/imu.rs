//! `imu.txt` beside `rgb.txt`: the camera's IMU, one sample per line
//! `timestamp gx gy gz ax ay az` (rad/s; specific force in m/s^2, +9.81 along up at
//! rest; in the IMU's axes). A line that cannot be used is skipped with a warning
//! naming the file and line, and the visual odometry goes on.

use crate::error::DatasetError;
use gfs_core::stamp::Stamp;
use gfs_inertial::ImuSample;
use gfs_inertial::sample::{ImuStream, Pushed};
use nalgebra::Vector3;
use std::path::{Path, PathBuf};

/// The file name of a folder's IMU samples.
pub const IMU_LIST: &str = "imu.txt";

/// The usable samples of an `imu.txt`, and what was skipped or noticed, by line.
#[derive(Clone, Debug, Default)]
pub struct ImuList {
    /// The samples, in strictly increasing stamp order.
    pub samples: Vec<ImuSample>,
    /// `path:line: what` for every line skipped and every gap found.
    pub warnings: Vec<String>,
}

/// Largest gap between samples read without a warning, seconds (ten samples at 200 Hz).
const QUIET_GAP_S: f64 = 0.05;

/// Reads `dir/imu.txt`; `Ok(None)` when the folder has none.
///
/// # Errors
/// [`DatasetError::Io`] when the file exists but cannot be read.
pub fn read_imu(dir: &Path) -> Result<Option<ImuList>, DatasetError> {
    let path = dir.join(IMU_LIST);
    if !path.is_file() {
        return Ok(None);
    }
    let text = std::fs::read_to_string(&path).map_err(|source| DatasetError::Io {
        path: path.clone(),
        source,
    })?;
    Ok(Some(parse_imu(&text, &path)))
}

fn parse_imu(text: &str, path: &Path) -> ImuList {
    let mut list = ImuList::default();
    // The stream's checks (order, repeats, NaN, gaps), with no bound on its length.
    let mut stream = ImuStream::new(QUIET_GAP_S, usize::MAX);
    let say =
        |line: usize, what: String| format!("{}:{line}: {what}", PathBuf::from(path).display());
    for (index, raw) in text.lines().enumerate() {
        let line = index + 1;
        let content = raw.trim();
        if content.is_empty() || content.starts_with('#') {
            continue;
        }
        let sample = match parse_line(content) {
            Ok(sample) => sample,
            Err(why) => {
                let shown: String = content.chars().take(80).collect();
                list.warnings
                    .push(say(line, format!("{why}: {shown:?}: skipped")));
                continue;
            }
        };
        match stream.push(sample) {
            Pushed::Kept => {}
            Pushed::KeptWith(issue) | Pushed::Dropped(issue) => {
                list.warnings.push(say(line, issue.to_string()));
            }
        }
    }
    list.samples = stream.samples().to_vec();
    list
}

fn parse_line(content: &str) -> Result<ImuSample, String> {
    let fields: Vec<&str> = content.split_whitespace().collect();
    if fields.len() != 7 {
        return Err(format!(
            "{} fields, 7 expected (`timestamp gx gy gz ax ay az`)",
            fields.len()
        ));
    }
    let stamp: Stamp = fields[0].parse().map_err(|e| format!("{e}"))?;
    let mut values = [0.0; 6];
    for (value, text) in values.iter_mut().zip(&fields[1..]) {
        *value = text
            .parse()
            .map_err(|_| format!("{text:?} is not a number"))?;
    }
    Ok(ImuSample {
        stamp,
        gyro: Vector3::new(values[0], values[1], values[2]),
        accel: Vector3::new(values[3], values[4], values[5]),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn good_lines_are_read_and_bad_ones_skipped_with_file_and_line() {
        let text = "# timestamp gx gy gz ax ay az\n\
                    1305031102.175304001 0.1 0.2 0.3 0.0 0.0 9.81\n\
                    1305031102.180304001 0.1 0.2 0.3 0.0 0.0 9.81\n\
                    1305031102.180304001 0.1 0.2 0.3 0.0 0.0 9.81\n\
                    1305031102.170000000 0.1 0.2 0.3 0.0 0.0 9.81\n\
                    1305031102.185304001 NaN 0.2 0.3 0.0 0.0 9.81\n\
                    1305031102.190304001 0.1 0.2\n\
                    1305031102.19x 0.1 0.2 0.3 0.0 0.0 9.81\n\
                    1305031103.500000000 0.1 0.2 0.3 0.0 0.0 9.81\n";
        let list = parse_imu(text, Path::new("seq/imu.txt"));
        let stamps: Vec<i64> = list.samples.iter().map(|s| s.stamp.nanos()).collect();
        assert_eq!(
            stamps,
            [
                1_305_031_102_175_304_001,
                1_305_031_102_180_304_001,
                1_305_031_103_500_000_000
            ]
        );
        assert_eq!(list.samples[0].accel.z, 9.81);
        let lines: Vec<&str> = list
            .warnings
            .iter()
            .map(|w| w.split(": ").next().unwrap_or(""))
            .collect();
        assert_eq!(
            lines,
            [
                "seq/imu.txt:4",
                "seq/imu.txt:5",
                "seq/imu.txt:6",
                "seq/imu.txt:7",
                "seq/imu.txt:8",
                "seq/imu.txt:9"
            ]
        );
        assert!(list.warnings[0].contains("repeats"), "{}", list.warnings[0]);
        assert!(
            list.warnings[1].contains("before the previous"),
            "{}",
            list.warnings[1]
        );
        assert!(
            list.warnings[2].contains("not finite"),
            "{}",
            list.warnings[2]
        );
        assert!(
            list.warnings[3].contains("3 fields"),
            "{}",
            list.warnings[3]
        );
        assert!(
            list.warnings[5].contains("missing for 1.3"),
            "{}",
            list.warnings[5]
        );
    }

    #[test]
    fn a_folder_without_imu_txt_has_no_imu() {
        let dir = std::env::temp_dir().join(format!("gfs-imu-none-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        assert!(read_imu(&dir).expect("readable").is_none());
        std::fs::remove_dir_all(&dir).ok();
    }
}
