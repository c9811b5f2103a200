//! `gfsvo`: the command users type. Each subcommand is a thin layer over the library
//! crates in `common/`; `main` calls one fallible function, prints the error once and
//! turns it into the exit code.

mod bench;
mod cmd;
mod pipeline;
use gfs_pipeline::config;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Errors of the command line: every library error converts into this.
pub type CliError = Box<dyn std::error::Error + Send + Sync>;
/// Result of a subcommand.
pub type CliResult<T = ()> = Result<T, CliError>;

/// GFS-VO: grid-based fast and structural RGB-D visual odometry.
///
/// Datasets are folders in TUM RGB-D layout (rgb.txt, depth.txt, optional
/// associations.txt and groundtruth.txt). The camera config is chosen from the folder
/// name (fr1/fr2/fr3, 7scenes, icl, synthetic) unless --config names a TOML file; see
/// the files in configs/ for every parameter.
#[derive(Parser)]
#[command(name = "gfsvo", version, about, long_about)]
struct Cli {
    /// Log level filter (error, warn, info, debug, trace), or a tracing filter string.
    #[arg(long, global = true, default_value = "info", env = "GFSVO_LOG")]
    log: String,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run the odometry on a dataset folder (default: the built-in synthetic sequence):
    /// writes trajectory.txt and status.txt, prints the ATE and the time per stage.
    Run(cmd::run::RunArgs),
    /// Write a dataset folder as a ROS 2 bag (MCAP, CDR) on an RGB-D driver's topics.
    Convert(cmd::convert::ConvertArgs),
    /// Compare an estimated trajectory with ground truth: ATE and RPE, as evo computes them.
    Eval(cmd::eval::EvalArgs),
    /// Render a synthetic RGB-D sequence with ground truth in TUM layout.
    Synth(cmd::synth::SynthArgs),
    /// Time one front-end stage over the frames of a dataset (medians over real frames).
    #[command(subcommand)]
    Bench(bench::BenchCommand),
    /// Per-stage timing table (median / p90 / p99 / max) of a pipeline run's profile.json
    /// and a PNG of each stage's processing time over the frames.
    Profile(cmd::profile::ProfileArgs),
    /// Record the poses and stage profile of a pipeline whose stages run as services
    /// (systemd): trajectory.txt, status.txt, profile.json, until SIGINT / SIGTERM.
    Record(cmd::record::RecordArgs),
    /// Remove what dead runs left in /dev/shm and /tmp/iceoryx2 (never a live run's files).
    Clean(cmd::clean::CleanArgs),
    /// The pipeline on a live ROS 2 camera (realtime): subscribes to colour, depth and
    /// camera info, publishes /odom, /tf and the status, until SIGINT / SIGTERM; then
    /// writes trajectory.txt, status.txt and profile.json.
    Ros2(cmd::ros2::Ros2Args),
    /// Place recognition: build the bag-of-words vocabulary from rendered scenes or
    /// datasets, and measure keyframe retrieval with it on a dataset with ground truth.
    #[command(subcommand)]
    Vocab(cmd::vocab::VocabCommand),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    if let Err(e) = init_logging(&cli.log) {
        eprintln!("error: {e}");
        return ExitCode::FAILURE;
    }
    let result = match &cli.command {
        Command::Run(args) => cmd::run::run(args, &cli.log),
        Command::Convert(args) => cmd::convert::run(args),
        Command::Eval(args) => cmd::eval::run(args),
        Command::Synth(args) => cmd::synth::run(args),
        Command::Bench(command) => bench::run(command),
        Command::Profile(args) => cmd::profile::run(args),
        Command::Record(args) => cmd::record::run(args),
        Command::Clean(args) => cmd::clean::run(args),
        Command::Ros2(args) => cmd::ros2::run(args, &cli.log),
        Command::Vocab(command) => cmd::vocab::run(command),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprint!("{}", error_report(e.as_ref()));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes, one per line; a cause whose text the line above already
/// holds (errors that print their source) is not repeated.
fn error_report(e: &(dyn std::error::Error + 'static)) -> String {
    let mut out = format!("error: {e}\n");
    let mut above = e.to_string();
    let mut source = e.source();
    while let Some(cause) = source {
        let text = cause.to_string();
        if !above.contains(&text) {
            out.push_str(&format!("  caused by: {text}\n"));
        }
        above = text;
        source = cause.source();
    }
    out
}

/// Logging to stderr, coloured only on a terminal.
///
/// # Errors
/// When `filter` is neither a level nor `target=level` directives.
fn init_logging(filter: &str) -> CliResult {
    let filter = gfs_pipeline::service::log_filter(filter)?;
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .with_writer(std::io::stderr)
        .init();
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, thiserror::Error)]
    #[error("cannot read x.toml: {0}")]
    struct Outer(#[source] std::io::Error);

    #[derive(Debug, thiserror::Error)]
    #[error("run failed")]
    struct Top(#[source] Outer);

    #[test]
    fn a_cause_the_line_above_already_says_is_not_repeated() {
        let io = || std::io::Error::other("disk on fire");
        let report = error_report(&Outer(io()));
        assert_eq!(report, "error: cannot read x.toml: disk on fire\n");
        let report = error_report(&Top(Outer(io())));
        assert_eq!(
            report,
            "error: run failed\n  caused by: cannot read x.toml: disk on fire\n"
        );
    }
}
