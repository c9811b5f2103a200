//! IMU samples over the pipeline. The input (the source, the bag player, the ROS 2
//! stage) publishes, just before frame k, the samples before it (up to its stamp and
//! the first past it, [`gfs_inertial::ImuFeed`]) as one message with the frame's id; the
//! tracker keeps them by frame id and pushes those of every frame up to k before
//! tracking k (in realtime, the batches of the frames it skipped too: the IMU's motion
//! is continuous).
//!
//! One message per frame rather than one per sample: the batch is sent before the
//! frame, so it is in the tracker's queue before any feature of the frame can be, and
//! the join never waits for it (a restarted source or tracker cannot leave it waiting:
//! a missing batch is a gap the odometry bridges or reports); and it costs one message
//! per frame instead of seven at 200 Hz. An input without IMU opens no publisher and
//! sends nothing.

use super::context::{StageContext, StageError};
use crate::wire::WireImuSample;
use gfs_core::ids::FrameId;
use gfs_core::stamp::Stamp;
use gfs_core::throttle::Throttle;
use gfs_inertial::{ImuFeed, ImuSample, Pushed, SampleIssue};
use gfs_ipc::{MsgHeader, Service, TopicPublisher, TopicSubscriber, topics};
use gfs_odometry::session::TrackingSession;
use std::collections::BTreeMap;
use std::time::Duration;

/// The samples a frame's batch is sized for at first (0.1 s at 400 Hz).
pub const BATCH_INITIAL_LEN: usize = 40;

/// The input's side: its feed and the batch of the frame about to be published.
pub struct ImuOutbox<S: Service> {
    feed: ImuFeed,
    publisher: TopicPublisher<S, WireImuSample>,
    /// Where the samples come from (`imu.txt`'s path, a topic), for the warnings.
    input: String,
    samples: Vec<ImuSample>,
    batch: Vec<WireImuSample>,
    /// The frame the batch is for, and its stamp.
    frame: (u64, Stamp),
    /// Whether a batch was taken yet (the first frame needs no samples before its own).
    started: bool,
    throttle: Throttle,
}

impl<S: Service> ImuOutbox<S> {
    /// Opens the `imu` topic for the samples of `input`, put on the camera's clock by
    /// the config's `[imu] time_offset_s`, at most `capacity` waiting.
    ///
    /// # Errors
    /// [`StageError`] when the topic cannot be opened.
    pub fn open(ctx: &StageContext<S>, input: String, capacity: usize) -> Result<Self, StageError> {
        Ok(Self {
            feed: ImuFeed::new(ctx.config().imu.time_offset_s, capacity),
            started: false,
            publisher: ctx.publish(topics::IMU, BATCH_INITIAL_LEN)?,
            input,
            samples: Vec::with_capacity(BATCH_INITIAL_LEN),
            batch: Vec::with_capacity(BATCH_INITIAL_LEN),
            frame: (0, Stamp::default()),
            throttle: Throttle::new(Duration::from_secs(1)),
        })
    }

    /// The samples waiting (add to it as they come, in order and checked).
    pub fn feed(&mut self) -> &mut ImuFeed {
        &mut self.feed
    }

    /// Takes frame `id`'s samples out of the feed: those up to `stamp` and the first past
    /// it. Warns (at most once a second) when none past it has come: the IMU stopped or
    /// lags.
    pub fn prepare(&mut self, id: u64, stamp: Stamp) {
        if !std::mem::replace(&mut self.started, true) {
            self.feed.skip_before(stamp);
        }
        self.samples.clear();
        let covered = self.feed.through(stamp, &mut self.samples);
        if !covered && let Some(held) = self.throttle.admit() {
            let last = self.samples.last().map(|s| s.stamp).or(self.feed.newest());
            let last = last.map_or("none yet".to_owned(), |s| format!("the last at {s}"));
            tracing::warn!(
                frame = id,
                "{}: no IMU sample past the frame's stamp {stamp} ({last}; {held} more \
                 such warnings held back); the frame goes on without",
                self.input
            );
        }
        self.batch.clear();
        self.batch
            .extend(self.samples.iter().map(WireImuSample::from));
        self.frame = (id, stamp);
    }

    /// Publishes the batch [`Self::prepare`] took (again, when the frame is sent again).
    ///
    /// # Errors
    /// [`StageError`] when the topic fails.
    pub fn publish(&self) -> Result<(), StageError> {
        let (id, stamp) = self.frame;
        self.publisher
            .publish_slice(&MsgHeader::new(FrameId(id), stamp), &self.batch)?;
        Ok(())
    }

    /// Connects subscribers that came (a restarted tracker gets the last batches).
    ///
    /// # Errors
    /// [`StageError`] when the topic fails.
    pub fn update_connections(&self) -> Result<(), StageError> {
        self.publisher.update_connections()?;
        Ok(())
    }
}

/// Says the lines of an input file that were skipped (the first ones, then how many
/// more).
pub fn say_skipped_lines(warnings: &[String]) {
    const SHOWN: usize = 20;
    for w in warnings.iter().take(SHOWN) {
        tracing::warn!("{w}");
    }
    if warnings.len() > SHOWN {
        tracing::warn!("... and {} more such IMU lines", warnings.len() - SHOWN);
    }
}

/// The tracker's side: the batches received, by frame id, until their frame is tracked.
pub struct ImuInbox {
    batches: BTreeMap<u64, Vec<ImuSample>>,
    throttle: Throttle,
}

impl Default for ImuInbox {
    fn default() -> Self {
        Self {
            batches: BTreeMap::new(),
            throttle: Throttle::new(Duration::from_secs(1)),
        }
    }
}

impl ImuInbox {
    /// Takes the batches that arrived, for frames from `next_frame` on. A second batch
    /// for a frame adds the samples after the first's last (a batch sent again with its
    /// frame adds nothing; live, a frame that could not be converted leaves its id and
    /// its samples to the next).
    ///
    /// # Errors
    /// [`StageError`] when the topic fails.
    pub fn receive<S: Service>(
        &mut self,
        subscriber: &TopicSubscriber<S, WireImuSample>,
        next_frame: u64,
    ) -> Result<(), StageError> {
        while let Some(s) = subscriber.receive()? {
            let id = s.user_header().frame_id;
            if id >= next_frame {
                let batch = self.batches.entry(id).or_default();
                let last = batch.last().map(|b| b.stamp);
                let newer = s.payload().iter().map(WireImuSample::sample);
                batch.extend(newer.filter(|n| last.is_none_or(|l| n.stamp > l)));
            }
        }
        Ok(())
    }

    /// Pushes the samples of the frames up to `id` into `session`, oldest first, with a
    /// warning (at most one a second) for each one it drops or notices; returns how many
    /// it kept.
    pub fn push_through(&mut self, id: u64, session: &mut TrackingSession) -> usize {
        let mut kept = 0;
        while let Some(entry) = self.batches.first_entry() {
            if *entry.key() > id {
                break;
            }
            let (frame, batch) = entry.remove_entry();
            for sample in batch {
                match session.push_imu(sample) {
                    Pushed::Kept => kept += 1,
                    Pushed::KeptWith(issue) => {
                        kept += 1;
                        self.warn(frame, issue);
                    }
                    Pushed::Dropped(issue) => self.warn(frame, issue),
                }
            }
        }
        kept
    }

    fn warn(&mut self, frame: u64, issue: SampleIssue) {
        if let Some(held) = self.throttle.admit() {
            tracing::warn!(
                frame,
                "tracker: imu: {issue} ({held} more IMU warnings held back)"
            );
        }
    }
}
