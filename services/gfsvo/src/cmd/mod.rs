//! Subcommands other than the benchmarks.

pub mod eval;
pub mod profile;
pub mod record;
pub mod run;
pub mod synth;
