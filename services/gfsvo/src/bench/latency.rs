//! `gfsvo bench latency DATASET [--rate HZ] [--busy N]`: the pipeline in realtime, as a
//! robot runs it, with N busy-looping competitor processes, and the figures a
//! controller cares about: end-to-end latency (frame published -> pose out) median /
//! p90 / p99 / max, frames dropped, and the ATE.
//!
//! Each run is `gfsvo run DATASET --mode realtime --json` (this executable again, so
//! what is measured is exactly what a user runs); the competitors are this executable
//! again with the hidden `--busy-loop`, one core each at the default priority, started
//! before the run and killed after it. Both die with this process (parent-death signal).

use crate::CliResult;
use clap::Args;
use serde::Deserialize;
use std::ffi::OsString;
use std::os::unix::process::CommandExt;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};

/// Arguments of `gfsvo bench latency`.
#[derive(Args)]
pub struct LatencyArgs {
    /// Dataset folder in TUM RGB-D layout (required unless --busy-loop).
    #[arg(required_unless_present = "busy_loop")]
    pub dataset: Option<PathBuf>,
    /// Config TOML (default: chosen from the dataset folder name).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Play at this many frames per second (default: the capture times).
    #[arg(long)]
    pub rate: Option<f64>,
    /// Busy-looping competitor processes running during the measurement.
    #[arg(long, default_value_t = 0)]
    pub busy: usize,
    /// Runs to measure, one table row (or JSON object) each.
    #[arg(long, default_value_t = 1)]
    pub runs: usize,
    /// Process only the first N frames.
    #[arg(long)]
    pub frames: Option<usize>,
    /// Folder of the runs' outputs (run k in DIR/k).
    #[arg(long, default_value = "out/bench-latency")]
    pub out: PathBuf,
    /// Print one JSON object per run instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Internal: be a competitor process (spin until killed).
    #[arg(long, hide = true)]
    pub busy_loop: bool,
}

/// What `gfsvo run --json` prints that this benchmark reads.
#[derive(Deserialize)]
struct RunSummary {
    frames: usize,
    processed: usize,
    #[serde(default)]
    status: std::collections::BTreeMap<String, usize>,
    ate_rmse_m: Option<f64>,
    profile: ProfileJson,
}

#[derive(Deserialize)]
struct ProfileJson {
    end_to_end: gfs_ipc::profile::Quantiles,
}

/// Runs the benchmark (or, with `--busy-loop`, spins forever).
pub fn run(args: &LatencyArgs) -> CliResult {
    if args.busy_loop {
        spin();
    }
    let Some(dataset) = &args.dataset else {
        return Err("bench latency: a dataset folder is required".into());
    };
    if args.rate.is_some_and(|r| !(r.is_finite() && r > 0.0)) {
        return Err("bench latency: --rate must be a positive number of frames per second".into());
    }
    if args.runs == 0 {
        return Err("bench latency: --runs must be at least 1".into());
    }
    let exe = std::env::current_exe()?;
    let mut competitors = Competitors::start(&exe, args.busy)?;
    let mut rows = Vec::new();
    for k in 0..args.runs {
        let out = args.out.join(k.to_string());
        let summary = measure(&exe, dataset, &out, args)?;
        if args.json {
            print_json(&summary, args, &out)?;
        }
        rows.push(summary);
    }
    competitors.stop();
    if !args.json {
        print_table(&rows, args);
    }
    Ok(())
}

fn spin() -> ! {
    let mut x = 0u64;
    loop {
        x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
    }
}

/// The busy-looping processes; killed when dropped.
struct Competitors(Vec<Child>);

impl Competitors {
    fn start(exe: &PathBuf, n: usize) -> CliResult<Self> {
        let mut children = Self(Vec::with_capacity(n));
        for _ in 0..n {
            let mut command = Command::new(exe);
            command
                .args(["bench", "latency", "--busy-loop"])
                .stdin(Stdio::null())
                .stdout(Stdio::null());
            die_with_parent(&mut command);
            children.0.push(command.spawn()?);
        }
        Ok(children)
    }

