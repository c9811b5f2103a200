//! The stage loop: DDS messages in, frames out; poses in, ROS 2 messages out; resets
//! and pose hints asked for over ROS 2 on to the tracker, map saves to the mapper. It
//! plays the source's role in the run (its stamps are the source's in `profile.json`).

use crate::dds::{DdsError, Endpoints, camera_info_only, endpoints};
use crate::map_saves::MapSaves;
use crate::requests::Requests;
use crate::visuals::Visuals;
use gfs_core::stamp::Stamp;
use gfs_inertial::{ImuFeed, ImuSample};
use gfs_ipc::{FrameLayout, IpcRun, RunId, Stage, ipc, monotonic_ns, topics};
use gfs_pipeline::service::StageArgs;
use gfs_pipeline::stages::StageContext;
use gfs_pipeline::stages::imu::ImuOutbox;
use gfs_pipeline::stages::ros2_frames::publish_pair;
use gfs_pipeline::state::RESTARTS;
use gfs_pipeline::wire::WirePose;
use gfs_ros2::camera_info::{camera_from_info, cameras_differ};
use gfs_ros2::diagnostics::DiagnosticsWindow;
use gfs_ros2::image::{FrameConverter, Received};
use gfs_ros2::imu::ImuInput;
use gfs_ros2::msg::{Header, Time};
use gfs_ros2::odom::{OdometryPublisherState, TrackedPose};
use gfs_ros2::pairing::{Paired, Pairer};
use gfs_ros2::transport::{TransportDecoder, TransportImage};
use std::io::Write;
use std::time::{Duration, Instant};

/// The checkpoint: the id of the next frame (a restarted stage goes on from it).
const CHECKPOINT: &str = "ros2.bin";
/// The frames received, `id stamp` per line, for the trajectory `gfsvo ros2` writes.
const FRAMES_FILE: &str = "ros2-frames.txt";
/// How long the loop sleeps on the pose topic when nothing came.
const IDLE: Duration = Duration::from_millis(1);
/// How often `/diagnostics` is published.
const REPORT_EVERY: Duration = Duration::from_secs(1);
/// A colour stamp this far before the last one (ns) is a camera that restarted its
/// clock, not a late or repeated frame.
const CAMERA_RESTART_NS: i64 = 1_000_000_000;
/// How long a frame waits for an IMU sample past its stamp (the IMU's message is small
/// and usually there before the images): the preintegration needs the interval covered.
const IMU_WAIT: Duration = Duration::from_millis(10);

