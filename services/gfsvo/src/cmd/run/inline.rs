//! `--mode inline`: the front end and the odometry in this thread, frame after frame
//! (no processes, no shared memory): the library path the tests also drive.

use super::map_file::MapArgs;
use crate::CliResult;
use crate::bench::stats::Summary;
use crate::config::Config;
use gfs_core::Image;
use gfs_core::ids::FrameId;
use gfs_dataset::{DEFAULT_READ_AHEAD, Sequence};
use gfs_odometry::loop_closing::LoopClosure;
use gfs_odometry::map_file::MapCamera;
use gfs_odometry::{FinalTrajectory, FramePose, Frontend, Odometry, OdometryConfig};
use indicatif::ProgressBar;
use std::collections::BTreeMap;

/// Poses, per-stage timings and keyframes of an inline run.
pub struct InlineOutcome {
    /// One pose per input frame: the final best estimate (each frame's reference
    /// keyframe as the map holds it at the end, composed with the frame's pose relative
    /// to it), in the map frame.
    pub poses: Vec<FramePose>,
    /// One pose per input frame as published live: the continuous odometry.
    pub odometry: Vec<FramePose>,
    /// The loops closed.
    pub loops: Vec<LoopClosure>,
    /// Milliseconds per stage.
    pub timings: BTreeMap<&'static str, Summary>,
    /// Tracking milliseconds per block of [`BLOCK_FRAMES`] frames, in order (is the
    /// time per frame flat over a long run?).
    pub tracking_blocks: Vec<Summary>,
    /// Keyframes in the map at the end.
    pub keyframes: usize,
    /// Keyframes of the tracker's map (the neighbourhood of the last map update) at
    /// the end.
    pub tracker_keyframes: usize,
    /// The tracker's map and the whole map at the end as messages (`None` when
    /// larger than a message may be).
    pub map_bytes: Option<MapBytes>,
    /// The whole map at the end as a viewer draws it, when asked for.
    pub scene: Option<gfs_core::scene::Scene>,
    /// True when SIGINT / SIGTERM stopped the run: `poses` holds the frames done.
    pub interrupted: bool,
    /// The covariance of each tracked frame's published pose, by frame id.
    pub covariances: crate::pipeline::Covariances,
    /// Keyframes made by this run (0 when localising in a loaded map).
    pub keyframes_added: usize,
    /// Lost frames found again in the whole map (the first frame on a loaded map
    /// without a pose hint among them).
    pub relocalisations: usize,
}

/// Frames per block of [`InlineOutcome::tracking_blocks`].
pub const BLOCK_FRAMES: usize = 500;

/// Runs `total` frames of `sequence` from frame `map.start` (and draws the final map
/// `with_scene`), from and to the map files of `map`.
///
/// # Errors
/// When a stage's config is invalid, a frame's features do not line up, or a map file
/// cannot be read or written.
pub fn run(
    config: &Config,
    odometry_config: OdometryConfig,
    sequence: &Sequence,
    total: usize,
    progress: &ProgressBar,
    with_scene: bool,
    map: &MapArgs,
) -> CliResult<InlineOutcome> {
    let pinhole = config.camera()?.pinhole;
    let mut frontend = Frontend::new(
        pinhole,
        &config.points,
        &config.lines,
        &config.planes,
        odometry_config.tracking.use_lines,
        odometry_config.tracking.use_manhattan,
    )?;
    frontend.set_keep_depth(odometry_config.tracking.use_depth_alignment);
    frontend.set_keep_planes(odometry_config.tracking.use_planes);
    let mut imu = if odometry_config.tracking.use_imu {
        ImuFeed::read(sequence, config.imu.time_offset_s)?
    } else {
        None
    };
    let levels =
        u8::try_from(config.points.levels).map_err(|_| "points.levels must be below 256")?;
    let scale_factor = f64::from(config.points.scale_factor);
    let mut odometry = Odometry::new(
        odometry_config,
        pinhole,
        scale_factor,
        levels,
        &config.lines.grid,
    );
    let map_camera = MapCamera {
        camera: pinhole,
        scale_factor,
        levels,
    };
    map.load_into(&mut odometry, &map_camera)?;
    let mut times = StageTimes::default();
    let mut poses = Vec::with_capacity(total);
    let mut finals = FinalTrajectory::with_capacity(total);
    let mut interrupted = false;
    let mut covariances = crate::pipeline::Covariances::new();
    let (width, height) = (pinhole.width, pinhole.height);
    let blank = (
        Image::<u8>::new(width, height),
        Image::<f32>::new(width, height),
    );
    let frames = sequence.frames_from(map.start, Some(map.start + total), DEFAULT_READ_AHEAD);
    for (index, frame) in (map.start..).zip(frames) {
        if crate::pipeline::signals::interrupted() {
            interrupted = true;
            break;
        }
        // One policy in every mode: an unreadable frame goes through the front end as a
        // blank frame (as the pipeline's source publishes it), and a frame with no
        // feature gets the motion-model prediction.
        let (id, timestamp, gray, depth) = match &frame {
            Ok(frame) => (
                frame.id,
                frame.timestamp,
                frame.gray.view(),
                frame.depth.view(),
            ),
            Err(e) => {
                tracing::warn!("frame {index}: {e}; its pose is predicted");
                let timestamp = sequence
                    .timestamps()
                    .get(index)
                    .copied()
                    .unwrap_or_default();
                (
                    FrameId(index as u64),
                    timestamp,
                    blank.0.view(),
                    blank.1.view(),
                )
            }
        };
        if let Some(imu) = &mut imu {
            imu.push_until(timestamp, &mut odometry);
        }
        let rotation = odometry.predicted_rotation();
        let features = frontend.extract(id, timestamp, gray, depth, rotation.as_ref())?;
        let pose = if features.is_blank() {
            odometry.skip(id, timestamp)
        } else {
            odometry.process(features)?
        };
        if let Some(covariance) = odometry.pose_covariance() {
            covariances.insert(pose.id.0, covariance);
        }
        times.record(&frontend, &odometry);
        finals.record(
            odometry.anchor(&pose),
            odometry.map_from_odom() * pose.world_from_camera,
        );
        poses.push(pose);
        progress.inc(1);
    }
    map.save_from(&odometry, &map_camera)?;
    Ok(InlineOutcome {
        poses: finals.finish(odometry.map(), &poses),
        odometry: poses,
        loops: odometry.loops().to_vec(),
        tracking_blocks: times.tracking_blocks(),
        timings: times.summarise(),
        keyframes: odometry.map().keyframe_count(),
        tracker_keyframes: odometry.tracking().map().keyframe_count(),
        map_bytes: map_bytes(&odometry),
        scene: with_scene.then(|| odometry.map().scene()),
        interrupted,
        covariances,
        keyframes_added: odometry.keyframes_added(),
        relocalisations: odometry.relocalisations(),
    })
}

