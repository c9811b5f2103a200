//! `sensor_msgs/Imu` in: the unified topic (RealSense's `/camera/imu`), or separate
//! gyroscope and accelerometer topics united at the gyroscope's stamps
//! ([`GyroAccelUnion`]). Every message is checked against the one before it on its
//! topic (order, repeats, NaN, gaps, an invalid stamp, a rate too low for the
//! preintegration); a bad one is dropped with a warning naming the topic and stamp, at
//! most one a second per topic, and the visual odometry goes on. And `sensor_msgs/Imu`
//! out, for the bags `gfsvo convert` writes.

use crate::msg::{Header, Imu, Quaternion, Vector3};
use gfs_core::stamp::Stamp;
use gfs_core::throttle::Throttle;
use gfs_inertial::sample::{ImuStream, Pushed};
use gfs_inertial::{GyroAccelUnion, ImuNoise, ImuSample};
use std::time::Duration;

/// The IMU topics of a camera.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ImuTopics {
    /// Gyroscope and accelerometer in one message.
    pub unified: String,
    /// Gyroscope alone.
    pub gyro: String,
    /// Accelerometer alone.
    pub accel: String,
}

/// Which of the [`ImuTopics`] a message came on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImuTopic {
    /// The unified topic.
    Unified,
    /// The gyroscope's.
    Gyro,
    /// The accelerometer's.
    Accel,
}

impl ImuTopics {
    /// Which IMU topic `topic` is.
    pub fn which(&self, topic: &str) -> Option<ImuTopic> {
        [
            (&self.unified, ImuTopic::Unified),
            (&self.gyro, ImuTopic::Gyro),
            (&self.accel, ImuTopic::Accel),
        ]
        .into_iter()
        .find_map(|(name, which)| (name == topic).then_some(which))
    }

    fn name(&self, which: ImuTopic) -> &str {
        match which {
            ImuTopic::Unified => &self.unified,
            ImuTopic::Gyro => &self.gyro,
            ImuTopic::Accel => &self.accel,
        }
    }
}

/// Below this rate a topic is said to be too slow (the preintegration bridges gaps of
/// `[imu] max_gap_s`, 0.05 s by default; consumer parts run at 100-400 Hz).
pub const MIN_RATE_HZ: f64 = 50.0;

/// A gap longer than this is said (ten samples at 200 Hz).
const QUIET_GAP_S: f64 = 0.05;

/// The checks and the rate of one topic.
struct TopicCheck {
    stream: ImuStream,
    window: Option<(Stamp, usize)>,
    throttle: Throttle,
}

impl TopicCheck {
    fn new() -> Self {
        Self {
            // Capacity 2: only the last sample matters to the checks.
            stream: ImuStream::new(QUIET_GAP_S, 2),
            window: None,
            throttle: Throttle::new(Duration::from_secs(1)),
        }
    }

    /// Whether the sample is kept; warns about what is wrong with it.
    fn check(&mut self, topic: &str, sample: ImuSample) -> bool {
        let (kept, issue) = match self.stream.push(sample) {
            Pushed::Kept => (true, None),
            Pushed::KeptWith(issue) => (true, Some(issue.to_string())),
            Pushed::Dropped(issue) => (false, Some(issue.to_string())),
        };
        if kept && let Some(rate) = self.rate(sample.stamp) {
            self.warn(
                topic,
                &format!(
                    "{rate:.0} Hz up to {}: below {MIN_RATE_HZ} Hz",
                    sample.stamp
                ),
            );
        }
        if let Some(issue) = issue {
            self.warn(topic, &issue);
        }
        kept
    }

    /// The rate over the last second of stamps when it was below [`MIN_RATE_HZ`].
    fn rate(&mut self, stamp: Stamp) -> Option<f64> {
        let (start, count) = self.window.get_or_insert((stamp, 0));
        *count += 1;
        let span = stamp.secs_since(*start);
        if !(0.0..1.0).contains(&span) {
            let rate = (*count - 1) as f64 / span;
            self.window = Some((stamp, 1));
            return (span > 0.0 && rate < MIN_RATE_HZ).then_some(rate);
        }
        None
    }

