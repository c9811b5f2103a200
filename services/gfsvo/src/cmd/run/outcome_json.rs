//! `gfsvo run --json`: the run's outcome as one JSON object (frames per status,
//! timings, restarts, ATE, loops, map counts, NEES, the tracker's map).

use super::inline::{BLOCK_FRAMES, MapBytes};
use super::{RunMode, Timings};
use crate::CliResult;
use crate::bench::stats::Summary;
use gfs_dataset::{Consistency, Evaluation};
use gfs_odometry::loop_closing::LoopClosure;
use std::collections::BTreeMap;
use std::path::Path;

/// What a run gives, for its JSON object.
pub struct RunOutcome<'a> {
    /// The dataset folder or bag played.
    pub dataset: &'a Path,
    /// How the stages ran.
    pub mode: RunMode,
    /// Poses written.
    pub frames: usize,
    /// Frames per tracking status.
    pub counts: &'a BTreeMap<&'static str, usize>,
    /// Keyframes made.
    pub keyframes: usize,
    /// Wall time of the run, seconds.
    pub wall_s: f64,
    /// Frames processed.
    pub processed: usize,
    /// The per-stage timings.
    pub timings: &'a Timings,
    /// Pipeline: the restarts per stage.
    pub restarts: Option<&'a BTreeMap<&'static str, u32>>,
    /// The ATE, with ground truth.
    pub evaluation: Option<&'a Evaluation>,
    /// Inline: the loops closed.
    pub loops: Option<&'a [LoopClosure]>,
    /// The map's counts (`loops_closed`, `keyframes_added`, ...), as an object.
    pub map_counts: Option<serde_json::Value>,
    /// The NEES of the published covariances, with ground truth.
    pub consistency: Option<&'a Consistency>,
    /// Inline: tracking milliseconds per block of frames.
    pub tracking_blocks: &'a [Summary],
    /// The ATE of the continuous odometry, when loop corrections moved the trajectory.
    pub odometry_evaluation: Option<&'a Evaluation>,
    /// Inline: the tracker's keyframes and the map's sizes as messages.
    pub tracker_map: Option<(usize, Option<MapBytes>)>,
}

impl RunOutcome<'_> {
    /// The JSON object `gfsvo run --json` prints.
    ///
    /// # Errors
    /// A value serde cannot turn into JSON.
    pub fn to_json(&self) -> CliResult<serde_json::Value> {
        let mut object = serde_json::json!({
            "dataset": self.dataset.display().to_string(),
            "mode": format!("{:?}", self.mode).to_lowercase(),
            "frames": self.frames,
            "status": self.counts,
            "keyframes": self.keyframes,
            "wall_s": self.wall_s,
            "processed": self.processed,
            "processed_per_s": self.processed as f64 / self.wall_s.max(1e-9),
        });
        match self.timings {
            Timings::Inline(t) => object["timings_ms"] = serde_json::to_value(t)?,
            Timings::Pipeline(p) => object["profile"] = serde_json::to_value(p)?,
        }
        if let Some(r) = self.restarts {
            object["restarts"] = serde_json::to_value(r)?;
        }
        if let Some(e) = self.evaluation {
            object["ate_rmse_m"] = e.ate.stats.rmse.into();
            object["ate_max_m"] = e.ate.stats.max.into();
            object["matched"] = e.matched().into();
        }
        if let Some(found) = self.loops {
            object["loops"] = serde_json::to_value(found)?;
        }
        if let Some(serde_json::Value::Object(counts)) = &self.map_counts {
            for (key, value) in counts {
                object[key.as_str()] = value.clone();
            }
        }
        if let Some(c) = self.consistency {
            object["nees"] = crate::cmd::eval::consistency_json(c);
        }
        if !self.tracking_blocks.is_empty() {
            let medians: Vec<f64> = self.tracking_blocks.iter().map(|s| s.median).collect();
            object["tracking_median_ms_per_block"] = medians.into();
            object["block_frames"] = BLOCK_FRAMES.into();
        }
        if let Some(e) = self.odometry_evaluation {
            object["odometry_ate_rmse_m"] = e.ate.stats.rmse.into();
        }
        if let Some((keyframes, bytes)) = &self.tracker_map {
            object["tracker_map_keyframes"] = (*keyframes).into();
            if let Some(bytes) = bytes {
                object["map_bytes"] = serde_json::to_value(bytes)?;
            }
        }
        Ok(object)
    }
}
