//! `gfsvo eval`: ATE and RPE of an estimated trajectory against ground truth, with the
//! definitions of the evo tools, and the consistency of its covariances (NEES); a
//! table, a JSON object and a PNG plot.

use crate::CliResult;
use gfs_dataset::plot::{PlotConfig, write_evaluation_png};
use gfs_dataset::{
    CHI2_6DOF_999, Consistency, Covariances, EVO_MAX_DIFF_S, Evaluation, Stats, Trajectory,
    consistency, evaluate,
};
use serde_json::json;
use std::path::{Path, PathBuf};

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

With --consistency, the covariances of the estimated poses (`covariance.txt` of
`gfsvo run`, beside --est unless a FILE is given: `timestamp c11 ... c66`, each
pose's 6x6 covariance row by row over its error e = (x y z rx ry rz) in the camera's
axes, true T_wc = T_wc exp(e), the order of ROS's pose.covariance) are checked
against the actual error of every frame-to-frame motion:
  motion         M = A^-1 B for consecutive estimated poses A, B (camera to world)
                 whose ground truth G0, G1 was matched; G = G0^-1 G1
  its error      d = log(M^-1 G), in B's axes
  its covariance S = Cb + Ad(M^-1) Ca Ad(M^-1)^T from the two poses' covariances
                 Ca, Cb taken as independent (first order)
  NEES           d^T S^-1 d: chi-square with 6 degrees of freedom when consistent,
                 mean 6, 0.1 % of the pairs beyond 22.46 (the 99.9 % bound);
                 a pair with a pose without covariance (predicted) has no NEES
  f2f trans      median |translation of M^-1 G| over all pairs, m
  reported sigma median sqrt(trace of S's translation block), m

Examples:
  gfsvo eval --gt data/fr1_rpy/groundtruth.txt --est traj.txt --plot eval.png
  gfsvo eval --gt groundtruth.txt --est out/odometry.txt --consistency";

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
    /// Also the consistency of the covariances (NEES of each frame-to-frame motion, see
    /// below), from FILE or the covariance.txt beside --est.
    #[arg(long, value_name = "FILE")]
    pub consistency: Option<Option<PathBuf>>,
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
    let consistency = match &args.consistency {
        None => None,
        Some(file) => {
            let path = file.clone().unwrap_or_else(|| {
                args.est
                    .parent()
                    .unwrap_or_else(|| Path::new("."))
                    .join("covariance.txt")
            });
            let covariances = Covariances::read(&path)?;
            Some(consistency(&gt, &est, &covariances, args.max_diff))
        }
    };
    if let Some(path) = &args.plot {
        write_evaluation_png(&eval, path, &PlotConfig::default())?;
        tracing::info!("plot written to {}", path.display());
    }
    if args.json {
        let mut object = to_json(&eval);
        if let Some(c) = &consistency {
            object["nees"] = consistency_json(c);
        }
        println!("{object}");
    } else {
        print_table(&eval);
        if let Some(c) = &consistency {
            print_consistency(c);
        }
    }
    Ok(())
}

/// The consistency figures as a JSON object (`gfsvo eval --json`, `gfsvo run --json`).
pub fn consistency_json(c: &Consistency) -> serde_json::Value {
    json!({
        "pairs": c.pairs,
        "pairs_with_covariance": c.nees.len(),
        "mean": c.mean_nees,
        "beyond_999": c.beyond_bound,
        "f2f_trans_median_m": c.median_translation_error_m,
        "reported_sigma_median_m": c.median_reported_sigma_m,
    })
}

/// The consistency figures as lines of text.
pub fn print_consistency(c: &Consistency) {
    let number =
        |v: Option<f64>, scale: f64| v.map_or("-".to_owned(), |v| format!("{:.2}", v * scale));
    println!(
        "NEES f2f    mean {} over {} of {} pairs (6 if consistent), {} % beyond {CHI2_6DOF_999}",
        number(c.mean_nees, 1.0),
        c.nees.len(),
        c.pairs,
        number(c.beyond_bound, 100.0),
    );
    println!(
        "f2f trans   median error {} mm, median reported sigma {} mm",
        number(c.median_translation_error_m, 1000.0),
        number(c.median_reported_sigma_m, 1000.0),
    );
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
