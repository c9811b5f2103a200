//! The map-file switches of `gfsvo run`: keep the global map for a later run
//! (`--save-map`), start from a kept one to extend it (`--load-map`) or to localise in
//! it (`--load-map --localize`, with an optional `--initial-pose`), and start part-way
//! into a dataset (`--start`). Inline, the odometry here loads and saves; in the
//! pipeline modes the mapper and tracker stages do ([`gfs_pipeline::map_files`]).

use crate::CliResult;
use gfs_odometry::Odometry;
use gfs_odometry::map_file::MapCamera;
use gfs_pipeline::map_files::MapFiles;

/// Map files and where in the dataset a run starts.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct MapArgs {
    /// The map files.
    #[command(flatten)]
    pub files: MapFiles,
    /// Start at frame N of the dataset (--frames counts from it). Inline the frames keep
    /// their numbers (status.txt); in the pipeline modes frame N is the run's frame 0.
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub start: usize,
}

impl MapArgs {
    /// Rejects `--start` for a bag (`bag`) and beyond the dataset's `frames`.
    ///
    /// # Errors
    /// Naming the switch.
    pub fn check(&self, bag: bool, frames: usize) -> CliResult {
        if bag && self.start > 0 {
            return Err("--start plays dataset folders, not bags".into());
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

    /// Reads `--load-map` and checks it against `camera` before the stages start, so
    /// that a bad file is refused with its error rather than by stages that keep dying.
    /// Returns the keyframe id counter of the loaded map (0 without one).
    ///
    /// # Errors
    /// The map file's error, naming it.
    pub fn check_load(&self, camera: &MapCamera) -> CliResult<u64> {
        Ok(self
            .files
            .load(camera)?
            .map_or(0, |saved| saved.map.next_keyframe_id().0))
    }

    /// Loads `--load-map` into `odometry` (before its first frame).
    ///
    /// # Errors
    /// The map file's error, naming it.
    pub fn load_into(&self, odometry: &mut Odometry, camera: &MapCamera) -> CliResult {
        if let Some(saved) = self.files.load(camera)? {
            odometry.start_from(saved, &self.files.use_());
        }
        Ok(())
    }

    /// Writes `--save-map` from `odometry`; returns the bytes written.
    ///
    /// # Errors
    /// The map file's error, naming it.
    pub fn save_from(&self, odometry: &Odometry, camera: &MapCamera) -> CliResult<Option<u64>> {
        let Some(path) = &self.files.save_map else {
            return Ok(None);
        };
        let start = std::time::Instant::now();
        let bytes = odometry.save_map(path, camera)?;
        let ms = start.elapsed().as_secs_f64() * 1e3;
        tracing::info!(file = %path.display(), bytes, ms, "map saved");
        Ok(Some(bytes))
    }
}
