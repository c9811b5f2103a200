//! `/diagnostics` as integrators monitor a node (`diagnostic_msgs/DiagnosticArray`, once
//! a second): the tracking state, input and output rates, the latency median and
//! maximum over the last second, the share of frames tracked and the restarts of the
//! stages; level WARN when degraded or late, ERROR when lost.
//!
//! [`DiagnosticsWindow`] counts on any clock in nanoseconds: the wall clock live, the
//! camera stamps in a recording (as a node with `use_sim_time`), so that a recording of
//! a 26 s bag holds about 26 reports whatever the playback speed.

use crate::msg::Header;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// `diagnostic_msgs/KeyValue`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct KeyValue {
    /// What the value is.
    pub key: String,
    /// The value, as text.
    pub value: String,
}

/// `diagnostic_msgs/DiagnosticStatus`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DiagnosticStatus {
    /// [`Level`] as its byte.
    pub level: u8,
    /// The component: `gfsvo: odometry`.
    pub name: String,
    /// One line on the state.
    pub message: String,
    /// The device: the colour topic.
    pub hardware_id: String,
    /// The figures.
    pub values: Vec<KeyValue>,
}

/// `diagnostic_msgs/DiagnosticArray`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DiagnosticArray {
    /// When the report was made.
    pub header: Header,
    /// One status: the odometry's.
    pub status: Vec<DiagnosticStatus>,
}

/// `DiagnosticStatus.level`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    /// Tracking, on time.
    Ok = 0,
    /// Degraded frames, late poses, frames without a pose, or no input.
    Warn = 1,
    /// Tracking lost (the last pose was predicted).
    Error = 2,
}

/// The window the rates and latencies are over, ns.
pub const WINDOW_NS: i64 = 1_000_000_000;

/// A pose this long after its frame was received is late (three frames at 30 Hz), s.
pub const LATE_S: f64 = 0.1;

/// Share of the input frames that must get a pose within the window, below which the
/// odometry falls behind (WARN).
const MIN_OUTPUT_SHARE: f64 = 0.9;

/// One pose out.
#[derive(Clone, Copy, Debug)]
struct Published {
    at_ns: i64,
    latency_s: Option<f64>,
    status: &'static str,
}

/// The last second of frames in and poses out, and the state they make.
#[derive(Clone, Debug, Default)]
pub struct DiagnosticsWindow {
    received: VecDeque<i64>,
    published: VecDeque<Published>,
    last_status: Option<&'static str>,
    /// The IMU samples the tracker took in over the run.
    imu_samples: u64,
}

impl DiagnosticsWindow {
    /// An empty window.
    pub fn new() -> Self {
        Self::default()
    }

    /// A frame came in at `now_ns`.
    pub fn frame_received(&mut self, now_ns: i64) {
        self.received.push_back(now_ns);
        self.forget_before(now_ns);
    }

    /// A pose went out at `now_ns`, `latency_s` after its frame came in, with `status`
    /// (`tracked`, `degraded`, `predicted`, `relocalised`).
    pub fn pose_published(&mut self, now_ns: i64, latency_s: Option<f64>, status: &'static str) {
        self.published.push_back(Published {
            at_ns: now_ns,
            latency_s,
            status,
        });
        self.last_status = Some(status);
        self.forget_before(now_ns);
    }

    /// The tracker took in `samples` more IMU samples (reported once there are some).
    pub fn imu_taken(&mut self, samples: u64) {
        self.imu_samples += samples;
    }

    fn forget_before(&mut self, now_ns: i64) {
        let start = now_ns - WINDOW_NS;
        while self.received.front().is_some_and(|&t| t <= start) {
            self.received.pop_front();
        }
        while self.published.front().is_some_and(|p| p.at_ns <= start) {
            self.published.pop_front();
        }
    }

