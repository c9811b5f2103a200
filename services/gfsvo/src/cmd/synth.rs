//! `gfsvo synth` (being written).

use crate::CliResult;

/// Arguments of `gfsvo synth`.
#[derive(clap::Args)]
pub struct SynthArgs {}

/// Runs `gfsvo synth`.
pub fn run(_args: &SynthArgs) -> CliResult {
    Err("gfsvo synth is not built yet".into())
}
