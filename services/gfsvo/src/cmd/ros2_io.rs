//! What `gfsvo run` and `gfsvo ros2` do with ROS 2 besides the stages: a bag's frame
//! stamps and camera (the CameraInfo wins over the config, with one warning, through a
//! config file derived for the run's stages), and the `--mcap` recording of `/odom`,
//! `/tf` and the status.

use crate::CliResult;
use crate::config::Config;
use crate::pipeline::Covariances;
use gfs_core::camera::Camera;
use gfs_core::scene::Scene;
use gfs_core::stamp::Stamp;
use gfs_ipc::Profile;
use gfs_odometry::FramePose;
use gfs_ros2::bag::{BagTopics, BagWriter, Compression, scan};
use gfs_ros2::camera_info::{camera_from_info, cameras_differ};
use gfs_ros2::diagnostics::{DiagnosticsWindow, WINDOW_NS};
use gfs_ros2::msg::{Header, Time};
use gfs_ros2::odom::{OdometryPublisherState, TrackedPose};
use gfs_ros2::schema;
use gfs_ros2::visualisation::{
    KEYFRAMES_TOPIC, LANDMARKS_TOPIC, PATH_TOPIC, STRUCTURE_TOPIC, Visualiser, msg,
};
use std::path::{Path, PathBuf};

/// The topics of `config` a bag is scanned for (the frames; not the IMU).
pub fn bag_topics(config: &Config) -> BagTopics {
    BagTopics {
        colour: config.ros2.colour_topic.clone(),
        depth: config.ros2.depth_topic.clone(),
        camera_info: config.ros2.camera_info_topic.clone(),
        transport: config.ros2.transport,
        imu: None,
    }
}

/// A bag opened for a run: its frame stamps and the config file the stages read.
pub struct BagRun {
    /// Colour stamps of the frames.
    pub timestamps: Vec<Stamp>,
    /// The config for the stages (derived when the CameraInfo disagrees).
    pub config_path: Option<PathBuf>,
    /// The config with the bag's camera.
    pub config: Config,
}

/// Scans the bag; when its CameraInfo disagrees with the config's camera, writes
/// `out/config.toml` (the config with the CameraInfo's camera) for the stages.
///
/// # Errors
/// The bag cannot be read, has no frames, or its CameraInfo is invalid.
pub fn open_bag(
    bag: &Path,
    config_path: Option<&Path>,
    config: Config,
    out: &Path,
) -> CliResult<BagRun> {
    let topics = bag_topics(&config);
    let (timestamps, info) = scan(bag, &topics, config.ros2.slop_s)?;
    if timestamps.is_empty() {
        return Err(format!(
            "{}: no {} image pairs with {} within {} s",
            bag.display(),
            topics.colour,
            topics.depth,
            config.ros2.slop_s
        )
        .into());
    }
    let camera = camera_from_info(&info, &topics.camera_info, config.camera.readout_s)?;
    if !cameras_differ(&camera, &config.camera()?) {
        return Ok(BagRun {
            timestamps,
            config_path: config_path.map(Path::to_path_buf),
            config,
        });
    }
    tracing::warn!(
        "{}: the camera of {} differs from the config's; using the bag's",
        bag.display(),
        topics.camera_info
    );
    let path = out.join("config.toml");
    let config = derived_config(config_path, bag, &camera, &path)?;
    Ok(BagRun {
        timestamps,
        config_path: Some(path),
        config,
    })
}

/// Writes the config of `config_path` (or the dataset's built-in one) with `camera` into
/// `path`, and loads it.
fn derived_config(
    config_path: Option<&Path>,
    dataset: &Path,
    camera: &Camera,
    path: &Path,
) -> CliResult<Config> {
    write_config(config_path, dataset, "camera", camera_values(camera)?, path)
}

/// The `[camera]` values of `camera` (its `readout_s` is not among them: the config's
/// stays).
///
/// # Errors
/// None in practice: a camera's table is always TOML.
pub fn camera_values(camera: &Camera) -> CliResult<Vec<(String, toml::Value)>> {
    let table = toml::Table::try_from(camera.config(0.0))?;
    Ok(table
        .into_iter()
        .filter(|(k, _)| k != "readout_s")
        .collect())
}

/// Writes the config of `config_path` (or the dataset's built-in one) with `values` set
/// in its table `section` into `path`, and loads it: how a run's stages get the camera
/// of a bag or the topic flags of `gfsvo ros2`.
///
/// # Errors
/// The base config cannot be read, or the result is invalid.
pub fn write_config(
    config_path: Option<&Path>,
    dataset: &Path,
    section: &str,
    values: impl IntoIterator<Item = (impl Into<String>, toml::Value)>,
    path: &Path,
) -> CliResult<Config> {
    let (origin, text) = Config::source_text(config_path, dataset)?;
    let mut table: toml::Table = toml::from_str(&text).map_err(|e| format!("{origin}: {e}"))?;
    let entry = table
        .entry(section)
        .or_insert_with(|| toml::Value::Table(toml::Table::new()));
    if let toml::Value::Table(t) = entry {
        for (key, value) in values {
            t.insert(key.into(), value);
        }
    }
    let text = format!(
        "# {origin}, [{section}] set by the command line of the run\n{}",
        toml::to_string(&table)?
    );
    std::fs::write(path, text)?;
    Ok(Config::load(Some(path), dataset)?)
}