    /// The report at `now_ns` stamped `header`, for the frames of `hardware_id`, with the
    /// restarts of each stage over the run.
    pub fn report(
        &mut self,
        now_ns: i64,
        header: Header,
        hardware_id: &str,
        restarts: &[(String, u32)],
    ) -> DiagnosticArray {
        self.forget_before(now_ns);
        let window_s = WINDOW_NS as f64 * 1e-9;
        let input_hz = self.received.len() as f64 / window_s;
        let output_hz = self.published.len() as f64 / window_s;
        let mut latencies: Vec<f64> = self.published.iter().filter_map(|p| p.latency_s).collect();
        latencies.sort_by(f64::total_cmp);
        let median = latencies.get(latencies.len() / 2).copied();
        let max = latencies.last().copied();
        let count = |status| self.published.iter().filter(|p| p.status == status).count();
        let lost = count("predicted");
        let degraded = count("degraded");
        let tracked_share = match self.published.len() {
            0 => None,
            n => Some((n - lost) as f64 / n as f64),
        };
        let state = self.last_status.unwrap_or("waiting for frames");
        let (level, message) = if self.last_status == Some("predicted") {
            (Level::Error, "tracking lost".to_owned())
        } else if self.received.is_empty() && self.published.is_empty() {
            (Level::Warn, "no frames in the last second".to_owned())
        } else if degraded > 0 {
            (Level::Warn, format!("{degraded} degraded frames"))
        } else if max.is_some_and(|m| m > LATE_S) {
            (
                Level::Warn,
                format!("poses late (max {:.0} ms)", 1e3 * max.unwrap_or(0.0)),
            )
        } else if output_hz < MIN_OUTPUT_SHARE * input_hz {
            (
                Level::Warn,
                format!("{output_hz:.1} poses/s for {input_hz:.1} frames/s"),
            )
        } else {
            (Level::Ok, format!("tracking, {output_hz:.1} Hz"))
        };
        let ms = |v: Option<f64>| v.map_or("n/a".to_owned(), |s| format!("{:.1}", 1e3 * s));
        let mut values = vec![
            ("tracking state", state.to_owned()),
            ("input rate (Hz)", format!("{input_hz:.1}")),
            ("output rate (Hz)", format!("{output_hz:.1}")),
            ("latency median (ms)", ms(median)),
            ("latency max (ms)", ms(max)),
            (
                "frames tracked (%)",
                tracked_share.map_or("n/a".to_owned(), |s| format!("{:.1}", 100.0 * s)),
            ),
        ]
        .into_iter()
        .map(|(key, value)| KeyValue {
            key: key.to_owned(),
            value,
        })
        .collect::<Vec<_>>();
        if self.imu_samples > 0 {
            values.push(KeyValue {
                key: "imu samples tracked".to_owned(),
                value: self.imu_samples.to_string(),
            });
        }
        values.extend(restarts.iter().map(|(stage, n)| KeyValue {
            key: format!("restarts {stage}"),
            value: n.to_string(),
        }));
        DiagnosticArray {
            header,
            status: vec![DiagnosticStatus {
                level: level as u8,
                name: "gfsvo: odometry".to_owned(),
                message,
                hardware_id: hardware_id.to_owned(),
                values,
            }],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: i64 = 1_000_000;

    fn value<'a>(array: &'a DiagnosticArray, key: &str) -> &'a str {
        let values = &array.status[0].values;
        values
            .iter()
            .find(|v| v.key == key)
            .map_or("", |v| &v.value)
    }

    #[test]
    fn rates_latency_share_and_levels_over_the_last_second() {
        let mut w = DiagnosticsWindow::new();
        // 2 s at 30 Hz, each pose 20 ms after its frame; one degraded in the first second.
        for i in 0..=60 {
            let t = i * 33_333_333;
            w.frame_received(t);
            let status = if i == 10 { "degraded" } else { "tracked" };
            w.pose_published(t + 20 * MS, Some(0.020), status);
        }
        let restarts = [("tracker".to_owned(), 1)];
        let report = w.report(2020 * MS, Header::default(), "/rgb", &restarts);
        let status = &report.status[0];
        assert_eq!(status.level, Level::Ok as u8, "{status:?}");
        assert_eq!(value(&report, "input rate (Hz)"), "30.0");
        assert_eq!(value(&report, "output rate (Hz)"), "30.0");
        assert_eq!(value(&report, "latency median (ms)"), "20.0");
        assert_eq!(value(&report, "frames tracked (%)"), "100.0");
        assert_eq!(value(&report, "restarts tracker"), "1");
        // A late pose: WARN.
        w.frame_received(2010 * MS);
        w.pose_published(2200 * MS, Some(0.19), "tracked");
        let report = w.report(2200 * MS, Header::default(), "/rgb", &[]);
        assert_eq!(report.status[0].level, Level::Warn as u8);
        assert_eq!(value(&report, "latency max (ms)"), "190.0");
        // Lost: ERROR, and the share counts it.
        w.frame_received(2233 * MS);
        w.pose_published(2250 * MS, Some(0.017), "predicted");
        let report = w.report(2250 * MS, Header::default(), "/rgb", &[]);
        assert_eq!(report.status[0].level, Level::Error as u8);
        assert_eq!(value(&report, "tracking state"), "predicted");
        let share: f64 = value(&report, "frames tracked (%)").parse().unwrap();
        assert!(share > 90.0 && share < 100.0, "{share}");
        // Nothing for a second after a lost frame: still lost.
        let report = w.report(4000 * MS, Header::default(), "/rgb", &[]);
        assert_eq!(report.status[0].level, Level::Error as u8);
        // Nothing at all: WARN.
        let mut idle = DiagnosticsWindow::new();
        let report = idle.report(4000 * MS, Header::default(), "/rgb", &[]);
        assert_eq!(report.status[0].level, Level::Warn as u8);
        assert_eq!(value(&report, "input rate (Hz)"), "0.0");
    }
}
