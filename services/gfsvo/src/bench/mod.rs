//! `gfsvo bench STAGE DATASET`: per-step timings of one front-end stage over real frames,
//! single-threaded, printed as medians / p90 (and as one JSON object with `--json`);
//! `bench transport` and `bench latency` time the pipeline's plumbing and whole;
//! `bench bag` what playing a ROS 2 bag costs.

mod bag;
mod latency;
mod lines;
mod planes;
mod points;
pub mod stats;
mod transport;

use crate::CliResult;
use clap::{Args, Subcommand};
use std::path::PathBuf;

/// The stage to time.
#[derive(Subcommand)]
pub enum BenchCommand {
    /// ORB: pyramid, FAST + quadtree distribution, orientation + descriptors.
    Points(BenchArgs),
    /// Lines: EDLines detection, joining, LBD, grid + homogenisation, 3D lines.
    Lines(BenchArgs),
    /// Planes: pixel normals, BFS plane extraction, Manhattan axes.
    Planes(BenchArgs),
    /// Playing a ROS 2 bag (BAG in place of DATASET): reading with chunk decompression,
    /// decoding compressed images, converting to gray and metres, per frame.
    Bag(BenchArgs),
    /// Transport latency of a 640x480 RGB-D frame between two processes over iceoryx2
    /// (median / p90 / p99 / max in µs); needs no dataset.
    Transport(transport::TransportArgs),
    /// The pipeline in realtime with N busy competitor processes: end-to-end latency
    /// (frame published -> pose out) median / p90 / p99 / max, frames dropped, ATE.
    Latency(latency::LatencyArgs),
}

/// Arguments shared by every benchmark.
#[derive(Args)]
pub struct BenchArgs {
    /// Dataset folder in TUM RGB-D layout.
    pub dataset: PathBuf,
    /// Config TOML (default: chosen from the dataset folder name).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Number of frames to time (default: all).
    #[arg(long)]
    pub frames: Option<usize>,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
    /// `bench lines`: draw the lines of frame --image-frame into this PNG (before
    /// homogenisation on the left, after on the right).
    #[arg(long)]
    pub image_out: Option<PathBuf>,
    /// `bench lines`: the frame (0-based) drawn by --image-out.
    #[arg(long, default_value_t = 0)]
    pub image_frame: usize,
}

/// Runs one benchmark.
pub fn run(command: &BenchCommand) -> CliResult {
    match command {
        BenchCommand::Points(args) => points::run(args),
        BenchCommand::Lines(args) => lines::run(args),
        BenchCommand::Planes(args) => planes::run(args),
        BenchCommand::Bag(args) => bag::run(args),
        BenchCommand::Transport(args) => transport::run(args),
        BenchCommand::Latency(args) => latency::run(args),
    }
}
