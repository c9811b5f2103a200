//! IMU samples as drivers send them, and the checks a stream of them needs: drivers
//! repeat samples, restart their clock, drop seconds of data and (rarely) send NaN. A
//! sample that cannot be used is dropped with the reason, so the caller can warn with
//! its topic or file and line, and the odometry goes on.

use gfs_core::stamp::Stamp;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// One measurement of the IMU, in the IMU's axes.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ImuSample {
    /// Capture stamp.
    pub stamp: Stamp,
    /// Angular velocity, rad/s.
    pub gyro: Vector3<f64>,
    /// Specific force, m/s^2 (+9.81 along up at rest).
    pub accel: Vector3<f64>,
}

impl ImuSample {
    /// Whether every component is finite.
    pub fn is_finite(&self) -> bool {
        self.gyro
            .iter()
            .chain(self.accel.iter())
            .all(|v| v.is_finite())
    }
}

/// What was wrong with a sample, or noteworthy about it.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum SampleIssue {
    /// A component is NaN or infinite: dropped.
    #[error("IMU sample at {0} is not finite: dropped")]
    NotFinite(Stamp),
    /// The stamp equals the previous sample's: dropped.
    #[error("IMU sample at {0} repeats the previous stamp: dropped")]
    Repeated(Stamp),
    /// The stamp is before the previous sample's: dropped (a jump back of more than
    /// [`ImuStream::RESTART_S`] restarts the stream instead).
    #[error("IMU sample at {at} is before the previous one ({previous}): dropped")]
    Backwards { at: Stamp, previous: Stamp },
    /// The clock went back by more than [`ImuStream::RESTART_S`]: the driver restarted;
    /// the buffer is cleared and the sample kept.
    #[error("IMU stamps jumped back from {previous} to {at}: the stream restarts")]
    Restarted { at: Stamp, previous: Stamp },
    /// Kept, but after a gap the preintegration will not bridge.
    #[error("IMU samples missing for {gap_s:.3} s before {at}")]
    Gap { at: Stamp, gap_s: f64 },
}

/// What [`ImuStream::push`] did with a sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Pushed {
    /// Kept.
    Kept,
    /// Kept, with something the caller should say ([`SampleIssue::Gap`],
    /// [`SampleIssue::Restarted`]).
    KeptWith(SampleIssue),
    /// Dropped, with the reason.
    Dropped(SampleIssue),
}

/// An ordered, bounded buffer of the samples not yet consumed by the tracker.
#[derive(Clone, Debug)]
pub struct ImuStream {
    samples: VecDeque<ImuSample>,
    max_gap_s: f64,
    capacity: usize,
}

impl ImuStream {
    /// A jump back of the stamps by more than this is a restart of the driver.
    pub const RESTART_S: f64 = 1.0;

    /// A stream flagging gaps longer than `max_gap_s` and keeping at most `capacity`
    /// samples (the oldest go first when frames stop coming).
    pub fn new(max_gap_s: f64, capacity: usize) -> Self {
        Self {
            samples: VecDeque::with_capacity(capacity.min(1 << 16)),
            max_gap_s,
            capacity: capacity.max(2),
        }
    }

    /// Adds `sample` after checking it against the last one.
    pub fn push(&mut self, sample: ImuSample) -> Pushed {
        if !sample.is_finite() {
            return Pushed::Dropped(SampleIssue::NotFinite(sample.stamp));
        }
        let mut said = None;
        if let Some(last) = self.samples.back() {
            let step = sample.stamp.secs_since(last.stamp);
            if step == 0.0 {
                return Pushed::Dropped(SampleIssue::Repeated(sample.stamp));
            }
            if step < -Self::RESTART_S {
                said = Some(SampleIssue::Restarted {
                    at: sample.stamp,
                    previous: last.stamp,
                });
                self.samples.clear();
            } else if step < 0.0 {
                return Pushed::Dropped(SampleIssue::Backwards {
                    at: sample.stamp,
                    previous: last.stamp,
                });
            } else if step > self.max_gap_s {
                said = Some(SampleIssue::Gap {
                    at: sample.stamp,
                    gap_s: step,
                });
            }
        }
        if self.samples.len() == self.capacity {
            self.samples.pop_front();
        }
        self.samples.push_back(sample);
        said.map_or(Pushed::Kept, Pushed::KeptWith)
    }

    /// The buffered samples, oldest first, as one slice.
    pub fn samples(&mut self) -> &[ImuSample] {
        self.samples.make_contiguous()
    }

    /// Forgets the samples before `stamp`, keeping the last one at or before it (the
    /// next interval starts there).
    pub fn discard_before(&mut self, stamp: Stamp) {
        while self.samples.len() >= 2 && self.samples[1].stamp <= stamp {
            self.samples.pop_front();
        }
    }

    /// The largest gap this stream accepts inside an interval, seconds.
    pub fn max_gap_s(&self) -> f64 {
        self.max_gap_s
    }
}

/// Combines a gyroscope stream and an accelerometer stream sent separately (RealSense
/// `gyro/sample` + `accel/sample`) into samples at the gyroscope's stamps, the
/// accelerometer interpolated linearly between its two samples around each (as the
/// driver's `unite_imu_method: linear_interpolation` does). Gyroscope samples wait
/// until an accelerometer sample at or after them has arrived.
#[derive(Clone, Debug, Default)]
pub struct GyroAccelUnion {
    gyro: VecDeque<(Stamp, Vector3<f64>)>,
    accel: VecDeque<(Stamp, Vector3<f64>)>,
}

impl GyroAccelUnion {
    /// At most this many samples wait on either side (one second at 1 kHz).
    const WAITING: usize = 1000;

    /// Adds a gyroscope sample; returns the samples now complete, into `out`.
    pub fn push_gyro(&mut self, stamp: Stamp, gyro: Vector3<f64>, out: &mut Vec<ImuSample>) {
        if self.gyro.len() == Self::WAITING {
            self.gyro.pop_front();
        }
        self.gyro.push_back((stamp, gyro));
        self.drain(out);
    }

    /// Adds an accelerometer sample; returns the samples now complete, into `out`.
    pub fn push_accel(&mut self, stamp: Stamp, accel: Vector3<f64>, out: &mut Vec<ImuSample>) {
        if self.accel.len() == Self::WAITING {
            self.accel.pop_front();
        }
        self.accel.push_back((stamp, accel));
        self.drain(out);
    }

    fn drain(&mut self, out: &mut Vec<ImuSample>) {
        while let Some(&(stamp, gyro)) = self.gyro.front() {
            let Some(after) = self.accel.iter().position(|(t, _)| *t >= stamp) else {
                return; // wait for the accelerometer to pass this stamp
            };
            self.gyro.pop_front();
            let (t1, a1) = self.accel[after];
            let accel = match after.checked_sub(1).map(|i| self.accel[i]) {
                Some((t0, a0)) if t1 > t0 => {
                    let w = stamp.secs_since(t0) / t1.secs_since(t0);
                    a0 + (a1 - a0) * w
                }
                // Before the first accelerometer sample: nothing to interpolate from.
                _ if t1 != stamp => continue,
                _ => a1,
            };
            out.push(ImuSample { stamp, gyro, accel });
            // Keep one accelerometer sample before the next gyroscope stamp.
            while self.accel.len() >= 2 && self.accel[1].0 <= stamp {
                self.accel.pop_front();
            }
        }
    }
}

#[cfg(test)]
#[path = "sample_tests.rs"]
mod tests;
