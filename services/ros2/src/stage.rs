//! The stage loop: DDS messages in, frames out; poses in, ROS 2 messages out. It plays
//! the source's role in the run (its stamps are the source's in `profile.json`).

use crate::dds::{DdsError, Endpoints, camera_info_only, endpoints};
use gfs_ipc::{FrameLayout, IpcRun, RunId, Stage, ipc, topics};
use gfs_pipeline::service::StageArgs;
use gfs_pipeline::stages::StageContext;
use gfs_pipeline::stages::ros2_frames::publish_pair;
use gfs_pipeline::wire::WirePose;
use gfs_ros2::camera_info::{camera_from_info, cameras_differ};
use gfs_ros2::image::{FrameConverter, Received};
use gfs_ros2::odom::{OdometryPublisherState, TrackedPose};
use gfs_ros2::pairing::{Paired, Pairer};
use gfs_ros2::transport::{TransportDecoder, TransportImage};
use std::io::Write;
use std::time::Duration;

/// The checkpoint: the id of the next frame (a restarted stage goes on from it).
const CHECKPOINT: &str = "ros2.bin";
/// The frames received, `id stamp` per line, for the trajectory `gfsvo ros2` writes.
const FRAMES_FILE: &str = "ros2-frames.txt";
/// How long the loop sleeps on the pose topic when nothing came.
const IDLE: Duration = Duration::from_millis(1);

/// Runs the stage until SIGINT / SIGTERM.
///
/// # Errors
/// When the config, the run's topics or DDS cannot be set up, or a topic fails.
pub fn run(args: &StageArgs) -> Result<(), DdsError> {
    let settings = args.settings()?;
    let run = IpcRun::new(RunId::new(&args.run_id)?)?;
    let ctx = StageContext::<ipc::Service>::process(run, Stage::Source, settings)?;
    let config = ctx.config().clone();
    let ros2 = &config.ros2;
    let camera = config.camera()?;
    let layout = FrameLayout::new(camera.pinhole.width, camera.pinhole.height, false)?;
    let publisher = ctx.publish::<u8>(topics::FRAME, layout.byte_len())?;
    let poses = ctx.subscribe::<WirePose>(topics::POSE)?;
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
    let (colour_topic, depth_topic) = ros2.image_topics();
    tracing::info!("subscribed to {colour_topic} and {depth_topic}; next frame {next_id}");
    let mut converter = FrameConverter::new(&camera, &config.depth);
    let mut pairer = Pairer::<TransportImage, TransportImage>::new(ros2.slop_s, 8);
    let mut decoders = (TransportDecoder::new(), TransportDecoder::new());
    let mut odometry = OdometryPublisherState::new(ros2);
    let mut camera_checked = false;
    let mut last_published: Option<u64> = None;
    while !ctx.stopping() {
        let mut busy = take_images(&dds, &mut pairer, (&colour_topic, &depth_topic));
        if !camera_checked && let Ok(Some((info, _))) = dds.camera_info.take() {
            camera_checked = true;
            match camera_from_info(&info, &ros2.camera_info_topic, config.camera.readout_s) {
                Ok(c) if cameras_differ(&c, &camera) => tracing::warn!(
                    "{}: the driver's camera {:?} differs from the config's {:?}; \
                     tracking with the config's (restart with a matching --config)",
                    ros2.camera_info_topic,
                    c.pinhole,
                    camera.pinhole
                ),
                Ok(_) => {}
                Err(e) => tracing::warn!("{e}; tracking with the config's camera"),
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
                    match publish_pair(&publisher, &layout, &mut converter, next_id, colour, depth)?
                    {
                        Ok(()) => {
                            if let Some(file) = frames_file.as_mut() {
                                writeln!(
                                    file,
                                    "{next_id} {:.9}",
                                    colour.image.header.stamp.secs()
                                )?;
                            }
                            next_id += 1;
                            state.write(CHECKPOINT, &next_id, &mut scratch)?;
                        }
                        Err(e) => tracing::warn!("{e}; frame skipped"),
                    }
                }
                Paired::ColourWithoutDepth(stamp) => tracing::warn!(
                    "{colour_topic} at {:.6} s: no {depth_topic} image within {} s; frame skipped",
                    stamp as f64 * 1e-9,
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
        }
        if !busy {
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
                        let (p, d) = (&camera.pinhole, &camera.distortion);
                        let table = gfs_core::camera::CameraConfig {
                            fx: p.fx,
                            fy: p.fy,
                            cx: p.cx,
                            cy: p.cy,
                            width: p.width,
                            height: p.height,
                            k1: d.k1,
                            k2: d.k2,
                            p1: d.p1,
                            p2: d.p2,
                            k3: d.k3,
                            readout_s: config.camera.readout_s,
                        };
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

fn publish<E: std::fmt::Debug>(result: Result<(), E>, topic: &str) {
    if let Err(e) = result {
        tracing::warn!("{topic}: not published: {e:?}");
    }
}
