//! The visualisation topics live (`[ros2.visualisation]`), off the frame path: a thread
//! of the stage with its own DDS participant reads what the tracker and the mapper
//! publish (poses, each frame's matches, the map after each keyframe) and publishes the
//! landmarks, structure, keyframes, path, frame points and tracking image. The stage's
//! loop only hands it each frame's id and stamp, and a copy of the colour image of the
//! frames due for a tracking image; it never waits on it. A frame is due once its stamp
//! reaches the last tracking image's plus `1 / tracking_image_rate_hz`: in realtime the
//! tracker may skip a frame, whose image is then never drawn, so the frames after it
//! stay due until one is.

use crate::dds::{DdsError, node, topic};
use gfs_core::RgbImage;
use gfs_core::scene::FrameView;
use gfs_core::stamp::Stamp;
use gfs_ipc::{
    IpcRun, MAX_VARIABLE_MESSAGE_BYTES, Mode, TopicSubscriber, decode_message, ipc, topics,
};
use gfs_odometry::session::MapUpdate;
use gfs_pipeline::wire::{WirePose, WireTrackedFeature};
use gfs_ros2::Ros2Config;
use gfs_ros2::image::{FrameConverter, Received};
use gfs_ros2::msg::{CompressedImage, Image, Time};
use gfs_ros2::visualisation::frame::{
    FRAME_POINTS_TOPIC, ImageFormat, RateGate, TrackingImage, camera_header, tracking_image,
};
use gfs_ros2::visualisation::msg::{MarkerArray, Path, PointCloud2};
use gfs_ros2::visualisation::{
    KEYFRAMES_TOPIC, LANDMARKS_TOPIC, PATH_TOPIC, STRUCTURE_TOPIC, Visualiser,
};
use nalgebra::Isometry3;
use ros2_client::Publisher;
use ros2_client::qos::{History, QosProfile};
use std::collections::BTreeMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicI64, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError, sync_channel};
use std::thread::JoinHandle;
use std::time::Duration;

/// Frames the loop may hand over before the thread takes them (more are dropped).
const QUEUE: usize = 64;
/// Frames whose stamp, status and colour the thread keeps while their matches come.
const FRAMES_KEPT: usize = 64;
/// Messages each publisher keeps for a reliable viewer that needs them again.
const FRAMES_KEPT_BY_DDS: usize = 30;
const IMAGES_KEPT_BY_DDS: usize = 4;
/// How long the thread sleeps on the pose topic when nothing came.
const IDLE: Duration = Duration::from_millis(5);

/// A frame the stage published: its id, colour stamp and camera frame, and its colour
/// image when due for a tracking image.
struct FrameIn {
    id: u64,
    stamp: Stamp,
    camera_frame: String,
    colour: Option<Image>,
}

