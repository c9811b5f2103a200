//! `gfsvo run`: the odometry over a dataset folder (or the built-in synthetic sequence),
//! as the supervised multi-process pipeline (default, `lockstep`), paced at the camera
//! rate (`realtime`), as threads of one process (`threads`) or in this thread
//! (`inline`). Writes `trajectory.txt`, `odometry.txt`, `covariance.txt`, `status.txt`
//! and (pipeline) `profile.json`, prints the ATE and the consistency of the published
//! covariances (NEES) when ground truth exists, and the time per stage.

pub mod checks;
mod inline;
pub mod map_file;
mod map_png;
mod outcome_json;

use super::frame_visuals::FrameVisuals;
use crate::CliResult;
use crate::bench::stats::Summary;
use crate::config::Config;
use crate::pipeline::{self, PipelineOptions};
use gfs_core::scene::Scene;
use gfs_core::stamp::Stamp;
use gfs_dataset::{Covariances, EVO_MAX_DIFF_S, Evaluation, Sequence, Trajectory, evaluate};
use gfs_ipc::{Mode, RunId};
use gfs_odometry::{FramePose, TrackingStatus};
use gfs_pipeline::stages::StageSettings;
use gfs_ros2::bag::Compression;
use indicatif::{ProgressBar, ProgressStyle};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

/// How `gfsvo run` runs the stages.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum RunMode {
    /// Stage processes; frame k+1 enters after frame k's pose: reproducible.
    Lockstep,
    /// Stage processes at the camera rate (or --max-rate); stages overlap and a stage
    /// that falls behind takes the newest frame.
    Realtime,
    /// Every stage as a thread of this process (iceoryx2 local services), lockstep.
    Threads,
    /// The library in this thread, frame after frame.
    Inline,
}

/// Arguments of `gfsvo run`.
#[derive(clap::Args)]
pub struct RunArgs {
    /// Dataset folder in TUM RGB-D layout. Without it, the built-in synthetic sequence
    /// (a textured room, 300 frames, rendered once into a cache folder) is used.
    pub dataset: Option<PathBuf>,
    /// Config TOML (default: chosen from the dataset folder name; see configs/).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Output folder for trajectory.txt, odometry.txt, covariance.txt (each published
    /// pose's covariance, see `gfsvo eval --help`), status.txt, profile.json.
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    /// How to run the stages.
    #[arg(long, value_enum, default_value = "lockstep")]
    pub mode: RunMode,
    /// Realtime: play at this many frames per second instead of the capture times.
    #[arg(long)]
    pub max_rate: Option<f64>,
    /// Run id: the iceoryx2 prefix of the run's shared memory (default: unique).
    #[arg(long)]
    pub run_id: Option<String>,
    /// Process only the first N frames.
    #[arg(long)]
    pub frames: Option<usize>,
    /// Ablation: run without line features.
    #[arg(long)]
    pub no_lines: bool,
    /// Ablation: run without Manhattan axes.
    #[arg(long)]
    pub no_manhattan: bool,
    /// Ablation: run without loop closing.
    #[arg(long)]
    pub no_loop_closing: bool,
    /// Ablation: run without the IMU's samples (`imu.txt`).
    #[arg(long)]
    pub no_imu: bool,
    /// Print the summary as one JSON object (ATE, frames per status, timings, and with
    /// ground truth the NEES of the published covariances as `gfsvo eval --consistency`).
    #[arg(long)]
    pub json: bool,
    /// Also write /odom, /tf and the status as a ROS 2 bag file (MCAP, CDR).
    #[arg(long)]
    pub mcap: Option<PathBuf>,
    /// Write a PNG of the final map: top and perspective views of the points (coloured
    /// by height), lines, planes and keyframe path (and ground truth when there is one).
    #[arg(long)]
    pub map_png: Option<PathBuf>,
    /// Chunk compression of the --mcap recording: none, lz4 or zstd (as `ros2 bag
    /// record` writes).
    #[arg(long, default_value = "zstd")]
    pub mcap_compression: Compression,
    /// Map files and the first frame.
    #[command(flatten)]
    pub map: map_file::MapArgs,
}

