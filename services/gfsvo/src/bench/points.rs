//! `gfsvo bench points` (being written).

use super::BenchArgs;
use crate::CliResult;

/// Runs the points benchmark.
pub fn run(_args: &BenchArgs) -> CliResult {
    Err("gfsvo bench points is not built yet".into())
}
