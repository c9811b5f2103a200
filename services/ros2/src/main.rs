//! `gfsvo-ros2`: the ROS 2 stage of the GFS-VO pipeline. In the source's place, it
//! subscribes to a camera driver's colour, depth and camera-info topics over DDS, pairs
//! colour and depth by stamp and publishes each pair into the frame topic; it turns the
//! tracker's poses into `/odom`, `/tf` and the status. Run by `gfsvo ros2` (which
//! restarts it like any stage) or as a systemd service; `--help` lists the arguments.

mod dds;
mod stage;

use gfs_pipeline::service::StageArgs;
use std::process::ExitCode;

fn main() -> ExitCode {
    let args = <StageArgs as clap::Parser>::parse();
    // RustDDS is noisy below error (harmless loopback and fragment messages).
    let filter = format!("{},rustdds=error,ros2_client=error", args.log);
    let filter = tracing_subscriber::EnvFilter::try_new(filter)
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn"));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .init();
    match stage::run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("gfsvo-ros2: error: {e}");
            ExitCode::FAILURE
        }
    }
}