/// Runs the stage until SIGINT / SIGTERM.
///
/// # Errors
/// When the config, the run's topics or DDS cannot be set up, or a topic fails.
pub fn run(args: &StageArgs) -> Result<(), DdsError> {
    let settings = args.settings()?;
    let run = IpcRun::new(RunId::new(&args.run_id)?)?;
    let ctx = StageContext::<ipc::Service>::process(run.clone(), Stage::Source, settings)?;
    let config = ctx.config().clone();
    let ros2 = &config.ros2;
    let camera = config.camera()?;
    let layout = FrameLayout::new(camera.pinhole.width, camera.pinhole.height, false)?;
    let publisher = ctx.publish::<u8>(topics::FRAME, layout.byte_len())?;
    let poses = ctx.subscribe::<WirePose>(topics::POSE)?;
    let control = ctx.publish::<u8>(topics::CONTROL, 256)?;
    let state = ctx.state();
    let mut scratch = Vec::new();
    let mut next_id = state.read::<u64>(CHECKPOINT)?.unwrap_or(0);
    let mut frames_file = match &ctx.settings.state_dir {
        Some(dir) => {
            std::fs::create_dir_all(dir)?;
            let path = dir.join(FRAMES_FILE);
            let file = std::fs::OpenOptions::new()
                .create(true)
                .append(true)
                .open(&path);
            Some(file.map_err(|e| format!("{}: {e}", path.display()))?)
        }
        None => None,
    };
    let dds = endpoints(ros2)?;
    let save_path = ctx.settings.map_files.save_map.clone();
    let mut map_saves = MapSaves::open(&ctx, &ros2.save_map_service, save_path)?;
    let mut visuals = Visuals::start(&run, ctx.mode(), &config)?;
    let (colour_topic, depth_topic) = ros2.image_topics();
    tracing::info!("subscribed to {colour_topic} and {depth_topic}; next frame {next_id}");
    let mut converter = FrameConverter::new(&camera, &config.depth);
    let mut pairer = Pairer::<TransportImage, TransportImage>::new(ros2.slop_s, 8);
    let mut decoders = (TransportDecoder::new(), TransportDecoder::new());
    let mut odometry = OdometryPublisherState::new(ros2);
    let mut camera_checked = false;
    let mut last_published: Option<u64> = None;
    let mut diagnostics = DiagnosticsWindow::new();
    let mut next_report = Instant::now() + REPORT_EVERY;
    let mut imu_input = ImuInput::new(ros2.imu_topics());
    // Opened at the first IMU sample: a camera without IMU sends nothing on the topic.
    let mut imu: Option<ImuOutbox<ipc::Service>> = None;
    let mut imu_taken = Vec::new();
    while !ctx.stopping() {
        let mut busy = take_images(&dds, &mut pairer, (&colour_topic, &depth_topic));
        let to_tracker = Requests {
            dds: &dds,
            control: &control,
            odometry: &odometry,
            ros2,
            localising: ctx.settings.map_files.localize,
        };
        busy |= to_tracker.pass_on(next_id, &mut scratch)?;
        busy |= map_saves.serve(&dds.save_map)?;
        if take_imu(&dds, &mut imu_input, &mut imu_taken) {
            busy = true;
            feed_imu(&ctx, &imu_input, &mut imu, &mut imu_taken)?;
        }
        if !camera_checked && let Ok(Some((info, _))) = dds.camera_info.take() {
            camera_checked = true;
            match camera_from_info(&info, &ros2.camera_info_topic, config.camera.readout_s) {
                Ok(c) if cameras_differ(&c, &camera) => tracing::warn!(
                    "{}: the driver's camera {:?} differs from the one the run started \
                     with, {:?}; tracking on with the latter (restart the run to change)",
                    ros2.camera_info_topic,
                    c,
                    camera
                ),
                Ok(_) => {}
                Err(e) => tracing::warn!("{e}; tracking on with the camera the run started with"),
            }
        }
        while let Some(decision) = pairer.decide_next() {
            busy = true;
            match decision {
                Paired::Pair(colour, depth) => {
                    let decoded = decoders
                        .0
                        .colour(&colour, &colour_topic)
                        .and_then(|c| Ok((c, decoders.1.depth(&depth, &depth_topic)?)));
                    let (colour, depth) = match decoded {
                        Ok(pair) => pair,
                        Err(e) => {
                            tracing::warn!("{e}; frame skipped");
                            continue;
                        }
                    };
                    let colour = Received {
                        image: colour,
                        topic: &colour_topic,
                    };
                    let depth = Received {
                        image: depth,
                        topic: &depth_topic,
                    };
                    if imu.is_some() {
                        let stamp = Stamp::from(colour.image.header.stamp);
                        let deadline = Instant::now() + IMU_WAIT;
                        while imu.as_mut().is_some_and(|i| !i.feed().reaches_past(stamp))
                            && Instant::now() < deadline
                        {
                            std::thread::sleep(Duration::from_micros(200));
                            take_imu(&dds, &mut imu_input, &mut imu_taken);
                            feed_imu(&ctx, &imu_input, &mut imu, &mut imu_taken)?;
                        }
                        if let Some(imu) = imu.as_mut() {
                            // A pair that fails below keeps its id: the next frame's batch
                            // goes to the same id, and the tracker appends it.
                            imu.prepare(next_id, stamp);
                            imu.publish()?;
                        }
                    }
                    match publish_pair(&publisher, &layout, &mut converter, next_id, colour, depth)?
                    {
                        Ok(()) => {
                            diagnostics.frame_received(monotonic_ns() as i64);
                            let stamp = Stamp::from(colour.image.header.stamp);
                            if let Some(file) = frames_file.as_mut() {
                                writeln!(file, "{next_id} {stamp}")?;
                            }
                            if let Some(visuals) = visuals.as_mut() {
                                visuals.frame(next_id, stamp, colour.image);
                            }
                            next_id += 1;
                            state.write(CHECKPOINT, &next_id, &mut scratch)?;
                        }
                        Err(e) => tracing::warn!("{e}; frame skipped"),
                    }
                }
                Paired::NotAfter { stamp, last } if last - stamp > CAMERA_RESTART_NS => {
                    tracing::warn!(
                        "{colour_topic}: the stamps went back from {} to {}: the camera \
                         restarted; going on from there",
                        Stamp::from_nanos(last),
                        Stamp::from_nanos(stamp)
                    );
                    pairer.restart(stamp);
                }
                Paired::NotAfter { stamp, last } => tracing::warn!(
                    "{colour_topic} at {}: not after the frame before it, at {}; frame skipped",
                    Stamp::from_nanos(stamp),
                    Stamp::from_nanos(last)
                ),
                Paired::ColourWithoutDepth(stamp) => tracing::warn!(
                    "{colour_topic} at {}: no {depth_topic} image within {} s; frame skipped",
                    Stamp::from_nanos(stamp),
                    ros2.slop_s
                ),
            }
        }
        while let Some(sample) = poses.receive()? {
            busy = true;
            let Some(wire) = sample.payload().first() else {
                continue;
            };
            let Some(pose) = wire.pose() else {
                continue;
            };
            // A restarted tracker may send a pose again: publish each frame once.
            if last_published.is_some_and(|last| pose.id.0 <= last) {
                continue;
            }
            last_published = Some(pose.id.0);
            let received_ns = sample.user_header().stamp(Stage::Source).received_ns;
            let now_ns = monotonic_ns();
            let latency_s = (received_ns != 0 && now_ns >= received_ns)
                .then(|| (now_ns - received_ns) as f64 * 1e-9);
            // The frame's colour stamp as received, carried bit for bit by the pipeline.
            let messages = odometry.messages(&TrackedPose {
                stamp: pose.timestamp,
                world_from_camera: pose.world_from_camera,
                covariance: wire.covariance(),
                status: pose.status.as_str(),
                map_from_odom: wire.map_from_odom(),
            });
            if let Some(odom) = messages.odometry {
                publish(dds.odom.publish(odom), &ros2.odom_topic);
            }
            if let Some(tf) = messages.tf {
                publish(dds.tf.publish(tf), &ros2.tf_topic);
            }
            publish(dds.status.publish(messages.status), &ros2.status_topic);
            diagnostics.pose_published(now_ns as i64, latency_s, pose.status.as_str());
            if wire.is_keyframe() {
                diagnostics.keyframe(wire.starts_new_map());
            }
            diagnostics.imu_taken(u64::from(wire.imu_samples));
        }
        if Instant::now() >= next_report {
            next_report += REPORT_EVERY;
            // The supervisor writes the restarts once a stage restarted; none before.
            let restarts = state
                .read(RESTARTS)
                .ok()
                .flatten()
                .unwrap_or_else(|| Stage::ALL.map(|s| (s.name().to_owned(), 0)).to_vec());
            let report = diagnostics.report(
                monotonic_ns() as i64,
                Header {
                    stamp: Time::from(Stamp::now()),
                    frame_id: String::new(),
                },
                &ros2.colour_topic,
                &restarts,
            );
            publish(dds.diagnostics.publish(report), &ros2.diagnostics_topic);
        }
        if !busy {
            if let Some(imu) = &imu {
                imu.update_connections()?;
            }
            publisher.update_connections()?;
            poses.wait(IDLE)?;
        }
    }
    Ok(())
}

