//! `gfsvo eval` (being written).

use crate::CliResult;

/// Arguments of `gfsvo eval`.
#[derive(clap::Args)]
pub struct EvalArgs {}

/// Runs `gfsvo eval`.
pub fn run(_args: &EvalArgs) -> CliResult {
    Err("gfsvo eval is not built yet".into())
}
