//! Subcommands other than the benchmarks.

pub mod eval;
pub mod synth;
