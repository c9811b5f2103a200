//! `gfsvo bench lines` (being written).

use super::BenchArgs;
use crate::CliResult;

/// Runs the lines benchmark.
pub fn run(_args: &BenchArgs) -> CliResult {
    Err("gfsvo bench lines is not built yet".into())
}
