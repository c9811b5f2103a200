//! The whole `main` of a stage executable: command line, logging, the run's topics,
//! the stage loop, and the exit code the supervisor reads.

use crate::config::Config;
use crate::map_files::MapFiles;
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
    /// Start at frame N of the dataset, which becomes the run's frame 0 (source).
    #[arg(long, default_value_t = 0)]
    pub start: usize,
    /// Play only N frames from --start (source).
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
    /// Ablation: no loop closing.
    #[arg(long)]
    pub no_loop_closing: bool,
    /// Map files (the mapper and the tracker start on a loaded map, the mapper saves).
    #[command(flatten)]
    pub map_files: MapFiles,
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
        config.loop_closing.enabled &= !self.no_loop_closing;
        Ok(StageSettings {
            config,
            mode: if self.mode == "realtime" {
                Mode::Realtime
            } else {
                Mode::Lockstep
            },
            state_dir: self.state_dir.clone(),
            dataset: self.dataset.clone(),
            start: self.start,
            frames: self.frames,
            max_rate: self.max_rate,
            map_files: self.map_files.clone(),
        })
    }
}

/// Parses the command line and runs `stage` as a process until SIGINT / SIGTERM.
/// Returns failure (after printing the error) when the stage cannot run, so that the
/// supervisor restarts it.
pub fn service_main(stage: Stage) -> ExitCode {
    let args = <StageArgs as clap::Parser>::parse();
    let filter = log_filter(&args.log).unwrap_or_else(|e| {
        eprintln!("gfsvo-{}: {e}; logging warnings", stage.name());
        tracing_subscriber::EnvFilter::new("warn")
    });
    init_logging(filter);
    match run(stage, &args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("gfsvo-{}: error: {e}", stage.name());
            ExitCode::FAILURE
        }
    }
}

/// Logs to stderr through `filter`, in colour only on a terminal (the same for every
/// stage executable).
pub fn init_logging(filter: tracing_subscriber::EnvFilter) {
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .with_writer(std::io::stderr)
        .init();
}

/// The log filter of `--log`: a level (`error`, `warn`, `info`, `debug`, `trace`, `off`)
/// or comma-separated `target=level` directives. A bare word that is not a level would
/// be read by `tracing` as a target and hide every other message, so it is an error.
///
/// # Errors
/// Naming the directive that is neither.
pub fn log_filter(text: &str) -> Result<tracing_subscriber::EnvFilter, String> {
    const LEVELS: [&str; 6] = ["error", "warn", "info", "debug", "trace", "off"];
    let invalid = |why: String| {
        format!(
            "--log {text:?}: {why}; expected a level (error, warn, info, debug, trace, off) or target=level directives"
        )
    };
    for directive in text.split(',').map(str::trim) {
        let level = directive.rsplit_once('=').map_or(directive, |(_, l)| l);
        if !LEVELS.contains(&level.to_ascii_lowercase().as_str()) {
            return Err(invalid(format!("{directive:?} names no level")));
        }
    }
    tracing_subscriber::EnvFilter::try_new(text).map_err(|e| invalid(e.to_string()))
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

#[cfg(test)]
mod tests {
    use super::log_filter;

    #[test]
    fn a_log_filter_without_a_level_is_an_error() {
        for good in [
            "warn",
            "INFO",
            "gfs_odometry=debug",
            "warn,gfs_pipeline=trace",
        ] {
            assert!(log_filter(good).is_ok(), "{good}");
        }
        for bad in ["nonsense", "", "warn,oops", "gfs_odometry=loud"] {
            let e = log_filter(bad).unwrap_err();
            assert!(e.contains("--log") && e.contains("expected a level"), "{e}");
        }
    }
}