    fn warn(&mut self, topic: &str, what: &str) {
        if let Some(held) = self.throttle.admit() {
            tracing::warn!("{topic}: {what} ({held} more warnings on it held back)");
        }
    }
}

/// The IMU messages of a camera in, checked samples out.
pub struct ImuInput {
    topics: ImuTopics,
    checks: [TopicCheck; 3],
    union: GyroAccelUnion,
    /// Once the unified topic spoke, the separate ones are ignored.
    unified: bool,
    received: u64,
}

impl ImuInput {
    /// Reads `topics`.
    pub fn new(topics: ImuTopics) -> Self {
        Self {
            topics,
            checks: [TopicCheck::new(), TopicCheck::new(), TopicCheck::new()],
            union: GyroAccelUnion::default(),
            unified: false,
            received: 0,
        }
    }

    /// The topics read.
    pub fn topics(&self) -> &ImuTopics {
        &self.topics
    }

    /// Messages taken so far, on every topic.
    pub fn received(&self) -> u64 {
        self.received
    }

    /// Takes a message of topic `which`; the samples it completes go into `out`.
    pub fn push(&mut self, which: ImuTopic, message: &Imu, out: &mut Vec<ImuSample>) {
        self.received += 1;
        let topic = self.topics.name(which).to_owned();
        let check = &mut self.checks[which as usize];
        let Some(stamp) = message.header.stamp.stamp() else {
            check.warn(
                &topic,
                &format!(
                    "stamp {}.{} has nanoseconds past 1e9: dropped",
                    message.header.stamp.sec, message.header.stamp.nanosec
                ),
            );
            return;
        };
        let v = |v: &Vector3| nalgebra::Vector3::new(v.x, v.y, v.z);
        let sample = ImuSample {
            stamp,
            gyro: v(&message.angular_velocity),
            accel: v(&message.linear_acceleration),
        };
        match which {
            ImuTopic::Unified => {
                self.unified = true;
                if check.check(&topic, sample) {
                    out.push(sample);
                }
            }
            _ if self.unified => {}
            ImuTopic::Gyro => {
                let gyro_only = ImuSample {
                    accel: nalgebra::Vector3::zeros(),
                    ..sample
                };
                if check.check(&topic, gyro_only) {
                    self.union.push_gyro(stamp, sample.gyro, out);
                }
            }
            ImuTopic::Accel => {
                let accel_only = ImuSample {
                    gyro: nalgebra::Vector3::zeros(),
                    ..sample
                };
                if check.check(&topic, accel_only) {
                    self.union.push_accel(stamp, sample.accel, out);
                }
            }
        }
    }
}

/// A sample as `sensor_msgs/Imu` in `frame_id`: no orientation (-1 in element 0 of its
/// covariance, REP 145), the measurement covariances those of `noise` sampled at
/// `rate_hz` (the white noise density squared times the rate, on the diagonal).
pub fn imu_message(sample: &ImuSample, frame_id: &str, noise: &ImuNoise, rate_hz: f64) -> Imu {
    let diagonal = |density: f64| {
        let variance = density * density * rate_hz;
        [variance, 0.0, 0.0, 0.0, variance, 0.0, 0.0, 0.0, variance]
    };
    let v = |v: &nalgebra::Vector3<f64>| Vector3 {
        x: v.x,
        y: v.y,
        z: v.z,
    };
    let mut orientation_covariance = [0.0; 9];
    orientation_covariance[0] = -1.0;
    Imu {
        header: Header {
            stamp: sample.stamp.into(),
            frame_id: frame_id.to_owned(),
        },
        orientation: Quaternion::default(),
        orientation_covariance,
        angular_velocity: v(&sample.gyro),
        angular_velocity_covariance: diagonal(noise.gyro_noise),
        linear_acceleration: v(&sample.accel),
        linear_acceleration_covariance: diagonal(noise.accel_noise),
    }
}

#[cfg(test)]
#[path = "imu_tests.rs"]
mod tests;
