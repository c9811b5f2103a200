//! The list files of a TUM RGB-D folder (`rgb.txt`, `depth.txt`, `associations.txt`) and
//! the TUM association rule that pairs colour and depth images by timestamp.

use crate::error::DatasetError;
use gfs_core::stamp::Stamp;
use std::path::{Path, PathBuf};

/// Largest colour-depth stamp difference the TUM tools associate (`associate.py`
/// `--max_difference` default), s. Pairs must be strictly closer.
pub const TUM_MAX_DIFFERENCE_S: f64 = 0.02;

/// Where one image comes from: its file and the list line that names it.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ImageRef {
    /// Capture stamp, exactly as listed.
    pub stamp: Stamp,
    /// Image file (folder joined with the listed relative path).
    pub path: PathBuf,
    /// List file that names it.
    pub list: PathBuf,
    /// 1-based line in `list`.
    pub line: usize,
}

/// One frame: a colour image and the depth image associated with it.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Entry {
    /// The colour image (its stamp is the frame's timestamp).
    pub rgb: ImageRef,
    /// The depth image.
    pub depth: ImageRef,
}

/// Reads the frames of `dir`: from `associations.txt` when present, else by associating
/// `rgb.txt` with `depth.txt`.
pub(crate) fn read_entries(dir: &Path) -> Result<Vec<Entry>, DatasetError> {
    let assoc = dir.join("associations.txt");
    let entries = if assoc.is_file() {
        let entries = read_associations(dir, &assoc)?;
        if entries.is_empty() {
            return Err(DatasetError::NoFrames {
                dir: dir.to_path_buf(),
                reason: "associations.txt lists no frame".to_owned(),
            });
        }
        entries
    } else {
        let rgb = read_list(dir, &dir.join("rgb.txt"))?;
        let depth = read_list(dir, &dir.join("depth.txt"))?;
        if rgb.is_empty() || depth.is_empty() {
            return Err(DatasetError::NoFrames {
                dir: dir.to_path_buf(),
                reason: format!(
                    "rgb.txt lists {} images, depth.txt {}",
                    rgb.len(),
                    depth.len()
                ),
            });
        }
        let pairs = associate_tum(
            &rgb.iter().map(|r| r.stamp).collect::<Vec<_>>(),
            &depth.iter().map(|r| r.stamp).collect::<Vec<_>>(),
            TUM_MAX_DIFFERENCE_S,
        );
        pairs
            .into_iter()
            .map(|(i, j)| Entry {
                rgb: rgb[i].clone(),
                depth: depth[j].clone(),
            })
            .collect()
    };
    if entries.is_empty() {
        return Err(DatasetError::NoFrames {
            dir: dir.to_path_buf(),
            reason: format!(
                "no colour image has a depth image within {} ms",
                TUM_MAX_DIFFERENCE_S * 1e3
            ),
        });
    }
    Ok(entries)
}

fn read_text(path: &Path) -> Result<String, DatasetError> {
    std::fs::read_to_string(path).map_err(|source| {
        if source.kind() == std::io::ErrorKind::NotFound {
            DatasetError::MissingList {
                path: path.to_path_buf(),
            }
        } else {
            DatasetError::Io {
                path: path.to_path_buf(),
                source,
            }
        }
    })
}

/// The data lines of a list file: (1-based line number, whitespace-separated fields).
/// Blank lines and `#` comments are skipped.
fn data_lines(text: &str) -> impl Iterator<Item = (usize, &str, Vec<&str>)> {
    text.lines().enumerate().filter_map(|(i, line)| {
        let trimmed = line.trim();
        if trimmed.is_empty() || trimmed.starts_with('#') {
            None
        } else {
            Some((i + 1, trimmed, trimmed.split_whitespace().collect()))
        }
    })
}

fn parse_stamp(field: &str, path: &Path, line: usize, text: &str) -> Result<Stamp, DatasetError> {
    field.parse().map_err(|_| DatasetError::MalformedLine {
        path: path.to_path_buf(),
        line,
        reason: "timestamp is not decimal seconds",
        text: text.to_owned(),
    })
}

/// Checks that `stamp` is larger than the previous one and remembers it.
fn check_increasing(
    previous: &mut Option<Stamp>,
    stamp: Stamp,
    path: &Path,
    line: usize,
) -> Result<(), DatasetError> {
    if let Some(prev) = *previous
        && stamp <= prev
    {
        return Err(DatasetError::TimestampNotIncreasing {
            path: path.to_path_buf(),
            line,
            timestamp: stamp,
            previous: prev,
        });
    }
    *previous = Some(stamp);
    Ok(())
}

/// Reads `rgb.txt` or `depth.txt`: lines `timestamp relative/path`.
fn read_list(dir: &Path, path: &Path) -> Result<Vec<ImageRef>, DatasetError> {
    let text = read_text(path)?;
    let mut out = Vec::new();
    let mut previous = None;
    for (line, raw, fields) in data_lines(&text) {
        if fields.len() != 2 {
            return Err(DatasetError::MalformedLine {
                path: path.to_path_buf(),
                line,
                reason: "expected `timestamp path`",
                text: raw.to_owned(),
            });
        }
        let stamp = parse_stamp(fields[0], path, line, raw)?;
        check_increasing(&mut previous, stamp, path, line)?;
        out.push(ImageRef {
            stamp,
            path: dir.join(fields[1]),
            list: path.to_path_buf(),
            line,
        });
    }
    Ok(out)
}

