//! `gfsvo ros2`: the supervised pipeline in realtime mode fed by ROS 2 (the `gfsvo-ros2`
//! stage in the source's place subscribes to the camera and publishes `/odom`, `/tf`
//! and the status) until SIGINT / SIGTERM; then writes `trajectory.txt` (one pose per
//! frame received, stamped with the colour stamp), `status.txt` and `profile.json`.

use super::frame_visuals::{ColourFrames, FrameVisuals};
use super::ros2_io::{RunDetails, camera_values, record_mcap, write_config};
use super::run::write_outputs;
use crate::CliResult;
use crate::pipeline::{self, PipelineOptions};
use gfs_core::camera::{Camera, CameraConfig};
use gfs_core::stamp::Stamp;
use gfs_ipc::{Mode, RunId};
use gfs_pipeline::map_files::MapFiles;
use gfs_pipeline::stages::StageSettings;
use gfs_ros2::bag::Compression;
use gfs_ros2::camera_info::cameras_differ;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Arguments of `gfsvo ros2`; the topic and frame flags override the config's `[ros2]`.
#[derive(clap::Args)]
pub struct Ros2Args {
    /// Config TOML with the camera (`[camera]`, `[depth]`) and optionally `[ros2]`.
    #[arg(long)]
    pub config: PathBuf,
    /// Output folder for trajectory.txt, status.txt, profile.json, config.toml.
    #[arg(long, default_value = "out/ros2")]
    pub out: PathBuf,
    /// Run id: the iceoryx2 prefix of the run's shared memory (default: unique).
    #[arg(long)]
    pub run_id: Option<String>,
    /// Colour image topic (sensor_msgs/Image).
    #[arg(long)]
    pub colour_topic: Option<String>,
    /// Depth image topic registered to colour (16UC1 mm or 32FC1 m).
    #[arg(long)]
    pub depth_topic: Option<String>,
    /// CameraInfo topic of the colour camera.
    #[arg(long)]
    pub camera_info_topic: Option<String>,
    /// Odometry output topic.
    #[arg(long)]
    pub odom_topic: Option<String>,
    /// TF output topic.
    #[arg(long)]
    pub tf_topic: Option<String>,
    /// Tracking status output topic (std_msgs/String).
    #[arg(long)]
    pub status_topic: Option<String>,
    /// Odometry frame (REP 105).
    #[arg(long)]
    pub odom_frame: Option<String>,
    /// Robot body frame: the odometry's child frame.
    #[arg(long)]
    pub base_frame: Option<String>,
    /// Do not publish odom -> base on /tf.
    #[arg(long)]
    pub no_tf: bool,
    /// Colour / depth pairing slop, seconds.
    #[arg(long)]
    pub slop: Option<f64>,
    /// What a lost frame publishes: predict (inflated covariance) or nothing.
    #[arg(long, value_parser = ["predict", "nothing"])]
    pub when_lost: Option<String>,
    /// Also write /odom, /tf and the status into this MCAP file at the end.
    #[arg(long)]
    pub mcap: Option<PathBuf>,
    /// Chunk compression of the --mcap recording: none, lz4 or zstd (as `ros2 bag
    /// record` writes).
    #[arg(long, default_value = "zstd")]
    pub mcap_compression: Compression,
    /// How long to wait for the driver's CameraInfo before starting (its camera wins
    /// over the config's, with a warning); 0: track with the config's camera.
    #[arg(long, default_value_t = 10.0)]
    pub camera_info_timeout: f64,
    /// Map files: the mapper starts on --load-map and writes --save-map at SIGINT /
    /// SIGTERM (see `gfsvo run --help`).
    #[command(flatten)]
    pub map: MapFiles,
}

/// File in the state folder where the ROS 2 stage lists the frames it received.
pub const FRAMES_FILE: &str = "ros2-frames.txt";

