//! Order statistics of a profile: per-stage processing and queueing times and the
//! end-to-end latency, as median / p90 / p99 / max in milliseconds.

use std::fmt;

use serde::{Deserialize, Serialize};

use super::record::{Profile, ns_to_ms};
use crate::header::Stage;

/// Median, p90, p99 and max of a set of durations, in milliseconds.
///
/// Quantiles are *nearest-rank*: the q-quantile of n sorted samples is the sample of
/// 1-based rank `ceil(q * n)` (at least 1), so every reported value is a measured one
/// (the median of an even count is the lower middle sample, not an average). All zero
/// with `count == 0`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Quantiles {
    /// Number of samples.
    pub count: usize,
    /// 50th percentile (nearest rank).
    pub median_ms: f64,
    /// 90th percentile (nearest rank).
    pub p90_ms: f64,
    /// 99th percentile (nearest rank).
    pub p99_ms: f64,
    /// Largest sample.
    pub max_ms: f64,
}

impl Quantiles {
    /// The quantiles of `samples` (milliseconds, reordered in place; non-finite values
    /// are ignored).
    pub fn of(samples: &mut Vec<f64>) -> Self {
        samples.retain(|v| v.is_finite());
        samples.sort_by(f64::total_cmp);
        let n = samples.len();
        if n == 0 {
            return Self::default();
        }
        let rank = |q: f64| samples[((q * n as f64).ceil() as usize).clamp(1, n) - 1];
        Self {
            count: n,
            median_ms: rank(0.5),
            p90_ms: rank(0.9),
            p99_ms: rank(0.99),
            max_ms: samples[n - 1],
        }
    }
}

/// The times of one stage over the frames it stamped.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct StageSummary {
    /// The stage.
    pub stage: &'static str,
    /// started -> finished.
    pub processing: Quantiles,
    /// received -> started: how long the input waited inside the stage.
    pub queueing: Quantiles,
}

/// The summary of a [`Profile`]; its `Display` is an aligned table.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ProfileSummary {
    /// Pipeline mode of the run.
    pub mode: String,
    /// Frames recorded.
    pub frames: usize,
    /// One entry per stage that stamped at least one frame, in pipeline order.
    pub stages: Vec<StageSummary>,
    /// Source "started" to tracker "finished" of each frame: frame published -> pose out.
    pub end_to_end: Quantiles,
}

impl Profile {
    /// Per-stage processing / queueing times and end-to-end latency over all frames.
    pub fn summary(&self) -> ProfileSummary {
        let stages = self
            .stages_present()
            .into_iter()
            .map(|stage| {
                let mut processing = self.series(|f| f.processing_ms(stage));
                let mut queueing = self.series(|f| f.queueing_ms(stage));
                StageSummary {
                    stage: stage.name(),
                    processing: Quantiles::of(&mut processing),
                    queueing: Quantiles::of(&mut queueing),
                }
            })
            .collect();
        let mut end_to_end = self.series(|f| f.end_to_end_ns.map(ns_to_ms));
        ProfileSummary {
            mode: self.mode.clone(),
            frames: self.frames.len(),
            stages,
            end_to_end: Quantiles::of(&mut end_to_end),
        }
    }

    /// The values `value` gives for the frames that have one.
    fn series(&self, value: impl Fn(&super::FrameRecord) -> Option<f64>) -> Vec<f64> {
        self.frames.iter().filter_map(value).collect()
    }

    /// Processing time of `stage` in ms per frame, as `(frame index, ms)` for the frames
    /// the stage stamped (the series of a per-stage plot).
    pub fn processing_series(&self, stage: Stage) -> Vec<(u64, f64)> {
        self.frames
            .iter()
            .filter_map(|f| Some((f.frame_id, f.processing_ms(stage)?)))
            .collect()
    }
}

/// Width of one number column.
const COL: usize = 8;
/// Width of a 4-number block (median p90 p99 max).
const BLOCK: usize = 4 * COL + 3;

fn write_block(f: &mut fmt::Formatter<'_>, q: &Quantiles) -> fmt::Result {
    if q.count == 0 {
        return write!(f, "{:>COL$} {:>COL$} {:>COL$} {:>COL$}", "-", "-", "-", "-");
    }
    write!(
        f,
        "{:>COL$.3} {:>COL$.3} {:>COL$.3} {:>COL$.3}",
        q.median_ms, q.p90_ms, q.p99_ms, q.max_ms
    )
}

