//! Subcommands other than the benchmarks.

pub mod clean;
pub mod eval;
pub mod profile;
pub mod record;
pub mod run;
pub mod synth;
