//! `gfsvo-ros2`: the ROS 2 stage of the GFS-VO pipeline. In the source's place, it
//! subscribes to a camera driver's colour, depth and camera-info topics over DDS, pairs
//! colour and depth by stamp and publishes each pair into the frame topic; it turns the
//! tracker's poses into `/odom`, `/tf` and the status. Run by `gfsvo ros2` (which
//! restarts it like any stage) or as a systemd service; `--help` lists the arguments.

mod dds;
mod map_saves;
mod requests;
mod stage;
mod visuals;

use gfs_pipeline::service::StageArgs;
use std::path::PathBuf;
use std::process::ExitCode;

/// The stage's command line: every stage's, and the camera probe `gfsvo ros2` runs
/// before it starts the stages.
#[derive(clap::Parser, Debug)]
#[command(version)]
struct Args {
    #[command(flatten)]
    stage: StageArgs,
    /// Instead of running the stage: wait for one CameraInfo, write its camera as the
    /// `[camera]` TOML table into this file, and exit.
    #[arg(long)]
    probe_camera: Option<PathBuf>,
    /// How long the probe waits for a CameraInfo, seconds.
    #[arg(long, default_value_t = 10.0)]
    probe_timeout_s: f64,
}

fn main() -> ExitCode {
    let Args {
        stage: args,
        probe_camera,
        probe_timeout_s,
    } = <Args as clap::Parser>::parse();
    // RustDDS is noisy below error (harmless loopback and fragment messages): its `log`
    // records reach `tracing` from error up, unless the filter names it.
    let dds_named = args.log.contains("rustdds") || args.log.contains("ros2_client");
    let level = if dds_named {
        tracing_log::log::LevelFilter::Trace
    } else {
        tracing_log::log::LevelFilter::Error
    };
    if let Err(e) = tracing_log::LogTracer::init_with_filter(level) {
        eprintln!("gfsvo-ros2: DDS logs are not shown: {e}");
    }
    let filter =
        gfs_pipeline::service::log_filter(&format!("rustdds=error,ros2_client=error,{}", args.log))
            .unwrap_or_else(|e| {
                eprintln!("gfsvo-ros2: {e}; logging warnings");
                tracing_subscriber::EnvFilter::new("warn")
            });
    gfs_pipeline::service::init_logging(filter);
    let result = match &probe_camera {
        Some(path) => stage::probe_camera(&args, path, probe_timeout_s),
        None => stage::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("gfsvo-ros2: error: {e}");
            ExitCode::FAILURE
        }
    }
}