/// Waits up to `timeout_s` for a valid CameraInfo and writes its camera (with the
/// config's `readout_s`) as a `[camera]` table into `path`.
///
/// # Errors
/// No valid CameraInfo in time (the last problem is named), DDS or the file.
pub fn probe_camera(
    args: &StageArgs,
    path: &std::path::Path,
    timeout_s: f64,
) -> Result<(), DdsError> {
    let config = args.settings()?.config;
    let ros2 = &config.ros2;
    let (_node, camera_info) = camera_info_only(ros2)?;
    let deadline = std::time::Instant::now() + Duration::from_secs_f64(timeout_s.max(0.0));
    let mut problem = format!("no message on {}", ros2.camera_info_topic);
    while std::time::Instant::now() < deadline {
        match camera_info.take() {
            Ok(Some((info, _))) => {
                match camera_from_info(&info, &ros2.camera_info_topic, config.camera.readout_s) {
                    Ok(camera) => {
                        let table = camera.config(config.camera.readout_s);
                        std::fs::write(path, toml::to_string(&table)?)?;
                        return Ok(());
                    }
                    Err(e) => problem = e.to_string(),
                }
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(20)),
            Err(e) => problem = format!("{}: {e:?}", ros2.camera_info_topic),
        }
    }
    Err(format!("no valid CameraInfo within {timeout_s} s: {problem}").into())
}