    fn stop(&mut self) {
        for child in &mut self.0 {
            let _ = child.kill();
            let _ = child.wait();
        }
        self.0.clear();
    }
}

impl Drop for Competitors {
    fn drop(&mut self) {
        self.stop();
    }
}

fn die_with_parent(command: &mut Command) {
    // SAFETY: prctl is async-signal-safe; nothing else runs between fork and exec.
    unsafe {
        command.pre_exec(|| {
            libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL);
            Ok(())
        });
    }
}

fn measure(
    exe: &PathBuf,
    dataset: &PathBuf,
    out: &PathBuf,
    args: &LatencyArgs,
) -> CliResult<RunSummary> {
    let mut run_args: Vec<OsString> = vec![
        "run".into(),
        dataset.into(),
        "--mode".into(),
        "realtime".into(),
        "--json".into(),
        "--out".into(),
        out.into(),
    ];
    if let Some(rate) = args.rate {
        run_args.extend(["--max-rate".into(), rate.to_string().into()]);
    }
    if let Some(config) = &args.config {
        run_args.extend(["--config".into(), config.into()]);
    }
    if let Some(frames) = args.frames {
        run_args.extend(["--frames".into(), frames.to_string().into()]);
    }
    let mut command = Command::new(exe);
    command.args(&run_args).stdin(Stdio::null());
    die_with_parent(&mut command);
    let output = command.output()?;
    if !output.status.success() {
        return Err(format!(
            "bench latency: `gfsvo run` on {} failed ({}): {}",
            dataset.display(),
            output.status,
            String::from_utf8_lossy(&output.stderr).trim()
        )
        .into());
    }
    let stdout = String::from_utf8_lossy(&output.stdout);
    let line = stdout.lines().last().unwrap_or_default();
    serde_json::from_str(line).map_err(|e| {
        format!("bench latency: cannot read the summary of `gfsvo run` ({e}): {line}").into()
    })
}

fn print_json(s: &RunSummary, args: &LatencyArgs, out: &std::path::Path) -> CliResult {
    let object = serde_json::json!({
        "out": out.display().to_string(),
        "rate_hz": args.rate,
        "busy": args.busy,
        "frames": s.frames,
        "dropped": s.frames - s.processed.min(s.frames),
        "status": s.status,
        "end_to_end_ms": s.profile.end_to_end,
        "ate_rmse_m": s.ate_rmse_m,
    });
    println!("{object}");
    Ok(())
}

fn print_table(rows: &[RunSummary], args: &LatencyArgs) {
    let rate = args
        .rate
        .map_or_else(|| "capture rate".to_owned(), |r| format!("{r} Hz"));
    println!(
        "realtime at {rate}, {} busy competitor process(es); end-to-end = frame published -> pose out",
        args.busy
    );
    println!(
        "{:>4} {:>7} {:>8} {:>9} | {:>8} {:>8} {:>8} {:>8} | {:>9}",
        "run", "frames", "dropped", "tracked", "median", "p90", "p99", "max", "ATE (m)"
    );
    for (k, s) in rows.iter().enumerate() {
        let e = &s.profile.end_to_end;
        let tracked = s.status.get("tracked").copied().unwrap_or(0);
        let ate = s
            .ate_rmse_m
            .map_or_else(|| "-".to_owned(), |a| format!("{a:.4}"));
        println!(
            "{k:>4} {:>7} {:>8} {tracked:>9} | {:>8.2} {:>8.2} {:>8.2} {:>8.2} | {ate:>9}",
            s.frames,
            s.frames - s.processed.min(s.frames),
            e.median_ms,
            e.p90_ms,
            e.p99_ms,
            e.max_ms,
        );
    }
}
