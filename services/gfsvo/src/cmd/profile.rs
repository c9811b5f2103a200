//! `gfsvo profile DIR/profile.json [--png OUT.png]`: the per-stage timing table of a
//! pipeline run and a plot of each stage's processing time over the frames.

use crate::CliResult;
use clap::Args;
use gfs_ipc::Profile;
use gfs_plot::{LineChart, PlotConfig, Series, write_line_chart_png};
use std::path::{Path, PathBuf};

/// Arguments of `gfsvo profile`.
#[derive(Args)]
pub struct ProfileArgs {
    /// profile.json written by a pipeline run (`gfsvo run --mode ...`).
    pub profile: PathBuf,
    /// PNG of the processing time per stage over the frame index
    /// (default: profile.png next to the JSON).
    #[arg(long)]
    pub png: Option<PathBuf>,
}

/// Prints the table and writes the plot.
pub fn run(args: &ProfileArgs) -> CliResult {
    let (table, png) = report(args)?;
    print!("{table}");
    println!("plot: {}", png.display());
    Ok(())
}

/// The summary table of `args.profile`, after writing its plot; returns the table and
/// the PNG path.
fn report(args: &ProfileArgs) -> CliResult<(String, PathBuf)> {
    let profile = Profile::read_json(&args.profile)?;
    let png = args.png.clone().unwrap_or_else(|| {
        args.profile
            .parent()
            .unwrap_or(Path::new("."))
            .join("profile.png")
    });
    write_line_chart_png(&processing_chart(&profile), &png, &PlotConfig::default())?;
    Ok((profile.summary().to_string(), png))
}

/// One series per stage: its processing time (ms) for each frame it stamped.
fn processing_chart(profile: &Profile) -> LineChart {
    LineChart {
        title: format!("Processing time per stage ({})", profile.mode),
        x_title: "frame".to_string(),
        y_title: "ms".to_string(),
        series: profile
            .stages_present()
            .into_iter()
            .map(|stage| Series {
                label: stage.name().to_string(),
                points: profile
                    .processing_series(stage)
                    .into_iter()
                    .map(|(frame, ms)| (frame as f64, ms))
                    .collect(),
            })
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gfs_core::ids::FrameId;
    use gfs_core::stamp::Stamp;
    use gfs_ipc::{MsgHeader, Stage, StageStamp};

    const MS: u64 = 1_000_000;

    #[test]
    fn prints_a_row_per_stage_and_writes_the_plot() {
        let dir = std::env::temp_dir().join(format!("gfsvo_profile_cmd_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut profile = Profile::new("lockstep");
        for k in 0..20u64 {
            let mut h = MsgHeader::new(FrameId(k), Stamp::from_nanos(k as i64 * 33_333_333));
            let t = 100 * MS * (k + 1);
            for (i, stage) in [Stage::Source, Stage::Points, Stage::Tracker]
                .into_iter()
                .enumerate()
            {
                let start = t + 10 * MS * i as u64;
                *h.stamp_mut(stage) = StageStamp {
                    received_ns: start,
                    started_ns: start + MS,
                    finished_ns: start + MS + (i as u64 + 1) * MS,
                };
            }
            profile.record(&h, "ok");
        }
        let json = dir.join("profile.json");
        profile.write_json(&json).unwrap();

        let args = ProfileArgs {
            profile: json.clone(),
            png: None,
        };
        let (table, png) = report(&args).unwrap();
        assert_eq!(png, dir.join("profile.png"));
        let image = image::open(&png).unwrap();
        assert_eq!((image.width(), image.height()), (1400, 640));
        // Processing 1 / 2 / 3 ms every frame; source started (t + 1) -> tracker finished
        // (t + 20 + 1 + 3) = 23 ms.
        for (row, ms) in [
            ("source", "1.000"),
            ("points", "2.000"),
            ("tracker", "3.000"),
        ] {
            let line = table.lines().find(|l| l.starts_with(row)).unwrap();
            assert!(
                line.contains(&format!("{row:<10} {:>6} | {ms:>8}", 20)),
                "{table}"
            );
        }
        assert!(table.contains("end-to-end     20 |   23.000"), "{table}");
        assert!(!table.contains("mapper"));

        std::fs::write(&json, "{\"mode\": ").unwrap();
        let err = report(&args).unwrap_err().to_string();
        assert!(err.contains("profile.json"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
