//! The map-file switches of `gfsvo run`: keep the global map for a later run
//! (`--save-map`), start from a kept one to extend it (`--load-map`) or to localise in
//! it (`--load-map --localize`, with an optional `--initial-pose`), and start part-way
//! into a dataset (`--start`).

use super::RunMode;
use crate::CliResult;
use gfs_odometry::Odometry;
use gfs_odometry::map_file::{MapCamera, load_map};
use gfs_odometry::session::LoadedMapUse;
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};
use std::path::PathBuf;

/// Map files and where in the dataset a run starts.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct MapArgs {
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
    /// Start at frame N of the dataset (it keeps its number; --frames counts from it).
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub start: usize,
}

impl MapArgs {
    /// Rejects the switches the mode does not support yet, and a start beyond the
    /// dataset's `frames`.
    ///
    /// # Errors
    /// Naming the switch.
    pub fn check(&self, mode: RunMode, frames: usize) -> CliResult {
        let used = [
            (self.save_map.is_some(), "--save-map"),
            (self.load_map.is_some(), "--load-map"),
            (self.start > 0, "--start"),
        ];
        if mode != RunMode::Inline
            && let Some((_, flag)) = used.iter().find(|(on, _)| *on)
        {
            return Err(format!("{flag} runs with --mode inline only (for now)").into());
        }
        if self.start >= frames {
            return Err(format!(
                "--start {}: the dataset has {frames} frames (0 to {})",
                self.start,
                frames.saturating_sub(1)
            )
            .into());
        }
        Ok(())
    }

    /// Loads `--load-map` into `odometry` (before its first frame).
    ///
    /// # Errors
    /// The map file's error, naming it.
    pub fn load_into(&self, odometry: &mut Odometry, camera: &MapCamera) -> CliResult {
        let Some(path) = &self.load_map else {
            return Ok(());
        };
        let start = std::time::Instant::now();
        let saved = load_map(path, camera)?;
        tracing::info!(
            file = %path.display(),
            ms = start.elapsed().as_secs_f64() * 1e3,
            keyframes = saved.map.keyframe_count(),
            points = saved.map.point_count(),
            localise = self.localize,
            "map loaded"
        );
        let use_ = LoadedMapUse {
            localise: self.localize,
            initial_pose: self.initial_pose,
        };
        odometry.start_from(saved, &use_);
        Ok(())
    }

    /// Writes `--save-map` from `odometry`; returns the bytes written.
    ///
    /// # Errors
    /// The map file's error, naming it.
    pub fn save_from(&self, odometry: &Odometry, camera: &MapCamera) -> CliResult<Option<u64>> {
        let Some(path) = &self.save_map else {
            return Ok(None);
        };
        let start = std::time::Instant::now();
        let bytes = odometry.save_map(path, camera)?;
        let ms = start.elapsed().as_secs_f64() * 1e3;
        tracing::info!(file = %path.display(), bytes, ms, "map saved");
        Ok(Some(bytes))
    }
}

/// `x,y,z,qx,qy,qz,qw` as `world_from_camera`.
fn parse_pose(text: &str) -> Result<Isometry3<f64>, String> {
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
