//! `gfsvo record --run-id ID`: the recorder of a pipeline whose stages run on their own
//! (as systemd services): writes the poses and the stage profile of run ID until
//! SIGINT / SIGTERM, refreshing the files every few seconds.

use crate::CliResult;
use crate::cmd::run::write_outputs;
use crate::pipeline::{Recorder, signals};
use gfs_ipc::{IpcRun, Mode, RunId, ipc};
use gfs_odometry::FramePose;
use iceoryx2::node::Node;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The files are rewritten this often, so that a killed recorder loses little.
const FLUSH_EVERY: Duration = Duration::from_secs(5);

/// Arguments of `gfsvo record`.
#[derive(clap::Args)]
pub struct RecordArgs {
    /// The run id of the stages (their `--run-id` / `GFSVO_IPC_RUN`).
    #[arg(long, env = gfs_ipc::RUN_ID_ENV)]
    pub run_id: String,
    /// The stages' mode (it sizes the topics' queues: both ends must agree).
    #[arg(long, default_value = "realtime", value_parser = ["lockstep", "realtime"])]
    pub mode: String,
    /// Output folder for trajectory.txt, status.txt and profile.json.
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
}

/// Records until interrupted.
pub fn run(args: &RecordArgs) -> CliResult {
    signals::install();
    let _out_lock = crate::cmd::run::checks::lock_out(&args.out)?;
    let mode = if args.mode == "lockstep" {
        Mode::Lockstep
    } else {
        Mode::Realtime
    };
    let run = IpcRun::new(RunId::new(&args.run_id)?)?;
    let node = run.node::<ipc::Service>("recorder")?;
    let result = record(&run, &node, mode, args);
    drop(node);
    // The stages may still run (they are services): their files stay with them.
    if let Err(e) = run.remove_if_unused() {
        tracing::warn!("cleaning up after the recorder: {e}");
    }
    result
}

fn record(run: &IpcRun, node: &Node<ipc::Service>, mode: Mode, args: &RecordArgs) -> CliResult {
    let mut recorder = Recorder::new(run, node, mode, &args.mode)?;
    tracing::info!(run = args.run_id, "recording poses until SIGINT / SIGTERM");
    let mut flushed = Instant::now();
    while !signals::interrupted() {
        recorder.drain()?;
        if flushed.elapsed() > FLUSH_EVERY {
            write(&recorder, &args.out)?;
            flushed = Instant::now();
        }
        recorder.wait(Duration::from_millis(50))?;
    }
    recorder.drain()?;
    write(&recorder, &args.out)?;
    println!(
        "{} poses of run {} in {}",
        recorder.len(),
        args.run_id,
        args.out.display()
    );
    Ok(())
}

fn write(recorder: &Recorder<ipc::Service>, out: &Path) -> CliResult {
    let poses: Vec<FramePose> = recorder.poses().values().copied().collect();
    write_outputs(out, &poses)?;
    recorder.profile().write_json(&out.join("profile.json"))?;
    Ok(())
}
