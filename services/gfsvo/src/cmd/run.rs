//! `gfsvo run`: the odometry over a dataset folder (or the built-in synthetic sequence),
//! writing `trajectory.txt` and `status.txt`, printing the ATE when ground truth exists
//! and the time per stage.

use crate::CliResult;
use crate::bench::stats::Summary;
use crate::config::Config;
use gfs_dataset::{EVO_MAX_DIFF_S, Sequence, Trajectory, evaluate};
use gfs_odometry::{Frontend, Odometry, TrackingStatus};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Arguments of `gfsvo run`.
#[derive(clap::Args)]
pub struct RunArgs {
    /// Dataset folder in TUM RGB-D layout. Without it, the built-in synthetic sequence
    /// (a textured room, 300 frames, rendered once into a cache folder) is used.
    pub dataset: Option<PathBuf>,
    /// Config TOML (default: chosen from the dataset folder name; see configs/).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Output folder for trajectory.txt and status.txt.
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    /// Process only the first N frames.
    #[arg(long)]
    pub frames: Option<usize>,
    /// Ablation: run without line features.
    #[arg(long)]
    pub no_lines: bool,
    /// Ablation: run without Manhattan axes.
    #[arg(long)]
    pub no_manhattan: bool,
    /// Print the summary as one JSON object (ATE, frames per status, timings).
    #[arg(long)]
    pub json: bool,
}

/// Runs the odometry in this process.
pub fn run(args: &RunArgs) -> CliResult {
    let dataset = match &args.dataset {
        Some(dir) => dir.clone(),
        None => built_in_sequence(args.json)?,
    };
    let config = Config::load(args.config.as_deref(), &dataset)?;
    let camera = config.camera()?;
    let mut odometry_config = config.odometry();
    odometry_config.tracking.use_lines &= !args.no_lines;
    odometry_config.tracking.use_manhattan &= !args.no_manhattan;
    let sequence = Sequence::open(&dataset, &camera, &config.depth)?;
    std::fs::create_dir_all(&args.out)?;

    let pinhole = camera.pinhole;
    let mut frontend = Frontend::new(
        pinhole,
        &config.points,
        &config.lines,
        &config.planes,
        odometry_config.tracking.use_lines,
        odometry_config.tracking.use_manhattan,
    )?;
    let levels =
        u8::try_from(config.points.levels).map_err(|_| "points.levels must be below 256")?;
    let mut odometry = Odometry::new(
        odometry_config,
        pinhole,
        f64::from(config.points.scale_factor),
        levels,
        &config.lines.grid,
    );
    let total = args
        .frames
        .map_or(sequence.len(), |n| n.min(sequence.len()));
    let progress = progress_bar(total as u64, args.json);
    let mut trajectory = Trajectory::new();
    let mut status = std::io::BufWriter::new(std::fs::File::create(args.out.join("status.txt"))?);
    writeln!(status, "# frame_id timestamp status")?;
    let mut timings = StageTimes::default();
    let mut counts = std::collections::BTreeMap::<&str, usize>::new();
    for (index, frame) in sequence.frames(Some(total)).enumerate() {
        let pose = match frame {
            Ok(frame) => {
                let rotation = odometry.predicted_rotation();
                let features = frontend.extract(
                    frame.id,
                    frame.timestamp,
                    frame.gray.view(),
                    frame.depth.view(),
                    rotation.as_ref(),
                )?;
                let pose = odometry.process(features)?;
                timings.record(&frontend, &odometry);
                pose
            }
            Err(e) => {
                tracing::warn!("frame {index}: {e}; its pose is predicted");
                let timestamp = sequence
                    .timestamps()
                    .get(index)
                    .copied()
                    .unwrap_or_default();
                odometry.skip(gfs_core::ids::FrameId(index as u64), timestamp)
            }
        };
        trajectory.push(pose.timestamp, pose.world_from_camera);
        writeln!(status, "{} {:.6} {}", pose.id, pose.timestamp, pose.status)?;
        *counts.entry(pose.status.as_str()).or_default() += 1;
        progress.inc(1);
    }
    progress.finish_and_clear();
    status.flush()?;
    let trajectory_path = args.out.join("trajectory.txt");
    trajectory.write_tum(&trajectory_path)?;

    let evaluation = match sequence.ground_truth_path() {
        Some(gt) => Some(evaluate(
            &Trajectory::read_tum(&gt)?,
            &trajectory,
            EVO_MAX_DIFF_S,
        )?),
        None => None,
    };
    let summary = timings.summarise();
    if args.json {
        let mut object = serde_json::json!({
            "dataset": dataset.display().to_string(),
            "frames": trajectory.len(),
            "status": counts,
            "keyframes": odometry.map().keyframe_count(),
            "timings_ms": summary,
        });
        if let Some(e) = &evaluation {
            object["ate_rmse_m"] = e.ate.stats.rmse.into();
            object["ate_max_m"] = e.ate.stats.max.into();
            object["matched"] = e.matched().into();
        }
        println!("{object}");
    } else {
        print_report(
            &dataset,
            &trajectory_path,
            trajectory.len(),
            &counts,
            &summary,
        );
        if let Some(e) = &evaluation {
            println!(
                "ATE RMSE {:.4} m (mean {:.4}, median {:.4}, max {:.4}) over {} matched poses",
                e.ate.stats.rmse,
                e.ate.stats.mean,
                e.ate.stats.median,
                e.ate.stats.max,
                e.matched()
            );
        }
    }
    Ok(())
}

