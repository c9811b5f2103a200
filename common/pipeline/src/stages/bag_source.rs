//! The source playing a ROS 2 bag (MCAP) instead of a dataset folder: colour and depth
//! paired by stamp (`[ros2] slop_s`), compressed images decoded here, converted like live
//! ROS 2 images, paced like the
//! folder source (lockstep: after the previous pose; realtime: at the stamps). Frame k
//! is the k-th pair, as `gfs_ros2::bag::scan` counts them for the supervisor. The IMU
//! (`[ros2] imu_topic`, or `gyro_topic` + `accel_topic`) goes to the tracker as the
//! folder source sends it, read ahead to the first sample past each frame.

use super::context::{POLL, StageContext, StageError};
use super::imu::ImuOutbox;
use super::ros2_frames::{publish_blank, publish_pair};
use super::source::{await_pose, pace};
use crate::wire::WirePose;
use gfs_core::stamp::Stamp;
use gfs_inertial::ImuFeed;
use gfs_ipc::{FrameLayout, Mode, Service, topics};
use gfs_ros2::bag::{BagReader, BagTopics};
use gfs_ros2::image::{FrameConverter, Received};
use gfs_ros2::transport::TransportDecoder;
use std::time::Instant;

/// The checkpoint: the index of the next frame to publish (as the folder source).
const CHECKPOINT: &str = "source.bin";

/// Plays the bag until its end, then idles until told to stop.
///
/// # Errors
/// [`StageError`] when the bag cannot be read or a topic fails.
pub fn run<S: Service>(ctx: &StageContext<S>) -> Result<(), StageError> {
    let config = ctx.config();
    let camera = config.camera()?;
    let ros2 = &config.ros2;
    let topics = BagTopics {
        colour: ros2.colour_topic.clone(),
        depth: ros2.depth_topic.clone(),
        camera_info: ros2.camera_info_topic.clone(),
        transport: ros2.transport,
        imu: Some(ros2.imu_topics()),
    };
    let mut bag = BagReader::open(&ctx.settings.dataset, &topics, ros2.slop_s)
        .map_err(|e| StageError::Dataset(e.to_string()))?;
    let (width, height) = (camera.pinhole.width, camera.pinhole.height);
    let layout = FrameLayout::new(width, height, false).map_err(|e| StageError::Setup {
        stage: "source",
        message: e.to_string(),
    })?;
    let mut converter = FrameConverter::new(&camera, &config.depth);
    let (colour_topic, depth_topic) = bag.image_topics();
    let (colour_topic, depth_topic) = (colour_topic.to_owned(), depth_topic.to_owned());
    let mut decoders = (TransportDecoder::new(), TransportDecoder::new());
    let mut imu = match bag.imu_topics() {
        Some(t) => {
            let name = [&t.unified, &t.gyro, &t.accel].map(String::as_str);
            let name = name.iter().filter(|n| !n.is_empty()).copied();
            let input = name.collect::<Vec<_>>().join(" + ");
            Some(ImuOutbox::open(ctx, input, ImuFeed::LIVE_CAPACITY)?)
        }
        None => None,
    };
    let imu_offset_ns = (config.imu.time_offset_s * 1e9).round() as i64;
    let publisher = ctx.publish::<u8>(topics::FRAME, layout.byte_len())?;
    let poses = ctx.subscribe::<WirePose>(topics::POSE)?;
    let state = ctx.state();
    let mut scratch = Vec::new();
    let start = state.read::<u64>(CHECKPOINT)?.unwrap_or(0);
    let limit = ctx.settings.frames.map_or(u64::MAX, |n| n as u64);
    let clock = Instant::now();
    let mut first = None;
    let mut index = 0u64;
    while index < limit {
        if ctx.stopping() {
            return Ok(());
        }
        let frame = match bag.next_frame() {
            Ok(Some(frame)) => frame,
            Ok(None) => break,
            Err(e) => return Err(StageError::Dataset(e.to_string())),
        };
        let stamp: Stamp = frame.colour.header().stamp.into();
        if let Some(imu) = imu.as_mut() {
            let on_imu_clock = Stamp::from_nanos(stamp.nanos().saturating_sub(imu_offset_ns));
            bag.imu_past(on_imu_clock, imu.feed())
                .map_err(|e| StageError::Dataset(e.to_string()))?;
            imu.prepare(index, stamp);
        }
        if index < start {
            index += 1;
            continue;
        }
        if ctx.mode() == Mode::Realtime {
            let first = *first.get_or_insert((index, stamp));
            let due = match ctx.settings.max_rate {
                Some(rate) if rate > 0.0 => (index - first.0) as f64 / rate,
                _ => stamp.secs_since(first.1),
            };
            pace(ctx, clock, due);
        }
        let decoded = decoders
            .0
            .colour(&frame.colour, &colour_topic)
            .and_then(|c| Ok((c, decoders.1.depth(&frame.depth, &depth_topic)?)));
        let converter = std::cell::RefCell::new(&mut converter);
        let publish = || -> Result<(), StageError> {
            if let Some(imu) = &imu {
                imu.publish()?;
            }
            let mut converter = converter.borrow_mut();
            let converted = match &decoded {
                Ok((colour, depth)) => {
                    let colour = Received {
                        image: colour,
                        topic: &colour_topic,
                    };
                    let depth = Received {
                        image: depth,
                        topic: &depth_topic,
                    };
                    publish_pair(&publisher, &layout, &mut converter, index, colour, depth)?
                }
                Err(e) => Err(e.clone()),
            };
            match converted {
                Ok(()) => Ok(()),
                Err(e) => {
                    tracing::warn!("source: frame {index}: {e}; publishing a blank frame");
                    publish_blank(&publisher, &layout, index, stamp)
                }
            }
        };
        publish()?;
        let ports = (&publisher, imu.as_ref());
        if ctx.mode() == Mode::Lockstep && !await_pose(ctx, ports, &poses, index, &publish)? {
            return Ok(());
        }
        index += 1;
        state.write(CHECKPOINT, &index, &mut scratch)?;
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