/// What a recording takes from the run besides the poses.
pub struct RunDetails<'a> {
    /// The latencies of the frames, when the run has a profile.
    pub profile: Option<&'a Profile>,
    /// Restarts of each stage.
    pub restarts: &'a [(String, u32)],
    /// The tracker's map after each keyframe, by the keyframe's stamp.
    pub scenes: &'a [(Stamp, Scene)],
    /// The frame points and tracking images, when recorded.
    pub frames: Option<super::frame_visuals::FrameVisuals<'a>>,
}

/// Writes `/odom`, `/tf` and the status of every pose into an MCAP file (ROS 2 profile),
/// stamped with the colour stamps the poses carry, with the covariance of each tracked pose (a pose
/// without one, predicted, gets the inflated "unknown" covariance); `/diagnostics`
/// once a second of the camera's clock; and the visualisation topics
/// `[ros2.visualisation]` switches on: the tracker's map after each keyframe
/// (`details.scenes`, by the keyframe's stamp) as landmarks, structure and keyframes,
/// and the path of the poses so far at `path_rate_hz` of their stamps and after the last;
/// each frame's points and tracking image (`details.frames`).
///
/// # Errors
/// The file cannot be written.
pub fn record_mcap(
    path: &Path,
    config: &Config,
    poses: &[FramePose],
    covariances: &Covariances,
    mut details: RunDetails<'_>,
    compression: Compression,
) -> CliResult {
    let ros2 = &config.ros2;
    let shown = &ros2.visualisation;
    let visualiser = Visualiser::new(ros2);
    let mut state = OdometryPublisherState::new(ros2);
    let mut writer = BagWriter::create(path, compression)?;
    let mut diagnostics = DiagnosticsWindow::new();
    let mut next_report = None;
    let mut scenes = details.scenes.iter().peekable();
    let mut path_so_far = Vec::with_capacity(poses.len());
    let mut next_path = None;
    let mut keyframes = 0;
    let path_period_ns = (1e9 / shown.path_rate_hz).round() as i64;
    let log_time = |stamp: Stamp| stamp.nanos().max(0) as u64;
    for (k, pose) in poses.iter().enumerate() {
        let stamp = pose.timestamp;
        while let Some((keyframe, scene)) = scenes.next_if(|(s, _)| *s <= stamp) {
            let at = log_time(*keyframe);
            keyframes = scene.keyframes.len();
            if shown.landmarks {
                let cloud = visualiser.landmarks(scene, *keyframe);
                writer.write(LANDMARKS_TOPIC, &msg::POINT_CLOUD2, at, &cloud)?;
            }
            if shown.structure {
                let markers = visualiser.structure(scene, *keyframe);
                writer.write(STRUCTURE_TOPIC, &msg::MARKER_ARRAY, at, &markers)?;
            }
            if shown.keyframes {
                let keyframes = visualiser.keyframes(scene, *keyframe);
                writer.write(KEYFRAMES_TOPIC, &msg::PATH, at, &keyframes)?;
            }
        }
        let messages = state.messages(&TrackedPose {
            stamp,
            world_from_camera: pose.world_from_camera,
            covariance: covariances.get(&pose.id.0).copied(),
            status: pose.status.as_str(),
            // The recorder sees the published (odom) poses only.
            map_from_odom: nalgebra::Isometry3::identity(),
        });
        let time = log_time(stamp);
        if let Some(odometry) = &messages.odometry {
            writer.write(&ros2.odom_topic, &schema::ODOMETRY, time, odometry)?;
        }
        if let Some(tf) = &messages.tf {
            writer.write(&ros2.tf_topic, &schema::TF_MESSAGE, time, tf)?;
        }
        writer.write(&ros2.status_topic, &schema::STRING, time, &messages.status)?;
        if let Some(frames) = &mut details.frames {
            frames.write(&mut writer, pose, (Time::from(stamp), time), keyframes)?;
        }
        path_so_far.push((stamp, pose.world_from_camera));
        let last = k + 1 == poses.len();
        if shown.path && (next_path.is_none_or(|next| stamp >= next) || last) {
            let message = visualiser.path(&path_so_far, stamp);
            writer.write(PATH_TOPIC, &msg::PATH, time, &message)?;
            next_path = Some(Stamp::from_nanos(stamp.nanos() + path_period_ns));
        }
        let now = time as i64;
        let latency_s = details
            .profile
            .and_then(|p| p.frame(pose.id.0))
            .and_then(|f| f.end_to_end_ns)
            .map(|ns| ns as f64 * 1e-9);
        diagnostics.frame_received(now);
        diagnostics.pose_published(now, latency_s, pose.status.as_str());
        let due = next_report.get_or_insert(now + WINDOW_NS);
        if now >= *due {
            while *due <= now {
                *due += WINDOW_NS;
            }
            let header = Header {
                stamp: Time::from(Stamp::from_nanos(now)),
                frame_id: String::new(),
            };
            let report = diagnostics.report(now, header, &ros2.colour_topic, details.restarts);
            writer.write(
                &ros2.diagnostics_topic,
                &schema::DIAGNOSTIC_ARRAY,
                time,
                &report,
            )?;
        }
    }
    writer.finish()?;
    Ok(())
}
