//! What `gfsvo run` and `gfsvo ros2` do with ROS 2 besides the stages: a bag's frame
//! stamps and camera (the CameraInfo wins over the config, with one warning, through a
//! config file derived for the run's stages), and the `--mcap` recording of `/odom`,
//! `/tf` and the status.

use crate::CliResult;
use crate::config::Config;
use crate::pipeline::Covariances;
use gfs_core::camera::Camera;
use gfs_odometry::FramePose;
use gfs_ros2::bag::{BagTopics, BagWriter, Compression, scan};
use gfs_ros2::camera_info::{camera_from_info, cameras_differ};
use gfs_ros2::odom::{OdometryPublisherState, TrackedPose};
use gfs_ros2::schema;
use std::path::{Path, PathBuf};

/// The topics of `config` a bag is read for.
pub fn bag_topics(config: &Config) -> BagTopics {
    BagTopics {
        colour: config.ros2.colour_topic.clone(),
        depth: config.ros2.depth_topic.clone(),
        camera_info: config.ros2.camera_info_topic.clone(),
        transport: config.ros2.transport,
    }
}

/// A bag opened for a run: its frame stamps and the config file the stages read.
pub struct BagRun {
    /// Colour stamps of the frames, seconds.
    pub timestamps: Vec<f64>,
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
    write_config(config_path, dataset, "camera", camera_values(camera), path)
}

/// The `[camera]` values of `camera` (its `readout_s` is not among them: the config's
/// stays).
pub fn camera_values(camera: &Camera) -> Vec<(&'static str, toml::Value)> {
    let (p, d) = (&camera.pinhole, &camera.distortion);
    let mut values: Vec<(&str, toml::Value)> = [
        ("fx", p.fx),
        ("fy", p.fy),
        ("cx", p.cx),
        ("cy", p.cy),
        ("k1", d.k1),
        ("k2", d.k2),
        ("p1", d.p1),
        ("p2", d.p2),
        ("k3", d.k3),
    ]
    .into_iter()
    .map(|(k, v)| (k, toml::Value::Float(v)))
    .collect();
    values.push(("width", toml::Value::Integer(p.width as i64)));
    values.push(("height", toml::Value::Integer(p.height as i64)));
    values
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
    values: Vec<(&'static str, toml::Value)>,
    path: &Path,
) -> CliResult<Config> {
    let (origin, text) = Config::source_text(config_path, dataset)?;
    let mut table: toml::Table = toml::from_str(&text).map_err(|e| format!("{origin}: {e}"))?;
    let entry = table
        .entry(section)
        .or_insert_with(|| toml::Value::Table(toml::Table::new()));
    if let toml::Value::Table(t) = entry {
        for (key, value) in values {
            t.insert(key.to_owned(), value);
        }
    }
    let text = format!(
        "# {origin}, [{section}] set by the command line of the run\n{}",
        toml::to_string(&table)?
    );
    std::fs::write(path, text)?;
    Ok(Config::load(Some(path), dataset)?)
}

/// Writes `/odom`, `/tf` and the status of every pose into an MCAP file (ROS 2 profile),
/// stamped with the colour stamps, with the covariance of each tracked pose (a pose
/// without one, predicted, gets the inflated "unknown" covariance).
///
/// # Errors
/// The file cannot be written.
pub fn record_mcap(
    path: &Path,
    config: &Config,
    poses: &[FramePose],
    covariances: &Covariances,
    compression: Compression,
) -> CliResult {
    let ros2 = &config.ros2;
    let mut state = OdometryPublisherState::new(ros2);
    let mut writer = BagWriter::create(path, compression)?;
    for pose in poses {
        let messages = state.messages(&TrackedPose {
            stamp: pose.timestamp,
            world_from_camera: pose.world_from_camera,
            covariance: covariances.get(&pose.id.0).copied(),
            status: pose.status.as_str(),
            // The recorder sees the published (odom) poses only.
            map_from_odom: nalgebra::Isometry3::identity(),
        });
        let time = (pose.timestamp.max(0.0) * 1e9).round() as u64;
        if let Some(odometry) = &messages.odometry {
            writer.write(&ros2.odom_topic, &schema::ODOMETRY, time, odometry)?;
        }
        if let Some(tf) = &messages.tf {
            writer.write(&ros2.tf_topic, &schema::TF_MESSAGE, time, tf)?;
        }
        writer.write(&ros2.status_topic, &schema::STRING, time, &messages.status)?;
    }
    writer.finish()?;
    Ok(())
}