/// Per-stage timings of a run, as printed.
enum Timings {
    /// Inline: milliseconds per stage.
    Inline(BTreeMap<&'static str, Summary>),
    /// Pipeline: the profile's summary (processing, queueing, end to end).
    Pipeline(gfs_ipc::profile::ProfileSummary),
}

/// Runs the odometry.
pub fn run(args: &RunArgs, log: &str) -> CliResult {
    checks::check_args(args)?;
    pipeline::signals::install();
    let dataset = match &args.dataset {
        Some(dir) => dir.clone(),
        None => built_in_sequence(args.json)?,
    };
    let mut config = Config::load(args.config.as_deref(), &dataset)?;
    config.tracking.use_lines &= !args.no_lines;
    config.tracking.use_manhattan &= !args.no_manhattan;
    config.loop_closing.enabled &= !args.no_loop_closing;
    config.tracking.use_imu &= !args.no_imu;
    if args.mcap.is_some() && args.mode == RunMode::Inline {
        return Err(
            "--mcap records the pose covariances of the pipeline modes, not of inline".into(),
        );
    }
    let _out_lock = checks::lock_out(&args.out)?;
    let source = RunSource::open(&dataset, args, config)?;
    let (config, sequence) = (source.config, source.sequence);
    let ground_truth = match sequence.as_ref().and_then(Sequence::ground_truth_path) {
        Some(gt) => Some(Trajectory::read_tum(&gt)?),
        None => None,
    };
    args.map
        .check(sequence.is_none(), source.timestamps.len())?;
    let remaining = source.timestamps.len() - args.map.start;
    let total = args.frames.map_or(remaining, |n| n.min(remaining));
    let timestamps = &source.timestamps[args.map.start..args.map.start + total];
    let clock = std::time::Instant::now();

    let mut tracking_blocks = Vec::new();
    let mut tracker_map = None;
    let mut scene = None;
    let mut keyframe_scenes = Vec::new();
    let mut frame_views = pipeline::FrameViews::new();
    let map_counts;
    let (poses, odometry, loops, processed, timings, keyframes, restarts, covariances) = if args
        .mode
        == RunMode::Inline
    {
        let sequence = sequence
            .as_ref()
            .ok_or("--mode inline plays dataset folders only")?;
        let progress = progress_bar(total as u64, args.json);
        let outcome = inline::run(
            &config,
            config.odometry(),
            sequence,
            total,
            &progress,
            args.map_png.is_some(),
            &args.map,
        )?;
        progress.finish_and_clear();
        if outcome.interrupted {
            write_outputs(&args.out, &outcome.poses)?;
            write_odometry(&args.out, &outcome.odometry)?;
            return Err(interrupted(outcome.poses.len(), total, &args.out));
        }
        let timings = Timings::Inline(outcome.timings);
        tracking_blocks = outcome.tracking_blocks;
        tracker_map = Some((outcome.tracker_keyframes, outcome.map_bytes));
        scene = outcome.scene;
        let processed = outcome.poses.len();
        let covariances = outcome.covariances;
        map_counts = Some(serde_json::json!({
            "loops_closed": outcome.loops.len(),
            "keyframes_added": outcome.keyframes_added,
            "relocalisations": outcome.relocalisations,
        }));
        (
            outcome.poses,
            outcome.odometry,
            Some(outcome.loops),
            processed,
            timings,
            outcome.keyframes,
            None,
            covariances,
        )
    } else {
        let state_dir = args.out.join("state");
        if state_dir.exists() {
            std::fs::remove_dir_all(&state_dir)?;
        }
        let run_id = match &args.run_id {
            Some(id) => RunId::new(id)?,
            None => RunId::unique("run")?,
        };
        let loaded_keyframes = args.map.check_load(&config.map_camera()?)?;
        let options = PipelineOptions {
            settings: StageSettings {
                mode: if args.mode == RunMode::Realtime {
                    Mode::Realtime
                } else {
                    Mode::Lockstep
                },
                state_dir: Some(state_dir),
                dataset: dataset.clone(),
                start: args.map.start,
                frames: args.frames,
                max_rate: args.max_rate,
                config: config.clone(),
                map_files: args.map.files.clone(),
            },
            config_path: source.config_path.clone(),
            no_lines: args.no_lines,
            no_manhattan: args.no_manhattan,
            no_loop_closing: args.no_loop_closing,
            run_id,
            log: log.to_owned(),
            threads: args.mode == RunMode::Threads,
            total,
            out: args.out.clone(),
            quiet: args.json,
            source_executable: None,
            open_ended: false,
            keep_scenes: args.mcap.is_some(),
        };
        let outcome = pipeline::run(&options)?;
        outcome.profile.write_json(&args.out.join("profile.json"))?;
        if outcome.interrupted {
            // Only the frames up to the last one with a pose: nothing after it was seen.
            let seen = outcome
                .received
                .keys()
                .next_back()
                .map_or(0, |&k| k as usize + 1);
            let poses =
                pipeline::complete_trajectory(&outcome.received, &timestamps[..seen.min(total)]);
            write_outputs(&args.out, &poses)?;
            return Err(interrupted(poses.len(), total, &args.out));
        }
        let poses = pipeline::complete_trajectory(&outcome.received, timestamps);
        let finals = pipeline::final_poses(
            &outcome.received,
            &outcome.corrections,
            &outcome.anchors,
            outcome.final_map.as_ref(),
        );
        let final_trajectory = pipeline::complete_trajectory(&finals, timestamps);
        if args.map_png.is_some() {
            scene = outcome
                .final_map
                .as_ref()
                .map(gfs_odometry::map::Map::scene);
        }
        keyframe_scenes = keyframe_stamps(outcome.scenes, timestamps);
        frame_views = outcome.views;
        let timings = Timings::Pipeline(outcome.profile.summary());
        if !outcome.leftovers.is_empty() {
            return Err(format!("files of the run left behind: {:?}", outcome.leftovers).into());
        }
        let processed = outcome.received.len();
        // From the mapper's last map: keyframe ids count up from the loaded map's.
        let made = |map: &gfs_odometry::map::Map| {
            let added = map.next_keyframe_id().0.saturating_sub(loaded_keyframes);
            (map.corrections(), added)
        };
        let (loops_closed, keyframes_added) = outcome.final_map.as_ref().map_or((0, 0), made);
        map_counts = Some(serde_json::json!({
            "loops_closed": loops_closed,
            "keyframes_added": keyframes_added,
            "imu_samples": outcome.imu_samples,
        }));
        // trajectory.txt: each frame with the loop corrections its keyframe received
        // later (the mapper's last saved map); odometry.txt: the poses as published.
        (
            final_trajectory,
            poses,
            None,
            processed,
            timings,
            outcome.keyframes,
            Some(outcome.restarts),
            outcome.covariances,
        )
    };

    let wall_s = clock.elapsed().as_secs_f64();
    write_outputs(&args.out, &poses)?;
    let published = write_odometry(&args.out, &odometry)?;
    let covariance_track = write_covariances(&args.out, &odometry, &covariances)?;
    if let Some(path) = &args.mcap {
        let stage_restarts: Vec<(String, u32)> = restarts
            .iter()
            .flatten()
            .map(|(stage, n)| ((*stage).to_owned(), *n))
            .collect();
        let details = super::ros2_io::RunDetails {
            profile: None,
            restarts: &stage_restarts,
            scenes: &keyframe_scenes,
            frames: Some(FrameVisuals::of_run(
                &config,
                &dataset,
                sequence.as_ref(),
                &frame_views,
            )?),
        };
        super::ros2_io::record_mcap(
            path,
            &config,
            &odometry,
            &covariances,
            details,
            args.mcap_compression,
        )?;
    }
    let estimated = checks::tracked_trajectory(&poses, &args.out)?;
    let evaluation = match &ground_truth {
        Some(gt) => Some(evaluate(gt, &estimated, EVO_MAX_DIFF_S)?),
        None => None,
    };
    let corrected = poses
        .iter()
        .zip(&odometry)
        .any(|(a, b)| a.world_from_camera != b.world_from_camera);
    if let Some(path) = &args.map_png {
        let scene = scene.ok_or("--map-png: the run left no map (the mapper saved none)")?;
        map_png::write(path, &scene, evaluation.as_ref())?;
    }
    let odometry_evaluation = match &ground_truth {
        Some(gt) if corrected => {
            let continuous = checks::tracked_poses(&odometry);
            Some(evaluate(gt, &continuous, EVO_MAX_DIFF_S)?)
        }
        _ => None,
    };
    let consistency = ground_truth
        .as_ref()
        .map(|gt| gfs_dataset::consistency(gt, &published, &covariance_track, EVO_MAX_DIFF_S));
    let mut counts = BTreeMap::<&str, usize>::new();
    for pose in &poses {
        *counts.entry(pose.status.as_str()).or_default() += 1;
    }
    if args.json {
        let outcome = outcome_json::RunOutcome {
            dataset: &dataset,
            mode: args.mode,
            frames: poses.len(),
            counts: &counts,
            keyframes,
            wall_s,
            processed,
            timings: &timings,
            restarts: restarts.as_ref(),
            evaluation: evaluation.as_ref(),
            loops: loops.as_deref(),
            map_counts,
            consistency: consistency.as_ref(),
            tracking_blocks: &tracking_blocks,
            odometry_evaluation: odometry_evaluation.as_ref(),
            tracker_map,
        };
        println!("{}", outcome.to_json()?);
    } else {
        print_report(&dataset, &args.out, poses.len(), &counts, &timings);
        println!(
            "wall        {wall_s:.2} s, {processed} frames processed, {:.1} per second",
            processed as f64 / wall_s.max(1e-9)
        );
        if let Some(r) = restarts.filter(|r| r.values().any(|n| *n > 0)) {
            println!("restarts    {r:?}");
        }
        if let Some(found) = &loops {
            println!("loops       {} closed", found.len());
            for l in found {
                println!(
                    "            keyframe {} -> {}: {} inliers, moved {:.3} m, found by {}",
                    l.current,
                    l.candidate,
                    l.inliers,
                    l.shift_m,
                    if l.by_appearance {
                        "appearance"
                    } else {
                        "position"
                    }
                );
            }
        }
        if let Some(e) = &evaluation {
            print_ate(e);
        }
        if let Some(c) = &consistency {
            super::eval::print_consistency(c);
        }
        if let Some(e) = &odometry_evaluation {
            println!(
                "ATE RMSE {:.4} m of the continuous odometry (odometry.txt)",
                e.ate.stats.rmse
            );
        }
    }
    Ok(())
}

/// The scenes of the keyframes by their frames' stamps (a frame id beyond the stamps,
/// which no run makes, is left out).
pub fn keyframe_stamps(scenes: pipeline::Scenes, timestamps: &[Stamp]) -> Vec<(Stamp, Scene)> {
    scenes
        .into_iter()
        .filter_map(|(frame, scene)| Some((*timestamps.get(frame as usize)?, scene)))
        .collect()
}

/// The error of a run stopped by SIGINT / SIGTERM after `done` of `total` frames.
fn interrupted(done: usize, total: usize, out: &Path) -> crate::CliError {
    format!(
        "interrupted after {done} of {total} frames; the trajectory of those frames is in {}",
        out.display()
    )
    .into()
}

/// What a run plays: a dataset folder or a ROS 2 bag, with the frame stamps.
struct RunSource {
    config: Config,
    config_path: Option<PathBuf>,
    timestamps: Vec<Stamp>,
    sequence: Option<Sequence>,
}

impl RunSource {
    fn open(dataset: &Path, args: &RunArgs, config: Config) -> CliResult<Self> {
        if gfs_ros2::bag::is_bag(dataset) {
            let bag = super::ros2_io::open_bag(dataset, args.config.as_deref(), config, &args.out)?;
            return Ok(Self {
                config: bag.config,
                config_path: bag.config_path,
                timestamps: bag.timestamps,
                sequence: None,
            });
        }
        let sequence = Sequence::open(dataset, &config.camera()?, &config.depth)?;
        Ok(Self {
            config,
            config_path: args.config.clone(),
            timestamps: sequence.timestamps().to_vec(),
            sequence: Some(sequence),
        })
    }
}

/// Writes `trajectory.txt` (TUM) and `status.txt`; returns the trajectory.
pub fn write_outputs(out: &Path, poses: &[FramePose]) -> CliResult<Trajectory> {
    let mut trajectory = Trajectory::new();
    let path = out.join("status.txt");
    let named = |e: std::io::Error| format!("cannot write {}: {e}", path.display());
    let mut status = std::io::BufWriter::new(std::fs::File::create(&path).map_err(named)?);
    writeln!(status, "# frame_id timestamp status").map_err(named)?;
    for pose in poses {
        trajectory.push(pose.timestamp, pose.world_from_camera);
        writeln!(status, "{} {} {}", pose.id, pose.timestamp, pose.status).map_err(named)?;
    }
    status.flush().map_err(named)?;
    trajectory.write_tum(&out.join("trajectory.txt"))?;
    Ok(trajectory)
}

/// Writes `odometry.txt` (TUM): the poses as published, continuous (REP 105 `odom`);
/// `trajectory.txt` holds the final best estimate, in the map frame. Returns the
/// poses written.
pub fn write_odometry(out: &Path, poses: &[FramePose]) -> CliResult<Trajectory> {
    let mut trajectory = Trajectory::new();
    for pose in poses {
        trajectory.push(pose.timestamp, pose.world_from_camera);
    }
    trajectory.write_tum(&out.join("odometry.txt"))?;
    Ok(trajectory)
}

/// Writes `covariance.txt`: the covariance of each published pose that has one (see
/// `gfs_dataset::Covariances` for the format and convention); returns them.
fn write_covariances(
    out: &Path,
    poses: &[FramePose],
    covariances: &crate::pipeline::Covariances,
) -> CliResult<Covariances> {
    let mut track = Covariances::new();
    for pose in poses {
        if let Some(c) = covariances.get(&pose.id.0) {
            track.push(pose.timestamp, *c);
        }
    }
    track.write(&out.join("covariance.txt"))?;
    Ok(track)
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

/// A frame progress bar (hidden when `hidden`).
pub fn progress_bar(total: u64, hidden: bool) -> ProgressBar {
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

fn print_ate(e: &Evaluation) {
    println!(
        "ATE RMSE {:.4} m (mean {:.4}, median {:.4}, max {:.4}) over {} matched poses",
        e.ate.stats.rmse,
        e.ate.stats.mean,
        e.ate.stats.median,
        e.ate.stats.max,
        e.matched()
    );
}

fn print_report(
    dataset: &Path,
    out: &Path,
    frames: usize,
    counts: &BTreeMap<&str, usize>,
    timings: &Timings,
) {
    println!("dataset     {}", dataset.display());
    println!(
        "trajectory  {} ({frames} poses)",
        out.join("trajectory.txt").display()
    );
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
    match timings {
        Timings::Pipeline(summary) => print!("{summary}"),
        Timings::Inline(summary) => {
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
    }
}