/// Runs the pipeline on ROS 2 input until interrupted.
pub fn run(args: &Ros2Args, log: &str) -> CliResult {
    let _out_lock = super::run::checks::lock_out(&args.out)?;
    let state_dir = args.out.join("state");
    if state_dir.exists() {
        std::fs::remove_dir_all(&state_dir)?;
    }
    let config_path = args.out.join("config.toml");
    let mut config = write_config(
        Some(&args.config),
        &args.out,
        "ros2",
        overrides(args),
        &config_path,
    )?;
    let run_id = match &args.run_id {
        Some(id) => RunId::new(id)?,
        None => RunId::unique("ros2")?,
    };
    if args.camera_info_timeout > 0.0
        && let Some(camera) = probe_camera(args, &config_path, &run_id)?
        && cameras_differ(&camera, &config.camera()?)
    {
        tracing::warn!(
            "the camera of {} differs from {}'s; tracking with the driver's: {:?}",
            config.ros2.camera_info_topic,
            args.config.display(),
            camera
        );
        config = write_config(
            Some(&config_path),
            &args.out,
            "camera",
            camera_values(&camera)?,
            &config_path,
        )?;
    }
    // A bad map file is refused here, with its error, not by stages that keep dying.
    args.map.load(&config.map_camera()?)?;
    let options = PipelineOptions {
        settings: StageSettings {
            mode: Mode::Realtime,
            state_dir: Some(state_dir.clone()),
            dataset: args.out.clone(),
            start: 0,
            frames: None,
            max_rate: None,
            config: config.clone(),
            map_files: args.map.clone(),
        },
        config_path: Some(config_path),
        no_lines: false,
        no_manhattan: false,
        no_loop_closing: false,
        run_id,
        log: log.to_owned(),
        threads: false,
        total: usize::MAX,
        out: args.out.clone(),
        quiet: true,
        source_executable: Some("gfsvo-ros2".to_owned()),
        open_ended: true,
        keep_scenes: args.mcap.is_some(),
    };
    eprintln!(
        "gfsvo ros2: waiting for {} + {} (Ctrl-C to stop)",
        config.ros2.colour_topic, config.ros2.depth_topic
    );
    let outcome = pipeline::run(&options)?;
    outcome.profile.write_json(&args.out.join("profile.json"))?;
    let timestamps = frames_received(&state_dir.join(FRAMES_FILE))?;
    let poses = pipeline::complete_trajectory(&outcome.received, &timestamps);
    write_outputs(&args.out, &poses)?;
    if let Some(path) = &args.mcap {
        let restarts: Vec<(String, u32)> = outcome
            .restarts
            .iter()
            .map(|(stage, n)| ((*stage).to_owned(), *n))
            .collect();
        let scenes = super::run::keyframe_stamps(outcome.scenes, &timestamps);
        let details = RunDetails {
            profile: Some(&outcome.profile),
            restarts: &restarts,
            scenes: &scenes,
            frames: Some(FrameVisuals::new(
                &config,
                &outcome.views,
                ColourFrames::None,
            )?),
        };
        record_mcap(
            path,
            &config,
            &poses,
            &outcome.covariances,
            details,
            args.mcap_compression,
        )?;
    }
    let mut counts = BTreeMap::<&str, usize>::new();
    for pose in &poses {
        *counts.entry(pose.status.as_str()).or_default() += 1;
    }
    println!(
        "frames      {} received, {} with a pose from the tracker",
        timestamps.len(),
        outcome.received.len()
    );
    println!("status      {counts:?}");
    println!("trajectory  {}", args.out.join("trajectory.txt").display());
    if outcome.restarts.values().any(|n| *n > 0) {
        println!("restarts    {:?}", outcome.restarts);
    }
    print!("{}", outcome.profile.summary());
    if !outcome.leftovers.is_empty() {
        return Err(format!("files of the run left behind: {:?}", outcome.leftovers).into());
    }
    Ok(())
}

