//! The IMU samples of one input (a folder's `imu.txt`, a bag, a live topic) handed to
//! the tracker a frame at a time: before frame k, the samples up to its stamp and the
//! first one past it (the preintegration interpolates the measurement at the stamp), on
//! the camera's clock.

use crate::sample::ImuSample;
use gfs_core::stamp::Stamp;
use std::collections::VecDeque;

/// Checked samples waiting for the frame they come before, on the camera's clock.
#[derive(Clone, Debug)]
pub struct ImuFeed {
    samples: VecDeque<ImuSample>,
    offset_ns: i64,
    capacity: usize,
}

impl ImuFeed {
    /// What a live input keeps waiting (10 s at 400 Hz); the oldest go first when frames
    /// stop coming.
    pub const LIVE_CAPACITY: usize = 4000;

    /// A feed putting the IMU's stamps on the camera's clock by adding `time_offset_s`
    /// (the `[imu]` table's), holding at most `capacity` samples.
    pub fn new(time_offset_s: f64, capacity: usize) -> Self {
        Self {
            samples: VecDeque::new(),
            offset_ns: (time_offset_s * 1e9).round() as i64,
            capacity: capacity.max(2),
        }
    }

    /// Adds a sample (in order and finite: checked by the input), stamped on the IMU's
    /// clock.
    pub fn push(&mut self, mut sample: ImuSample) {
        sample.stamp = Stamp::from_nanos(sample.stamp.nanos().saturating_add(self.offset_ns));
        if self.samples.len() == self.capacity {
            self.samples.pop_front();
        }
        self.samples.push_back(sample);
    }

    /// Moves into `out` the samples up to `stamp` (camera clock) and the first one past
    /// it when it arrived; true when it did (the frame's interval is covered).
    pub fn through(&mut self, stamp: Stamp, out: &mut Vec<ImuSample>) -> bool {
        while let Some(sample) = self.samples.pop_front() {
            out.push(sample);
            if sample.stamp > stamp {
                return true;
            }
        }
        false
    }

    /// Forgets the samples before the last one at or before `stamp` (camera clock): the
    /// first frame needs none earlier.
    pub fn skip_before(&mut self, stamp: Stamp) {
        while self.samples.len() >= 2 && self.samples[1].stamp <= stamp {
            self.samples.pop_front();
        }
    }

    /// Whether a sample past `stamp` (camera clock) is waiting.
    pub fn reaches_past(&self, stamp: Stamp) -> bool {
        self.samples.back().is_some_and(|s| s.stamp > stamp)
    }

    /// The newest sample's stamp, on the camera's clock.
    pub fn newest(&self) -> Option<Stamp> {
        self.samples.back().map(|s| s.stamp)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    fn sample(ms: i64) -> ImuSample {
        ImuSample {
            stamp: Stamp::from_nanos(ms * 1_000_000),
            gyro: Vector3::new(ms as f64, 0.0, 0.0),
            accel: Vector3::zeros(),
        }
    }

    #[test]
    fn each_frame_gets_the_samples_up_to_and_the_first_past_its_stamp() {
        // 200 Hz on the IMU's clock, 2 ms behind the camera's.
        let mut feed = ImuFeed::new(0.002, 100);
        for ms in (-100..100).step_by(5) {
            feed.push(sample(ms));
        }
        feed.skip_before(Stamp::from_nanos(3_000_000));
        let mut out = Vec::new();
        assert!(feed.through(Stamp::from_nanos(33_000_000), &mut out));
        let stamps: Vec<i64> = out.iter().map(|s| s.stamp.nanos() / 1_000_000).collect();
        assert_eq!(stamps, [2, 7, 12, 17, 22, 27, 32, 37]);
        assert_eq!(out[7].gyro.x, 35.0, "the sample's values are kept");
        out.clear();
        assert!(feed.through(Stamp::from_nanos(66_000_000), &mut out));
        let stamps: Vec<i64> = out.iter().map(|s| s.stamp.nanos() / 1_000_000).collect();
        assert_eq!(stamps, [42, 47, 52, 57, 62, 67], "no sample twice");
        out.clear();
        assert!(!feed.through(Stamp::from_nanos(200_000_000), &mut out));
        assert_eq!(out.len(), 6, "what there is, when the IMU stops");
        assert!(feed.newest().is_none());
    }
}
