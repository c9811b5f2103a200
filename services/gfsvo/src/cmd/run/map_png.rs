//! `gfsvo run ... --map-png FILE`: the picture of the run's final map, with the ground
//! truth moved into the map frame when the run was evaluated.

use crate::CliResult;
use gfs_core::scene::Scene;
use gfs_dataset::Evaluation;
use gfs_plot::{MapFigure, PlotConfig, write_map_png};
use nalgebra::Point3;
use std::path::Path;

/// Writes the map picture of `scene` to `path`.
///
/// # Errors
/// Naming the file when it cannot be written.
pub fn write(path: &Path, scene: &Scene, evaluation: Option<&Evaluation>) -> CliResult {
    // The alignment moves the estimate into the ground truth's frame; its inverse
    // brings the ground truth to the map.
    let ground_truth: Vec<Point3<f64>> = evaluation.map_or_else(Vec::new, |e| {
        let map_from_gt = e.ate.alignment.inverse();
        e.gt_matched
            .poses()
            .iter()
            .map(|p| map_from_gt * Point3::from(p.translation.vector))
            .collect()
    });
    let figure = MapFigure {
        scene,
        ground_truth: &ground_truth,
    };
    let config = PlotConfig {
        width: 1800,
        height: 860,
        line_width: 2,
    };
    write_map_png(&figure, path, &config)?;
    tracing::info!("map picture written to {}", path.display());
    Ok(())
}