/// The built-in synthetic sequence, rendered into the cache on first use with a
/// progress bar.
fn built_in_sequence(quiet: bool) -> CliResult<PathBuf> {
    let config = gfs_synth::SynthConfig::default();
    let bar = progress_bar(config.frames as u64, quiet);
    bar.set_message("rendering the built-in synthetic sequence (once)");
    let dir = gfs_synth::cached_sequence(&config, |done| bar.set_position(done as u64))?;
    bar.finish_and_clear();
    Ok(dir)
}

fn progress_bar(total: u64, hidden: bool) -> ProgressBar {
    if hidden {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(total);
    if let Ok(style) =
        ProgressStyle::with_template("{msg} {bar:40} {pos}/{len} frames {per_sec} eta {eta}")
    {
        bar.set_style(style);
    }
    bar
}

/// Per-frame milliseconds of each stage.
#[derive(Default)]
struct StageTimes {
    points: Vec<f64>,
    lines: Vec<f64>,
    planes: Vec<f64>,
    tracking: Vec<f64>,
    mapping: Vec<f64>,
}

impl StageTimes {
    fn record(&mut self, frontend: &Frontend, odometry: &Odometry) {
        let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
        let f = frontend.timings();
        self.points.push(ms(f.points));
        self.lines.push(ms(f.lines));
        self.planes.push(ms(f.planes));
        let o = odometry.timings();
        self.tracking.push(ms(o.tracking));
        if let Some(m) = o.mapping {
            self.mapping.push(ms(m));
        }
    }

    fn summarise(mut self) -> std::collections::BTreeMap<&'static str, Summary> {
        [
            ("points", Summary::of(&mut self.points)),
            ("lines", Summary::of(&mut self.lines)),
            ("planes", Summary::of(&mut self.planes)),
            ("tracking", Summary::of(&mut self.tracking)),
            ("mapping_per_keyframe", Summary::of(&mut self.mapping)),
        ]
        .into_iter()
        .collect()
    }
}

fn print_report(
    dataset: &Path,
    trajectory: &Path,
    frames: usize,
    counts: &std::collections::BTreeMap<&str, usize>,
    summary: &std::collections::BTreeMap<&'static str, Summary>,
) {
    println!("dataset     {}", dataset.display());
    println!("trajectory  {} ({frames} poses)", trajectory.display());
    let statuses = [
        TrackingStatus::Tracked,
        TrackingStatus::Degraded,
        TrackingStatus::Relocalised,
        TrackingStatus::Predicted,
    ];
    let line: Vec<String> = statuses
        .iter()
        .map(|s| format!("{} {}", s, counts.get(s.as_str()).copied().unwrap_or(0)))
        .collect();
    println!("frames      {}", line.join(", "));
    println!(
        "{:<22}{:>9}{:>9}{:>9}{:>9}{:>7}",
        "stage (ms)", "median", "p90", "p99", "max", "n"
    );
    for (name, s) in summary {
        println!(
            "{name:<22}{:>9.2}{:>9.2}{:>9.2}{:>9.2}{:>7}",
            s.median, s.p90, s.p99, s.max, s.count
        );
    }
}