/// True when a listed path lies in the `depth` folder (ICL-NUIM lists depth first).
fn is_depth_path(p: &str) -> bool {
    p.starts_with("depth")
}

/// Reads `associations.txt`: lines `t_rgb rgb/x.png t_depth depth/y.png` (or with depth
/// first, as some ICL-NUIM folders have it; the folder names tell which is which).
fn read_associations(dir: &Path, path: &Path) -> Result<Vec<Entry>, DatasetError> {
    let text = read_text(path)?;
    let mut out = Vec::new();
    let mut previous = None;
    for (line, raw, fields) in data_lines(&text) {
        if fields.len() != 4 {
            return Err(DatasetError::MalformedLine {
                path: path.to_path_buf(),
                line,
                reason: "expected `t_rgb rgb_path t_depth depth_path`",
                text: raw.to_owned(),
            });
        }
        let (mut a, mut b) = ((fields[0], fields[1]), (fields[2], fields[3]));
        if is_depth_path(a.1) && !is_depth_path(b.1) {
            std::mem::swap(&mut a, &mut b);
        }
        let rgb_stamp = parse_stamp(a.0, path, line, raw)?;
        let depth_stamp = parse_stamp(b.0, path, line, raw)?;
        check_increasing(&mut previous, rgb_stamp, path, line)?;
        let image = |stamp, rel: &str| ImageRef {
            stamp,
            path: dir.join(rel),
            list: path.to_path_buf(),
            line,
        };
        out.push(Entry {
            rgb: image(rgb_stamp, a.1),
            depth: image(depth_stamp, b.1),
        });
    }
    Ok(out)
}

/// Pairs two increasing stamp lists as TUM's `associate.py` does: among all pairs closer
/// than `max_difference`, repeatedly take the closest pair whose two stamps are both
/// still free. Returns `(index in first, index in second)` sorted by the first index.
pub fn associate_tum(
    first: &[Stamp],
    second: &[Stamp],
    max_difference_s: f64,
) -> Vec<(usize, usize)> {
    let max_difference = (max_difference_s * 1e9).round() as i64;
    let mut candidates = Vec::new();
    let mut lo = 0;
    for (i, a) in first.iter().map(|s| s.nanos()).enumerate() {
        while lo < second.len() && second[lo].nanos() <= a - max_difference {
            lo += 1;
        }
        let mut j = lo;
        while j < second.len() && second[j].nanos() < a + max_difference {
            let diff = (a - second[j].nanos()).abs();
            if diff < max_difference {
                candidates.push((diff, i, j));
            }
            j += 1;
        }
    }
    candidates.sort_unstable();
    let mut first_used = vec![false; first.len()];
    let mut second_used = vec![false; second.len()];
    let mut pairs = Vec::new();
    for (_, i, j) in candidates {
        if !first_used[i] && !second_used[j] {
            first_used[i] = true;
            second_used[j] = true;
            pairs.push((i, j));
        }
    }
    pairs.sort_unstable();
    pairs
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stamps(seconds: &[f64]) -> Vec<Stamp> {
        seconds
            .iter()
            .map(|&s| Stamp::from_secs(s).unwrap())
            .collect()
    }

    #[test]
    fn tum_association_takes_the_closest_free_pairs_within_20_ms() {
        // Depth runs 5 ms late with one dropped depth frame and one far-off stamp.
        let rgb = stamps(&[0.0, 0.033, 0.066, 0.100, 0.133]);
        let depth = stamps(&[0.005, 0.038, 0.105, 0.160]);
        let pairs = associate_tum(&rgb, &depth, TUM_MAX_DIFFERENCE_S);
        // 0.066 has no depth within 20 ms once 0.105 is taken by the closer 0.100;
        // 0.133 - 0.160 = 27 ms is too far.
        assert_eq!(pairs, vec![(0, 0), (1, 1), (3, 2)]);
    }

    #[test]
    fn tum_association_is_greedy_over_the_whole_list() {
        // 0.010 is 8 ms from depth 0.018 and would take it in a per-frame scan, but
        // 0.020 is closer (2 ms) so it wins; 0.010 then takes 0.000 (10 ms).
        let pairs = associate_tum(
            &stamps(&[0.010, 0.020]),
            &stamps(&[0.000, 0.018]),
            TUM_MAX_DIFFERENCE_S,
        );
        assert_eq!(pairs, vec![(0, 0), (1, 1)]);
        let pairs = associate_tum(
            &stamps(&[0.010, 0.020]),
            &stamps(&[0.018]),
            TUM_MAX_DIFFERENCE_S,
        );
        assert_eq!(pairs, vec![(1, 0)]);
    }
}