/// Moves the images that arrived into the pairer; true when any did.
fn take_images(
    dds: &Endpoints,
    pairer: &mut Pairer<TransportImage, TransportImage>,
    (colour_topic, depth_topic): (&str, &str),
) -> bool {
    let mut any = false;
    loop {
        match dds.colour.take() {
            Ok(Some(image)) => {
                pairer.push_colour(image.header().stamp.nanos(), image);
                any = true;
            }
            Ok(None) => break,
            Err(e) => {
                tracing::warn!("{colour_topic}: undecodable message: {e}");
                break;
            }
        }
    }
    loop {
        match dds.depth.take() {
            Ok(Some(image)) => {
                pairer.push_depth(image.header().stamp.nanos(), image);
                any = true;
            }
            Ok(None) => break,
            Err(e) => {
                tracing::warn!("{depth_topic}: undecodable message: {e}");
                break;
            }
        }
    }
    any
}

/// Moves the IMU messages that arrived through `input`'s checks into `taken`; true
/// when any arrived.
fn take_imu(dds: &Endpoints, input: &mut ImuInput, taken: &mut Vec<ImuSample>) -> bool {
    let mut any = false;
    for (which, subscription) in &dds.imu {
        loop {
            match subscription.take() {
                Ok(Some((message, _))) => {
                    input.push(*which, &message, taken);
                    any = true;
                }
                Ok(None) => break,
                Err(e) => {
                    tracing::warn!("{:?} IMU topic: undecodable message: {e:?}", which);
                    break;
                }
            }
        }
    }
    any
}

/// Puts the samples `taken` into the IMU's feed, opening the `imu` topic at the first.
fn feed_imu(
    ctx: &StageContext<ipc::Service>,
    input: &ImuInput,
    imu: &mut Option<ImuOutbox<ipc::Service>>,
    taken: &mut Vec<ImuSample>,
) -> Result<(), DdsError> {
    if taken.is_empty() {
        return Ok(());
    }
    let outbox = match imu {
        Some(outbox) => outbox,
        None => {
            let t = input.topics();
            let name = format!("{} (or {} + {})", t.unified, t.gyro, t.accel);
            tracing::info!("IMU samples from {name}: passed on to the tracker");
            imu.insert(ImuOutbox::open(ctx, name, ImuFeed::LIVE_CAPACITY)?)
        }
    };
    for sample in taken.drain(..) {
        outbox.feed().push(sample);
    }
    Ok(())
}

fn publish<E: std::fmt::Debug>(result: Result<(), E>, topic: &str) {
    if let Err(e) = result {
        tracing::warn!("{topic}: not published: {e:?}");
    }
}