/// The samples of the folder's `imu.txt`, handed to the odometry frame by frame.
struct ImuFeed {
    feed: gfs_inertial::ImuFeed,
    batch: Vec<gfs_inertial::ImuSample>,
    path: std::path::PathBuf,
}

impl ImuFeed {
    /// The folder's samples moved onto the camera's clock by `offset_s`; `None` when
    /// the folder has no `imu.txt`. Every line skipped is warned about by file and line.
    fn read(sequence: &Sequence, offset_s: f64) -> CliResult<Option<Self>> {
        let Some(list) = gfs_dataset::read_imu(sequence.dir())? else {
            return Ok(None);
        };
        for warning in &list.warnings {
            tracing::warn!("{warning}");
        }
        tracing::info!(samples = list.samples.len(), "IMU samples from imu.txt");
        let mut feed = gfs_inertial::ImuFeed::new(offset_s, list.samples.len());
        for sample in list.samples {
            feed.push(sample);
        }
        Ok(Some(Self {
            feed,
            batch: Vec::new(),
            path: sequence.dir().join(gfs_dataset::IMU_LIST),
        }))
    }

    /// Pushes the samples up to `stamp` and the first one past it.
    fn push_until(&mut self, stamp: gfs_core::stamp::Stamp, odometry: &mut Odometry) {
        self.batch.clear();
        self.feed.through(stamp, &mut self.batch);
        for sample in &self.batch {
            match odometry.push_imu(*sample) {
                gfs_inertial::Pushed::Kept => {}
                gfs_inertial::Pushed::KeptWith(issue) | gfs_inertial::Pushed::Dropped(issue) => {
                    tracing::warn!("{}: {issue}", self.path.display());
                }
            }
        }
    }
}

/// The size of the maps as messages, and what the whole map costs the loop stage.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct MapBytes {
    /// Bincode bytes of the tracker's map.
    pub tracker: usize,
    /// Bincode bytes of the whole map.
    pub global: usize,
    /// Milliseconds to encode the whole map.
    pub global_encode_ms: f64,
    /// Milliseconds to decode it.
    pub global_decode_ms: f64,
}

fn map_bytes(odometry: &Odometry) -> Option<MapBytes> {
    let mut buf = Vec::new();
    let tracker = gfs_ipc::encode_message(odometry.tracking().map(), &mut buf).ok()?;
    let start = std::time::Instant::now();
    let global = gfs_ipc::encode_message(odometry.map(), &mut buf).ok()?;
    let global_encode_ms = start.elapsed().as_secs_f64() * 1e3;
    let start = std::time::Instant::now();
    gfs_ipc::decode_message::<gfs_odometry::map::Map>(&buf, global).ok()?;
    let global_decode_ms = start.elapsed().as_secs_f64() * 1e3;
    Some(MapBytes {
        tracker,
        global,
        global_encode_ms,
        global_decode_ms,
    })
}

/// Per-frame milliseconds of each stage.
#[derive(Default)]
struct StageTimes {
    points: Vec<f64>,
    lines: Vec<f64>,
    planes: Vec<f64>,
    tracking: Vec<f64>,
    mapping: Vec<f64>,
}

impl StageTimes {
    fn record(&mut self, frontend: &Frontend, odometry: &Odometry) {
        let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
        let f = frontend.timings();
        self.points.push(ms(f.points));
        self.lines.push(ms(f.lines));
        self.planes.push(ms(f.planes));
        let o = odometry.timings();
        self.tracking.push(ms(o.tracking));
        if let Some(m) = o.mapping {
            self.mapping.push(ms(m));
        }
    }

    fn tracking_blocks(&self) -> Vec<Summary> {
        self.tracking
            .chunks(BLOCK_FRAMES)
            .map(|block| Summary::of(&mut block.to_vec()))
            .collect()
    }

    fn summarise(mut self) -> BTreeMap<&'static str, Summary> {
        [
            ("points", Summary::of(&mut self.points)),
            ("lines", Summary::of(&mut self.lines)),
            ("planes", Summary::of(&mut self.planes)),
            ("tracking", Summary::of(&mut self.tracking)),
            ("mapping_per_keyframe", Summary::of(&mut self.mapping)),
        ]
        .into_iter()
        .collect()
    }
}
