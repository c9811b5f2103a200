//! `source`: decodes the dataset's frames (undistorted gray and depth in metres) and
//! publishes each once for every other stage to read in place. Lockstep: frame k+1 only
//! after the pose of frame k. Realtime: at the capture rate (or `max_rate`). The run's
//! frame 0 is the dataset's frame `start` (a run started part-way in, as localising in
//! a map made from the whole folder does). A ROS 2 bag in place of the folder is played
//! by [`super::bag_source`].

use super::context::{POLL, StageContext, StageError};
use super::imu::{ImuOutbox, say_skipped_lines};
use crate::wire::WirePose;
use gfs_core::Image;
use gfs_core::ids::FrameId;
use gfs_core::stamp::Stamp;
use gfs_dataset::{DEFAULT_READ_AHEAD, IMU_LIST, Sequence, read_imu};
use gfs_ipc::{
    FrameImages, FrameLayout, Mode, MsgHeader, Service, Stage, TopicPublisher, TopicSubscriber,
    topics,
};
use std::time::{Duration, Instant};

/// The checkpoint: the run's index of the next frame to publish.
const CHECKPOINT: &str = "source.bin";

/// Runs the source until told to stop. After the last frame it stays up, idle, so that
/// a restarted stage still receives the last frames from its history.
///
/// # Errors
/// [`StageError`] when the dataset cannot be opened or a topic fails.
pub fn run<S: Service>(ctx: &StageContext<S>) -> Result<(), StageError> {
    if gfs_ros2::bag::is_bag(&ctx.settings.dataset) {
        return super::bag_source::run(ctx);
    }
    let camera = ctx.config().camera()?;
    let dataset = &ctx.settings.dataset;
    let sequence = Sequence::open(dataset, &camera, &ctx.config().depth)
        .map_err(|e| StageError::Dataset(e.to_string()))?;
    let first = ctx.settings.start;
    let remaining = sequence.len().saturating_sub(first);
    let total = ctx.settings.frames.map_or(remaining, |n| n.min(remaining));
    let (width, height) = (camera.pinhole.width, camera.pinhole.height);
    let layout = FrameLayout::new(width, height, false).map_err(|e| StageError::Setup {
        stage: "source",
        message: e.to_string(),
    })?;
    let publisher = ctx.publish::<u8>(topics::FRAME, layout.byte_len())?;
    let poses = ctx.subscribe::<WirePose>(topics::POSE)?;
    let state = ctx.state();
    let mut scratch = Vec::new();
    let start = state
        .read::<u64>(CHECKPOINT)?
        .map_or(0, |i| usize::try_from(i).unwrap_or(usize::MAX))
        .min(total);
    let blank = (
        Image::<u8>::new(width, height),
        Image::<f32>::new(width, height),
    );
    let mut imu = open_imu(ctx, &sequence, first, start)?;
    let mut reader = sequence.frames_from(first + start, Some(first + total), DEFAULT_READ_AHEAD);
    if ctx.mode() == Mode::Realtime && start == 0 {
        await_stages(ctx, &publisher, &poses)?;
    }
    let clock = Instant::now();
    let mut playback = Playback::default();
    for index in start..total {
        if ctx.stopping() {
            return Ok(());
        }
        let Some(item) = reader.next() else { break };
        let timestamp = match &item {
            Ok(frame) => frame.timestamp,
            Err(_) => sequence
                .timestamps()
                .get(first + index)
                .copied()
                .unwrap_or_default(),
        };
        if ctx.mode() == Mode::Realtime {
            let due = match ctx.settings.max_rate {
                Some(rate) if rate > 0.0 => (index - start) as f64 / rate,
                _ => playback.due(index, timestamp),
            };
            pace(ctx, clock, due);
        }
        let images = match &item {
            Ok(frame) => FrameImages {
                gray: frame.gray.view(),
                depth: frame.depth.view(),
                rgb: None,
            },
            Err(e) => {
                tracing::warn!(
                    "source: frame {index} (the dataset's {}): {e}; publishing a blank frame",
                    first + index
                );
                FrameImages {
                    gray: blank.0.view(),
                    depth: blank.1.view(),
                    rgb: None,
                }
            }
        };
        if let Some(imu) = imu.as_mut() {
            imu.prepare(index as u64, timestamp);
        }
        let publish = || -> Result<(), StageError> {
            let mut header = MsgHeader::new(FrameId(index as u64), timestamp);
            header.mark_received(Stage::Source);
            header.mark_started(Stage::Source);
            // Inside the source's stamps (its cost is the stage's), before the frame.
            if let Some(imu) = &imu {
                imu.publish()?;
            }
            let mut sample = publisher.loan_frame(&header, &layout)?;
            gfs_ipc::frame_view_mut(&mut sample, &layout)
                .and_then(|mut planes| planes.copy_from(&images))
                .map_err(|e| StageError::Setup {
                    stage: "source",
                    message: e.to_string(),
                })?;
            sample.user_header_mut().mark_finished(Stage::Source);
            publisher.send(sample)?;
            Ok(())
        };
        publish()?;
        ctx.made(index as u64);
        match ctx.mode() {
            Mode::Lockstep => {
                let ports = (&publisher, imu.as_ref());
                if !await_pose(ctx, ports, &poses, index as u64, &publish)? {
                    return Ok(());
                }
            }
            Mode::Realtime => {}
        }
        state.write(CHECKPOINT, &(index as u64 + 1), &mut scratch)?;
        if let Ok(frame) = item {
            reader.recycle(frame);
        }
    }
    while !ctx.stopping() {
        if let Some(imu) = &imu {
            imu.update_connections()?;
        }
        publisher.update_connections()?;
        std::thread::sleep(POLL * 25);
    }
    Ok(())
}

