//! `gfsvo bench planes` (being written).

use super::BenchArgs;
use crate::CliResult;

/// Runs the planes benchmark.
pub fn run(_args: &BenchArgs) -> CliResult {
    Err("gfsvo bench planes is not built yet".into())
}