/// The stage loop's end: hands frames to the thread, stops it when dropped.
pub struct Visuals {
    frames: SyncSender<FrameIn>,
    /// The stamp (ns) from which a frame is due for a tracking image; `i64::MAX`: never.
    next_image_ns: Arc<AtomicI64>,
    /// The tracking image's period, ns.
    period_ns: i64,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Visuals {
    /// Starts the thread when `[ros2.visualisation]` switches any topic on.
    ///
    /// # Errors
    /// The camera of the config is invalid.
    pub fn start(
        run: &IpcRun,
        mode: Mode,
        config: &gfs_pipeline::config::Config,
    ) -> Result<Option<Self>, DdsError> {
        let shown = &config.ros2.visualisation;
        if !(shown.landmarks
            || shown.structure
            || shown.keyframes
            || shown.path
            || shown.frame_points
            || shown.tracking_image)
        {
            return Ok(None);
        }
        let camera = config.camera()?;
        let converter = FrameConverter::new(&camera, &config.depth);
        let (sender, receiver) = sync_channel(QUEUE);
        let stop = Arc::new(AtomicBool::new(false));
        let next_image_ns = Arc::new(AtomicI64::new(if shown.tracking_image {
            i64::MIN
        } else {
            i64::MAX
        }));
        let period_ns = (1e9 / shown.tracking_image_rate_hz).round() as i64;
        let state = Thread {
            run: run.clone(),
            mode,
            ros2: config.ros2.clone(),
            visualiser: Visualiser::new(&config.ros2),
            camera: camera.pinhole,
            converter,
            frames: receiver,
            next_image_ns: Arc::clone(&next_image_ns),
            period_ns,
            stop: Arc::clone(&stop),
        };
        let thread = std::thread::Builder::new()
            .name("visualisation".to_owned())
            .spawn(move || {
                if let Err(e) = state.run() {
                    tracing::warn!("visualisation topics stopped: {e}");
                }
            })?;
        Ok(Some(Self {
            frames: sender,
            next_image_ns,
            period_ns,
            stop,
            thread: Some(thread),
        }))
    }

    /// Frame `id`, published by the stage with its `colour` image stamped `stamp`.
    pub fn frame(&mut self, id: u64, stamp: Stamp, colour: &Image) {
        let next = self.next_image_ns.load(Ordering::Relaxed);
        let ns = stamp.nanos();
        // A stamp far before the next due one is a camera that restarted its clock.
        let due = next != i64::MAX && (ns >= next || ns < next.saturating_sub(2 * self.period_ns));
        let frame = FrameIn {
            id,
            stamp,
            camera_frame: colour.header.frame_id.clone(),
            colour: due.then(|| colour.clone()),
        };
        if let Err(TrySendError::Full(_)) = self.frames.try_send(frame) {
            tracing::debug!("visualisation: behind; frame {id} not shown");
        }
    }
}

impl Drop for Visuals {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// What the thread keeps of a frame until its matches come.
#[derive(Default)]
struct FrameState {
    stamp: Option<Stamp>,
    camera_frame: String,
    colour: Option<Image>,
    status: Option<&'static str>,
}

/// The DDS publishers of the topics switched on.
struct Publishers {
    landmarks: Option<Publisher<PointCloud2>>,
    structure: Option<Publisher<MarkerArray>>,
    keyframes: Option<Publisher<Path>>,
    path: Option<Publisher<Path>>,
    frame_points: Option<Publisher<PointCloud2>>,
    image: Option<Publisher<Image>>,
    compressed: Option<Publisher<CompressedImage>>,
    _node: ros2_client::Node,
}

impl Publishers {
    fn new(ros2: &Ros2Config) -> Result<Self, DdsError> {
        let shown = &ros2.visualisation;
        let mut node = node("gfsvo_visualisation")?;
        // Reliable, as RViz subscribes; a second of frames kept for a slow viewer's
        // repairs (a few images).
        let qos = |depth| QosProfile::publisher_default().history(History::KeepLast { depth });
        macro_rules! publisher {
            ($on:expr, $name:expr, $pkg:literal, $ty:literal) => {
                publisher!($on, $name, $pkg, $ty, FRAMES_KEPT_BY_DDS)
            };
            ($on:expr, $name:expr, $pkg:literal, $ty:literal, $depth:expr) => {
                if $on {
                    let t = topic(&mut node, $name, $pkg, $ty, &qos($depth))?;
                    Some(node.create_publisher(&t, Some(qos($depth)))?)
                } else {
                    None
                }
            };
        }
        let raw = shown.tracking_image_format == ImageFormat::Raw;
        let image_topic = shown.tracking_image_format.topic();
        Ok(Self {
            landmarks: publisher!(
                shown.landmarks,
                LANDMARKS_TOPIC,
                "sensor_msgs",
                "PointCloud2"
            ),
            structure: publisher!(
                shown.structure,
                STRUCTURE_TOPIC,
                "visualization_msgs",
                "MarkerArray"
            ),
            keyframes: publisher!(shown.keyframes, KEYFRAMES_TOPIC, "nav_msgs", "Path"),
            path: publisher!(shown.path, PATH_TOPIC, "nav_msgs", "Path"),
            frame_points: publisher!(
                shown.frame_points,
                FRAME_POINTS_TOPIC,
                "sensor_msgs",
                "PointCloud2"
            ),
            image: publisher!(
                shown.tracking_image && raw,
                &image_topic,
                "sensor_msgs",
                "Image",
                IMAGES_KEPT_BY_DDS
            ),
            compressed: publisher!(
                shown.tracking_image && !raw,
                &image_topic,
                "sensor_msgs",
                "CompressedImage",
                IMAGES_KEPT_BY_DDS
            ),
            _node: node,
        })
    }
}

fn send<M: serde::Serialize>(publisher: &Option<Publisher<M>>, message: M, name: &str) {
    if let Some(p) = publisher
        && let Err(e) = p.publish(message)
    {
        tracing::warn!("{name}: not published: {e}");
    }
}

/// The thread's state.
struct Thread {
    run: IpcRun,
    mode: Mode,
    ros2: Ros2Config,
    visualiser: Visualiser,
    camera: gfs_core::camera::PinholeCamera,
    converter: FrameConverter,
    frames: Receiver<FrameIn>,
    next_image_ns: Arc<AtomicI64>,
    period_ns: i64,
    stop: Arc<AtomicBool>,
}

impl Thread {
    fn run(mut self) -> Result<(), DdsError> {
        let out = Publishers::new(&self.ros2)?;
        let node = self.run.node::<ipc::Service>("ros2-visualisation")?;
        let (run, mode) = (&self.run, self.mode);
        let poses: TopicSubscriber<_, WirePose> =
            TopicSubscriber::create(run, &node, topics::POSE.name, &topics::POSE.qos(mode))?;
        let tracked: TopicSubscriber<_, WireTrackedFeature> =
            TopicSubscriber::create(run, &node, topics::TRACKED.name, &topics::TRACKED.qos(mode))?;
        let maps: TopicSubscriber<_, u8> = TopicSubscriber::create(
            run,
            &node,
            topics::LOCAL_MAP.name,
            &topics::LOCAL_MAP.qos(mode),
        )?;
        let shown = self.ros2.visualisation.clone();
        let mut frames: BTreeMap<u64, FrameState> = BTreeMap::new();
        let mut path: Vec<(Stamp, Isometry3<f64>)> = Vec::new();
        let mut path_gate = RateGate::new(shown.path_rate_hz);
        let mut keyframes = 0;
        let mut view = FrameView::default();
        let mut image = RgbImage::new(0, 0);
        while !self.stop.load(Ordering::Relaxed) {
            let mut busy = false;
            while let Ok(frame) = self.frames.try_recv() {
                busy = true;
                let state = frames.entry(frame.id).or_default();
                state.stamp = Some(frame.stamp);
                state.camera_frame = frame.camera_frame;
                state.colour = frame.colour;
            }
            while let Some(sample) = poses.receive()? {
                busy = true;
                let Some(pose) = sample.payload().first().and_then(WirePose::pose) else {
                    continue;
                };
                let state = frames.entry(pose.id.0).or_default();
                state.status = Some(pose.status.as_str());
                if path.last().is_some_and(|(t, _)| *t >= pose.timestamp) {
                    continue;
                }
                path.push((pose.timestamp, pose.world_from_camera));
                if shown.path && path_gate.due(pose.timestamp) {
                    let message = self.visualiser.path(&path, pose.timestamp);
                    send(&out.path, message, PATH_TOPIC);
                }
            }
            while let Some(sample) = maps.receive()? {
                busy = true;
                let id = sample.user_header().frame_id;
                let update =
                    match decode_message::<MapUpdate>(sample.payload(), MAX_VARIABLE_MESSAGE_BYTES)
                    {
                        Ok(update) if update.keyframe.is_some() => update,
                        Ok(_) => continue,
                        Err(e) => {
                            tracing::warn!(frame = id, "visualisation: bad local map: {e}");
                            continue;
                        }
                    };
                let scene = update.scene();
                keyframes = scene.keyframes.len();
                let stamp = frames
                    .get(&id)
                    .and_then(|f| f.stamp)
                    .unwrap_or_else(|| sample.user_header().capture_stamp());
                send(
                    &out.landmarks,
                    self.visualiser.landmarks(&scene, stamp),
                    LANDMARKS_TOPIC,
                );
                send(
                    &out.structure,
                    self.visualiser.structure(&scene, stamp),
                    STRUCTURE_TOPIC,
                );
                send(
                    &out.keyframes,
                    self.visualiser.keyframes(&scene, stamp),
                    KEYFRAMES_TOPIC,
                );
            }
            while let Some(sample) = tracked.receive()? {
                busy = true;
                let id = sample.user_header().frame_id;
                let Some(state) = frames.get_mut(&id) else {
                    continue;
                };
                WireTrackedFeature::view(sample.payload(), &mut view);
                let stamp = state.stamp.map(Time::from).unwrap_or_default();
                let header = camera_header(stamp, &state.camera_frame, &shown.camera_frame);
                if shown.frame_points {
                    let cloud = self
                        .visualiser
                        .frame_points(&view, &self.camera, header.clone());
                    send(&out.frame_points, cloud, FRAME_POINTS_TOPIC);
                }
                let stamp_ns = state.stamp.map_or(i64::MIN, Stamp::nanos);
                // The frames copied while the image of an earlier one was on its way are
                // not due any more.
                let next = self.next_image_ns.load(Ordering::Relaxed);
                let due = stamp_ns >= next || stamp_ns < next.saturating_sub(2 * self.period_ns);
                if let Some(colour) = state.colour.take().filter(|_| due) {
                    self.next_image_ns
                        .store(stamp_ns.saturating_add(self.period_ns), Ordering::Relaxed);
                    let status = state.status.unwrap_or("unknown");
                    match self.draw(&colour, &view, (id, status, keyframes), &mut image) {
                        Ok(()) => match tracking_image(&image, header, shown.tracking_image_format)
                        {
                            Ok(TrackingImage::Raw(m)) => send(&out.image, m, "tracking image"),
                            Ok(TrackingImage::Compressed(m)) => {
                                send(&out.compressed, m, "tracking image");
                            }
                            Err(e) => tracing::warn!("{e}"),
                        },
                        Err(e) => tracing::warn!("tracking image of frame {id}: {e}"),
                    }
                }
            }
            while frames.len() > FRAMES_KEPT {
                frames.pop_first();
            }
            if !busy {
                poses.wait(IDLE)?;
            }
        }
        Ok(())
    }

    /// The tracking image of a frame into `image`.
    fn draw(
        &mut self,
        colour: &Image,
        view: &FrameView,
        (id, status, keyframes): (u64, &str, usize),
        image: &mut RgbImage,
    ) -> Result<(), DdsError> {
        let received = Received {
            image: colour,
            topic: &self.ros2.colour_topic,
        };
        self.converter.undistorted_colour(received, image)?;
        let line = gfs_plot::status_line(status, id, view, keyframes);
        gfs_plot::draw_tracking_image(image, view, &line)?;
        Ok(())
    }
}