/// The driver's camera, from one CameraInfo read by `gfsvo-ros2 --probe-camera` (the
/// DDS side lives in that executable); `None`, with a warning, when none came in time.
fn probe_camera(args: &Ros2Args, config: &Path, run_id: &RunId) -> CliResult<Option<Camera>> {
    let file = args.out.join("camera-info.toml");
    let _ = std::fs::remove_file(&file);
    let exe = std::env::current_exe()?
        .parent()
        .map(|d| d.join("gfsvo-ros2"))
        .unwrap_or_default();
    eprintln!(
        "gfsvo ros2: reading the camera from its CameraInfo (up to {} s)",
        args.camera_info_timeout
    );
    let status = std::process::Command::new(&exe)
        .arg("--dataset")
        .arg(&args.out)
        .arg("--config")
        .arg(config)
        .args(["--run-id", run_id.as_str(), "--probe-camera"])
        .arg(&file)
        .arg("--probe-timeout-s")
        .arg(args.camera_info_timeout.to_string())
        .status()
        .map_err(|e| format!("cannot start {}: {e}", exe.display()))?;
    if !status.success() {
        tracing::warn!(
            "no CameraInfo: tracking with the camera of {}",
            args.config.display()
        );
        return Ok(None);
    }
    let text = std::fs::read_to_string(&file)?;
    let table: CameraConfig =
        toml::from_str(&text).map_err(|e| format!("{}: {e}", file.display()))?;
    Ok(Some(Camera::from_config(&table)?))
}

fn overrides(args: &Ros2Args) -> Vec<(&'static str, toml::Value)> {
    let mut values = Vec::new();
    let text = [
        ("colour_topic", &args.colour_topic),
        ("depth_topic", &args.depth_topic),
        ("camera_info_topic", &args.camera_info_topic),
        ("odom_topic", &args.odom_topic),
        ("tf_topic", &args.tf_topic),
        ("status_topic", &args.status_topic),
        ("odom_frame", &args.odom_frame),
        ("base_frame", &args.base_frame),
        ("when_lost", &args.when_lost),
    ];
    for (key, value) in text {
        if let Some(v) = value {
            values.push((key, toml::Value::String(v.clone())));
        }
    }
    if let Some(slop) = args.slop {
        values.push(("slop_s", toml::Value::Float(slop)));
    }
    if args.no_tf {
        values.push(("publish_tf", toml::Value::Boolean(false)));
    }
    values
}

/// The colour stamps of the frames the ROS 2 stage received, by frame id (lines
/// `id stamp`, appended by the stage; a restarted stage goes on from the last id).
fn frames_received(path: &Path) -> CliResult<Vec<Stamp>> {
    let text = match std::fs::read_to_string(path) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(format!("{}: {e}", path.display()).into()),
    };
    let mut stamps = BTreeMap::new();
    for (n, line) in text.lines().enumerate() {
        let mut parts = line.split_whitespace();
        let parsed = parts
            .next()
            .and_then(|id| id.parse::<u64>().ok())
            .zip(parts.next().and_then(|s| s.parse::<Stamp>().ok()));
        match parsed {
            Some((id, stamp)) => {
                stamps.insert(id, stamp);
            }
            None => tracing::warn!("{}:{}: not `id stamp`; skipped", path.display(), n + 1),
        }
    }
    // Ids are consecutive from 0; a gap (a line lost to a kill) keeps its neighbour's stamp.
    let Some(&last) = stamps.keys().next_back() else {
        return Ok(Vec::new());
    };
    let mut previous = stamps.values().next().copied().unwrap_or_default();
    Ok((0..=last)
        .map(|id| {
            previous = stamps.get(&id).copied().unwrap_or(previous);
            previous
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_received_are_listed_by_id_with_gaps_filled() {
        let dir = std::env::temp_dir().join(format!("gfsvo-ros2-frames-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(FRAMES_FILE);
        assert!(
            frames_received(&path).unwrap().is_empty(),
            "no file: no frame"
        );
        std::fs::write(
            &path,
            "0 10.5\n1 10.6\nnot a line\n3 1700000000.123456789\n",
        )
        .unwrap();
        let text: Vec<String> = frames_received(&path)
            .unwrap()
            .iter()
            .map(ToString::to_string)
            .collect();
        assert_eq!(
            text,
            [
                "10.500000",
                "10.600000",
                "10.600000",
                "1700000000.123456789"
            ]
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
