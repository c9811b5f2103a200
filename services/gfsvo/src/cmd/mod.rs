//! Subcommands other than the benchmarks.

pub mod clean;
pub mod convert;
pub mod eval;
pub mod frame_visuals;
pub mod profile;
pub mod record;
pub mod ros2;
pub mod ros2_io;
pub mod run;
pub mod synth;
pub mod vocab;