impl fmt::Display for ProfileSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} frames, mode {} (ms; nearest-rank quantiles)",
            self.frames, self.mode
        )?;
        let titles = format!(
            "{:<10} {:>6} | {:^BLOCK$} | {:^BLOCK$}",
            "", "", "processing", "queueing"
        );
        writeln!(f, "{}", titles.trim_end())?;
        let names = format!(
            "{:>COL$} {:>COL$} {:>COL$} {:>COL$}",
            "median", "p90", "p99", "max"
        );
        writeln!(f, "{:<10} {:>6} | {names} | {names}", "stage", "n")?;
        for s in &self.stages {
            write!(f, "{:<10} {:>6} | ", s.stage, s.processing.count)?;
            write_block(f, &s.processing)?;
            write!(f, " | ")?;
            write_block(f, &s.queueing)?;
            writeln!(f)?;
        }
        write!(f, "{:<10} {:>6} | ", "end-to-end", self.end_to_end.count)?;
        write_block(f, &self.end_to_end)?;
        writeln!(f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::header::{MsgHeader, StageStamp};
    use gfs_core::ids::FrameId;
    use gfs_core::stamp::Stamp;

    const MS: u64 = 1_000_000;

    /// 100 frames: points takes k ms (k = 1..=100) after waiting (k mod 10) ms; the
    /// source takes 1 ms; the tracker finishes 2k ms after the source started.
    fn hundred_frames() -> Profile {
        let mut profile = Profile::new("realtime");
        for k in 1..=100u64 {
            let mut h = MsgHeader::new(FrameId(k), Stamp::from_nanos(k as i64 * 1_000_000_000));
            let t0 = 1_000 * MS * k;
            *h.stamp_mut(Stage::Source) = StageStamp {
                received_ns: t0,
                started_ns: t0,
                finished_ns: t0 + MS,
            };
            let received = t0 + MS;
            let started = received + (k % 10) * MS;
            *h.stamp_mut(Stage::Points) = StageStamp {
                received_ns: received,
                started_ns: started,
                finished_ns: started + k * MS,
            };
            h.stamp_mut(Stage::Tracker).finished_ns = t0 + 2 * k * MS + 200 * MS;
            profile.record(&h, "ok");
        }
        profile
    }

    #[test]
    fn nearest_rank_quantiles() {
        let mut v: Vec<f64> = (1..=100).rev().map(f64::from).collect();
        let q = Quantiles::of(&mut v);
        assert_eq!(
            (q.count, q.median_ms, q.p90_ms, q.p99_ms, q.max_ms),
            (100, 50.0, 90.0, 99.0, 100.0)
        );
        let mut ten: Vec<f64> = (1..=10).map(f64::from).collect();
        let q = Quantiles::of(&mut ten);
        assert_eq!((q.median_ms, q.p90_ms, q.p99_ms), (5.0, 9.0, 10.0));
        let mut one = vec![f64::NAN, 7.0];
        let q = Quantiles::of(&mut one);
        assert_eq!((q.count, q.median_ms, q.max_ms), (1, 7.0, 7.0));
        assert_eq!(Quantiles::of(&mut Vec::new()), Quantiles::default());
    }

    #[test]
    fn summary_of_known_stamps() {
        let s = hundred_frames().summary();
        assert_eq!(s.frames, 100);
        let names: Vec<&str> = s.stages.iter().map(|s| s.stage).collect();
        assert_eq!(names, ["source", "points", "tracker"]);
        let points = s.stages[1];
        assert_eq!(points.processing.count, 100);
        assert_eq!(
            (
                points.processing.median_ms,
                points.processing.p90_ms,
                points.processing.p99_ms,
                points.processing.max_ms
            ),
            (50.0, 90.0, 99.0, 100.0)
        );
        // Waits 0..9 ms, ten frames each: ranks 50 / 90 / 99 fall on 4 / 8 / 9 ms.
        assert_eq!(
            (
                points.queueing.median_ms,
                points.queueing.p90_ms,
                points.queueing.p99_ms,
                points.queueing.max_ms
            ),
            (4.0, 8.0, 9.0, 9.0)
        );
        assert_eq!(
            (
                s.stages[0].processing.median_ms,
                s.stages[0].queueing.max_ms
            ),
            (1.0, 0.0)
        );
        // The tracker has only "finished": no processing or queueing time.
        assert_eq!(s.stages[2].processing.count, 0);
        // End-to-end = max(tracker 2k+200, points 1+(k mod 10)+k) ms = 2k + 200 ms.
        assert_eq!(
            (
                s.end_to_end.count,
                s.end_to_end.median_ms,
                s.end_to_end.p99_ms,
                s.end_to_end.max_ms
            ),
            (100, 300.0, 398.0, 400.0)
        );
    }

    #[test]
    fn table_has_one_aligned_row_per_stage() {
        let text = hundred_frames().summary().to_string();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 3 + 3 + 1, "{text}");
        assert!(lines[0].starts_with("100 frames, mode realtime"));
        assert!(
            lines[3].starts_with("source        100 |    1.000    1.000"),
            "{text}"
        );
        assert!(
            lines[4]
                .starts_with("points        100 |   50.000   90.000   99.000  100.000 |    4.000")
        );
        assert!(lines[5].contains("tracker         0 |        -"), "{text}");
        assert!(
            lines[6].starts_with("end-to-end    100 |  300.000"),
            "{text}"
        );
        // Every row has its separators at the same columns.
        let bars: Vec<Vec<usize>> = lines[1..6]
            .iter()
            .map(|l| l.match_indices('|').map(|(i, _)| i).collect())
            .collect();
        assert!(bars.iter().all(|b| *b == bars[0]), "{text}");
        assert_eq!(Profile::new("x").summary().stages.len(), 0);
    }
}
