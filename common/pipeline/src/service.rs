//! The whole `main` of a stage executable: command line, logging, the run's topics,
//! the stage loop, and the exit code the supervisor reads.

use crate::config::Config;
use crate::stages::{StageContext, StageSettings, run_stage};
use gfs_ipc::{IpcRun, Mode, RunId, Stage, ipc};
use std::path::PathBuf;
use std::process::ExitCode;

/// The command line every stage executable takes (`gfsvo run` passes the same values
/// to all of them).
#[derive(clap::Parser, Debug)]
#[command(version)]
pub struct StageArgs {
    /// Dataset folder: the source plays it; every stage picks its config from its name
    /// unless --config is given.
    #[arg(long)]
    pub dataset: PathBuf,
    /// Config TOML (default: chosen from the dataset folder name; see configs/).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// The run id: stages of one run share it (iceoryx2 prefix `gfsvo_<run-id>_`).
    #[arg(long, env = gfs_ipc::RUN_ID_ENV)]
    pub run_id: String,
    /// How the pipeline is paced.
    #[arg(long, default_value = "lockstep", value_parser = ["lockstep", "realtime"])]
    pub mode: String,
    /// Folder for the checkpoints a restarted stage resumes from.
    #[arg(long)]
    pub state_dir: Option<PathBuf>,
    /// Play only the first N frames (source).
    #[arg(long)]
    pub frames: Option<usize>,
    /// Realtime: play at this many frames per second instead of the capture times.
    #[arg(long)]
    pub max_rate: Option<f64>,
    /// Ablation: no line features.
    #[arg(long)]
    pub no_lines: bool,
    /// Ablation: no Manhattan axes.
    #[arg(long)]
    pub no_manhattan: bool,
    /// Log filter (error, warn, info, debug, trace).
    #[arg(long, default_value = "warn", env = "GFSVO_LOG")]
    pub log: String,
}

impl StageArgs {
    /// The settings these arguments describe.
    ///
    /// # Errors
    /// [`crate::ConfigError`] when the config cannot be loaded.
    pub fn settings(&self) -> Result<StageSettings, crate::ConfigError> {
        let mut config = Config::load(self.config.as_deref(), &self.dataset)?;
        config.tracking.use_lines &= !self.no_lines;
        config.tracking.use_manhattan &= !self.no_manhattan;
        Ok(StageSettings {
            config,
            mode: if self.mode == "realtime" {
                Mode::Realtime
            } else {
                Mode::Lockstep
            },
            state_dir: self.state_dir.clone(),
            dataset: self.dataset.clone(),
            frames: self.frames,
            max_rate: self.max_rate,
        })
    }
}

/// Parses the command line and runs `stage` as a process until SIGINT / SIGTERM.
/// Returns failure (after printing the error) when the stage cannot run, so that the
/// supervisor restarts it.
pub fn service_main(stage: Stage) -> ExitCode {
    let args = <StageArgs as clap::Parser>::parse();
    let filter = tracing_subscriber::EnvFilter::try_new(&args.log)
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn"));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .init();
    match run(stage, &args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("gfsvo-{}: error: {e}", stage.name());
            ExitCode::FAILURE
        }
    }
}

fn run(stage: Stage, args: &StageArgs) -> Result<(), Box<dyn std::error::Error>> {
    let settings = args.settings()?;
    let run = IpcRun::new(RunId::new(&args.run_id)?)?;
    let ctx = StageContext::<ipc::Service>::process(run, stage, settings)?;
    tracing::debug!(stage = stage.name(), "started");
    run_stage(stage, &ctx)?;
    tracing::debug!(stage = stage.name(), "stopped");
    Ok(())
}
