//! `gfsvo eval`: ATE and RPE of an estimated trajectory against ground truth, with the
//! definitions of the evo tools; a table, a JSON object and a PNG plot.

use crate::CliResult;
use gfs_dataset::{EVO_MAX_DIFF_S, Evaluation, Stats, Trajectory, evaluate};
use gfs_plot::{PlotConfig, write_evaluation_png};
use serde_json::json;
use std::path::PathBuf;

/// What `gfsvo eval` computes, printed under `--help`.
const ABOUT_METRICS: &str = "\
Both files are TUM trajectories (`timestamp tx ty tz qx qy qz qw`, camera-to-world).
Poses are associated by timestamp (for each pose of the sparser file, the closest pose
of the other within --max-diff, as evo does), then:
  ATE            position error after SE(3) Umeyama alignment of the estimate onto the
                 ground truth, no scale (= evo_ape tum GT EST --align)
  RPE / frame    relative pose error between consecutive matched poses, translation m
                 and rotation deg (= evo_rpe tum GT EST, delta 1 frame)
  RPE / second   the same over matched poses about 1 s apart
                 (= TUM evaluate_rpe.py --fixed_delta --delta 1 --delta_unit s)

Example:
  gfsvo eval --gt data/fr1_rpy/groundtruth.txt --est traj.txt --plot eval.png";

/// Arguments of `gfsvo eval`.
#[derive(clap::Args)]
#[command(after_help = ABOUT_METRICS)]
pub struct EvalArgs {
    /// Ground-truth trajectory (TUM format).
    #[arg(long)]
    pub gt: PathBuf,
    /// Estimated trajectory (TUM format).
    #[arg(long)]
    pub est: PathBuf,
    /// Write a PNG: top view of both trajectories after alignment, and ATE over time.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Largest timestamp difference of an associated pair, s (evo's default 0.01).
    #[arg(long, default_value_t = EVO_MAX_DIFF_S)]
    pub max_diff: f64,
}

/// Runs `gfsvo eval`.
pub fn run(args: &EvalArgs) -> CliResult {
    if !(args.max_diff.is_finite() && args.max_diff >= 0.0) {
        return Err(format!(
            "--max-diff must be a non-negative number, got {}",
            args.max_diff
        )
        .into());
    }
    let gt = Trajectory::read_tum(&args.gt)?;
    let est = Trajectory::read_tum(&args.est)?;
    let eval = evaluate(&gt, &est, args.max_diff)?;
    if let Some(path) = &args.plot {
        write_evaluation_png(&eval, path, &PlotConfig::default())?;
        tracing::info!("plot written to {}", path.display());
    }
    if args.json {
        println!("{}", to_json(&eval));
    } else {
        print_table(&eval);
    }
    Ok(())
}

fn to_json(eval: &Evaluation) -> serde_json::Value {
    let a = &eval.ate.stats;
    let frame = eval.rpe_frame.as_ref();
    let second = eval.rpe_second.as_ref();
    json!({
        "matched": eval.matched(),
        "gt_poses": eval.gt_poses,
        "est_poses": eval.est_poses,
        "max_diff_s": eval.max_diff,
        "ate_rmse_m": a.rmse,
        "ate_mean_m": a.mean,
        "ate_median_m": a.median,
        "ate_std_m": a.std,
        "ate_min_m": a.min,
        "ate_max_m": a.max,
        "rpe_trans_rmse_m": frame.map(|r| r.trans_m.rmse),
        "rpe_trans_mean_m": frame.map(|r| r.trans_m.mean),
        "rpe_trans_max_m": frame.map(|r| r.trans_m.max),
        "rpe_rot_rmse_deg": frame.map(|r| r.rot_deg.rmse),
        "rpe_rot_mean_deg": frame.map(|r| r.rot_deg.mean),
        "rpe_rot_max_deg": frame.map(|r| r.rot_deg.max),
        "rpe_1s_pairs": second.map_or(0, |r| r.pairs.len()),
        "rpe_1s_trans_rmse_m": second.map(|r| r.trans_m.rmse),
        "rpe_1s_rot_rmse_deg": second.map(|r| r.rot_deg.rmse),
    })
}

fn row(name: &str, unit: &str, s: Option<&Stats>) {
    match s {
        Some(s) => println!(
            "{name:<24} {:>10.6} {:>10.6} {:>10.6} {:>10.6} {:>10.6}  {unit}",
            s.rmse, s.mean, s.median, s.std, s.max
        ),
        None => println!("{name:<24} {:>10}  (too few matched poses)", "-"),
    }
}

fn print_table(eval: &Evaluation) {
    println!(
        "poses matched: {} (ground truth {}, estimate {}, max diff {} s)",
        eval.matched(),
        eval.gt_poses,
        eval.est_poses,
        eval.max_diff
    );
    println!(
        "{:<24} {:>10} {:>10} {:>10} {:>10} {:>10}",
        "", "rmse", "mean", "median", "std", "max"
    );
    row("ATE (aligned)", "m", Some(&eval.ate.stats));
    let frame = eval.rpe_frame.as_ref();
    row("RPE trans / frame", "m", frame.map(|r| &r.trans_m));
    row("RPE rot / frame", "deg", frame.map(|r| &r.rot_deg));
    let second = eval.rpe_second.as_ref();
    row("RPE trans / second", "m", second.map(|r| &r.trans_m));
    row("RPE rot / second", "deg", second.map(|r| &r.rot_deg));
}
