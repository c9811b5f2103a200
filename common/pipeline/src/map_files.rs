//! The map files of a run (`--save-map`, `--load-map`, `--localize`, `--initial-pose`),
//! the same switches for `gfsvo run`, `gfsvo ros2` and every stage process. The mapper
//! owns the global map: it starts on the loaded map and writes the map file when it
//! stops (the end of the run, SIGINT / SIGTERM) and when asked on the
//! [`gfs_ipc::topics::SAVE_MAP`] topic ([`SaveMapRequest`]); the tracker starts on the
//! loaded map's neighbourhood as the inline odometry does.

use gfs_odometry::WorldManhattan;
use gfs_odometry::map::Map;
use gfs_odometry::map_file::{MapCamera, MapFileError, SavedMap, load_map, save_map};
use gfs_odometry::session::LoadedMapUse;
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};
use serde::{Deserialize, Serialize};
use std::ffi::OsString;
use std::path::PathBuf;
use std::time::Instant;

/// Map files and how a loaded map is used.
#[derive(clap::Args, Clone, Debug, Default, PartialEq)]
pub struct MapFiles {
    /// Write the global map to FILE when the run ends (also when SIGINT / SIGTERM
    /// stops it), atomically: FILE is the old map or the whole new one, never a part.
    #[arg(long, value_name = "FILE")]
    pub save_map: Option<PathBuf>,
    /// Start from the map in FILE (written by --save-map with the same camera and ORB
    /// pyramid): the first frame is found in it and mapping goes on in its frame.
    #[arg(long, value_name = "FILE")]
    pub load_map: Option<PathBuf>,
    /// With --load-map: localise only. The map is fixed (no keyframe added, no
    /// landmark changed); each frame is tracked against it, a lost one relocalised
    /// against the whole map; poses are in the map's frame.
    #[arg(long, requires = "load_map")]
    pub localize: bool,
    /// With --load-map: where the first frame is thought to be, `x,y,z,qx,qy,qz,qw`
    /// (world_from_camera in the map's frame): it is looked for around the nearest
    /// keyframe before the whole map is searched.
    #[arg(long, requires = "load_map", value_parser = parse_pose, allow_hyphen_values = true)]
    pub initial_pose: Option<Isometry3<f64>>,
}

impl MapFiles {
    /// How the loaded map is used.
    pub fn use_(&self) -> LoadedMapUse {
        LoadedMapUse {
            localise: self.localize,
            initial_pose: self.initial_pose,
        }
    }

    /// Reads `--load-map` (`None` without it), logging its size and time.
    ///
    /// # Errors
    /// The map file's error, naming it.
    pub fn load(&self, camera: &MapCamera) -> Result<Option<SavedMap>, MapFileError> {
        let Some(path) = &self.load_map else {
            return Ok(None);
        };
        let start = Instant::now();
        let saved = load_map(path, camera)?;
        tracing::info!(
            file = %path.display(),
            ms = start.elapsed().as_secs_f64() * 1e3,
            keyframes = saved.map.keyframe_count(),
            points = saved.map.point_count(),
            localise = self.localize,
            "map loaded"
        );
        Ok(Some(saved))
    }

    /// The switches on a stage's command line, each value joined to its flag.
    pub fn stage_args(&self) -> Vec<OsString> {
        let flag = |name: &str, value: &std::ffi::OsStr| {
            let mut arg = OsString::from(format!("--{name}="));
            arg.push(value);
            arg
        };
        let mut args = Vec::new();
        if let Some(path) = &self.save_map {
            args.push(flag("save-map", path.as_os_str()));
        }
        if let Some(path) = &self.load_map {
            args.push(flag("load-map", path.as_os_str()));
        }
        if self.localize {
            args.push("--localize".into());
        }
        if let Some(pose) = &self.initial_pose {
            args.push(flag("initial-pose", format_pose(pose).as_ref()));
        }
        args
    }
}

/// Writes `map` to `path` as a map file (atomically), logging the size and time;
/// returns the bytes written.
///
/// # Errors
/// The map file's error, naming it.
pub fn write_map(
    path: &std::path::Path,
    camera: &MapCamera,
    map: &Map,
    manhattan: &WorldManhattan,
) -> Result<u64, MapFileError> {
    let start = Instant::now();
    let bytes = save_map(path, camera, map, manhattan)?;
    tracing::info!(
        file = %path.display(),
        bytes,
        ms = start.elapsed().as_secs_f64() * 1e3,
        keyframes = map.keyframe_count(),
        "map saved"
    );
    Ok(bytes)
}

/// A request to the mapper stage to write the global map now (the `/gfsvo/save_map`
/// service of `gfsvo ros2` sends one on [`gfs_ipc::topics::SAVE_MAP`], bincode).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SaveMapRequest {
    /// Numbers the request; the reply carries it back.
    pub id: u64,
    /// Where to write the map (atomically).
    pub path: PathBuf,
}

/// The mapper's answer to a [`SaveMapRequest`] on [`gfs_ipc::topics::MAP_SAVED`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SaveMapReply {
    /// The request's number.
    pub id: u64,
    /// The file written.
    pub path: PathBuf,
    /// The bytes written, or the error naming the file.
    pub result: Result<u64, String>,
    /// Keyframes in the map written.
    pub keyframes: usize,
}

/// `x,y,z,qx,qy,qz,qw` as `world_from_camera`.
///
/// # Errors
/// Naming the text: not seven numbers, not finite, or a quaternion far from unit norm.
pub fn parse_pose(text: &str) -> Result<Isometry3<f64>, String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("{text:?}: {e} (expected x,y,z,qx,qy,qz,qw)"))?;
    let [x, y, z, qx, qy, qz, qw] = values[..] else {
        return Err(format!(
            "{text:?}: {} numbers, expected 7 (x,y,z,qx,qy,qz,qw)",
            values.len()
        ));
    };
    let q = Quaternion::new(qw, qx, qy, qz);
    let norm = q.norm();
    if !values.iter().all(|v| v.is_finite()) || !(0.5..2.0).contains(&norm) {
        return Err(format!(
            "{text:?}: not finite, or the quaternion's norm {norm:.3} is far from 1"
        ));
    }
    Ok(Isometry3::from_parts(
        Translation3::new(x, y, z),
        UnitQuaternion::from_quaternion(q),
    ))
}

/// The text [`parse_pose`] reads back to the same pose (shortest round-trip digits).
fn format_pose(pose: &Isometry3<f64>) -> String {
    let t = pose.translation.vector;
    let q = pose.rotation.coords;
    [t.x, t.y, t.z, q.x, q.y, q.z, q.w]
        .map(|v| v.to_string())
        .join(",")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_stage_command_line_gives_back_the_same_switches() {
        let files = MapFiles {
            save_map: Some("out/-odd name.gfsmap".into()),
            load_map: Some("maps/a.gfsmap".into()),
            localize: true,
            initial_pose: Some(parse_pose("0.1,-2.5e-3,3,0.1,0.2,-0.3,0.9").unwrap()),
        };
        #[derive(clap::Parser)]
        struct Cli {
            #[command(flatten)]
            files: MapFiles,
        }
        let mut args = vec![OsString::from("stage")];
        args.extend(files.stage_args());
        let parsed = <Cli as clap::Parser>::try_parse_from(args).unwrap();
        assert_eq!(parsed.files, files);
        assert!(parse_pose("1,2,3").unwrap_err().contains("7"));
        assert!(parse_pose("1,2,3,0,0,0,0").unwrap_err().contains("norm"));
    }
}
