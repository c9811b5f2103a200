//! `gfsvo clean`: removes what dead runs left in `/dev/shm` and `/tmp/iceoryx2` (a
//! SIGKILLed supervisor, a stage killed while it started), never anything of a live run.

use crate::CliResult;

/// Arguments of `gfsvo clean`.
#[derive(clap::Args)]
pub struct CleanArgs {
    /// Also list the runs left alone, and why.
    #[arg(long)]
    pub verbose: bool,
}

/// Sweeps the dead runs and says what it did.
pub fn run(args: &CleanArgs) -> CliResult {
    let report = gfs_ipc::sweep_dead_runs();
    for (id, files) in &report.removed {
        println!("removed run {id}: {files} files");
    }
    if args.verbose {
        for (id, why) in &report.live {
            println!("kept run {id}: {why}");
        }
    }
    println!(
        "{} dead runs removed, {} live runs kept",
        report.removed.len(),
        report.live.len()
    );
    Ok(())
}