/// The folder's `imu.txt` on the `imu` topic, `None` without one; resuming at the run's
/// frame `start` (the dataset's `first + start`), the samples of the frames before it
/// are passed.
fn open_imu<S: Service>(
    ctx: &StageContext<S>,
    sequence: &Sequence,
    first: usize,
    start: usize,
) -> Result<Option<ImuOutbox<S>>, StageError> {
    let dataset = &ctx.settings.dataset;
    let Some(list) = read_imu(dataset).map_err(|e| StageError::Dataset(e.to_string()))? else {
        return Ok(None);
    };
    say_skipped_lines(&list.warnings);
    let path = dataset.join(IMU_LIST).display().to_string();
    let mut imu = ImuOutbox::open(ctx, path, usize::MAX)?;
    for sample in list.samples {
        imu.feed().push(sample);
    }
    if let Some(&before) = start
        .checked_sub(1)
        .and_then(|i| sequence.timestamps().get(first + i))
    {
        imu.prepare(start as u64 - 1, before);
    }
    Ok(Some(imu))
}

/// Stages that read every frame: points, lines, planes.
const FRAME_READERS: usize = 3;

/// Realtime: waits until the stages that read frames are ready (each subscribes to the
/// frame topic after its other ports) and the tracker is up (it opens its pose topic
/// after its feature topics), so that the first frames are not played to stages still
/// starting: a realtime topic keeps only the newest frame for a late subscriber. Gives
/// up after the lockstep feature deadline, with a warning.
fn await_stages<S: Service>(
    ctx: &StageContext<S>,
    frames: &TopicPublisher<S, u8>,
    poses: &TopicSubscriber<S, WirePose>,
) -> Result<(), StageError> {
    let deadline =
        Instant::now() + Duration::from_millis(ctx.config().pipeline.lockstep_feature_deadline_ms);
    while frames.subscriber_count() < FRAME_READERS || poses.publisher_count() == 0 {
        if ctx.stopping() {
            return Ok(());
        }
        if Instant::now() >= deadline {
            tracing::warn!(
                readers = frames.subscriber_count(),
                tracker = poses.publisher_count(),
                "source: not every stage is up; playing anyway"
            );
            return Ok(());
        }
        frames.update_connections()?;
        std::thread::sleep(POLL);
    }
    Ok(())
}

/// Longest pause between two frames when playing at the capture times: a jump in the
/// timestamps (a gap in the recording, a bad clock) costs at most this, not the jump.
const MAX_GAP_S: f64 = 1.0;

/// When each frame is due, playing at the capture times with gaps capped.
#[derive(Default)]
struct Playback {
    due: f64,
    last: Option<Stamp>,
}

impl Playback {
    /// Seconds after the first frame at which frame `index`, captured at `timestamp`, is
    /// due: the capture interval since the previous frame, within `[0, MAX_GAP_S]`.
    fn due(&mut self, index: usize, timestamp: Stamp) -> f64 {
        if let Some(last) = self.last {
            let gap = timestamp.secs_since(last);
            if !(0.0..=MAX_GAP_S).contains(&gap) {
                tracing::warn!(
                    frame = index,
                    "source: the timestamps jump by {gap:.3} s; playing on after {MAX_GAP_S} s at most"
                );
            }
            self.due += gap.clamp(0.0, MAX_GAP_S);
        }
        self.last = Some(timestamp);
        self.due
    }
}

/// Sleeps until `due` seconds after `clock` (or until told to stop).
pub(super) fn pace<S: Service>(ctx: &StageContext<S>, clock: Instant, due: f64) {
    let due = Duration::from_secs_f64(due.max(0.0));
    while !ctx.stopping() {
        let now = clock.elapsed();
        if now >= due {
            return;
        }
        std::thread::sleep((due - now).min(POLL * 5));
    }
}

/// Lockstep: waits for the pose of frame `id` (or a later one), publishing the frame
/// again when none comes for a while (front-end stages restarted without it); the IMU's
/// batch reaches a late tracker from its history before the frame reaches the feature
/// stages. False when told to stop.
pub(super) fn await_pose<S: Service>(
    ctx: &StageContext<S>,
    (publisher, imu): (&TopicPublisher<S, u8>, Option<&ImuOutbox<S>>),
    poses: &TopicSubscriber<S, WirePose>,
    id: u64,
    publish: &dyn Fn() -> Result<(), StageError>,
) -> Result<bool, StageError> {
    let mut since = Instant::now();
    loop {
        while let Some(pose) = poses.receive()? {
            if pose.payload().first().is_some_and(|p| p.frame_id >= id) {
                return Ok(true);
            }
        }
        if ctx.stopping() {
            return Ok(false);
        }
        if let Some(imu) = imu {
            imu.update_connections()?;
        }
        publisher.update_connections()?;
        poses.wait(POLL * 5)?;
        if since.elapsed() > ctx.resend_after() {
            tracing::warn!(
                frame = id,
                "source: no pose yet; publishing the frame again"
            );
            publish()?;
            since = Instant::now();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_timestamp_jump_costs_at_most_the_gap_cap() {
        let mut p = Playback::default();
        let due: Vec<f64> = ["10", "10.5", "1000000", "1000000.25", "5"]
            .iter()
            .enumerate()
            .map(|(i, t)| p.due(i, t.parse().unwrap()))
            .collect();
        assert_eq!(due, [0.0, 0.5, 1.5, 1.75, 1.75]);
    }
}
