//! The config file: camera, depth and algorithm parameters, one TOML table per stage.
//!
//! The configs of `configs/` are built into the binary, so that `gfsvo` works from any
//! folder; `--config FILE` reads any other file with the same tables.

use crate::scheduling::SchedulingConfig;
use gfs_core::camera::{Camera, CameraConfig};
use gfs_dataset::{DepthConfig, DepthSensor};
use gfs_odometry::DepthNoise;
use serde::Deserialize;
use std::path::Path;

/// Everything a run or a benchmark is configured by.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// `[camera]`: intrinsics and distortion of the colour camera.
    pub camera: CameraConfig,
    /// `[depth]`: depth scale and valid range.
    #[serde(default)]
    pub depth: DepthConfig,
    /// `[planes]`: pixel normals, BFS plane extraction, Manhattan axes.
    #[serde(default)]
    pub planes: gfs_planes::PlaneConfig,
    /// `[lines]`: line detection, homogenisation, LBD and 3D lines.
    #[serde(default)]
    pub lines: gfs_lines::LineConfig,
    /// `[points]`: ORB extraction (pyramid, FAST thresholds, feature budget, depth range).
    #[serde(default)]
    pub points: gfs_points::OrbConfig,
    /// `[tracking]`: matching thresholds, inlier limits and the lines / Manhattan switches.
    #[serde(default)]
    pub tracking: gfs_odometry::TrackingConfig,
    /// `[keyframes]`: keyframe selection and culling on points and lines.
    #[serde(default)]
    pub keyframes: gfs_odometry::KeyframeConfig,
    /// `[mapping]`: landmark creation and the local BA.
    #[serde(default)]
    pub mapping: gfs_odometry::MappingConfig,
    /// `[loop_closing]`: loop detection, verification and the pose-graph correction.
    #[serde(default)]
    pub loop_closing: gfs_odometry::LoopClosingConfig,
    /// `[pipeline]`: deadlines, resends and the restart policy of the stage services.
    #[serde(default)]
    pub pipeline: PipelineConfig,
    /// `[ros2]`: topics, frames and lost-tracking output of the ROS 2 stage and bags.
    #[serde(default)]
    pub ros2: gfs_ros2::Ros2Config,
    /// `[imu]`: the IMU's mount in the camera, its noise and clock offset.
    #[serde(default)]
    pub imu: gfs_inertial::ImuConfig,
}

/// `[pipeline]`: how long stages wait for each other and how dead stages are restarted.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PipelineConfig {
    /// Lockstep: how long the tracker waits for a frame's missing feature message before
    /// it tracks the frame without it (degraded), ms. Long enough for a killed stage to
    /// be restarted and to deliver the frame again from history. Default 3000.
    pub lockstep_feature_deadline_ms: u64,
    /// Realtime: the same deadline, ms; short, so that a dead stage costs a few frames'
    /// quality, not the camera rate. Default 150.
    pub realtime_feature_deadline_ms: u64,
    /// A request still unanswered after this long is sent again (a keyframe to a
    /// restarted mapper, a frame to restarted front-end stages), ms. Default 4000.
    pub resend_after_ms: u64,
    /// Restarts of one stage within `restart_window_s` after which the supervisor gives
    /// up on the run. Default 5.
    pub max_restarts: u32,
    /// The window of `max_restarts`, seconds. Default 30.
    pub restart_window_s: u64,
    /// A stage that publishes nothing for this long while its input waits is taken for
    /// hung (stopped, deadlocked) and killed, then restarted as a dead one is, ms. Above
    /// both feature deadlines (a stage may wait that long for a missing input). Default
    /// 20000.
    pub hang_timeout_ms: u64,
    /// Realtime: how long a keyframe's local mapping may take before its local BA stops
    /// at its best iterate, ms; the BA also stops as soon as the next keyframe request
    /// arrives (ORB-SLAM2's abort flag). Lockstep and inline runs ignore it, so that
    /// they stay reproducible. Default 40 (docs/results.md, "Latency").
    pub realtime_ba_budget_ms: u64,
    /// `[pipeline.scheduling.<stage>]`: nice level, policy and CPUs of each stage.
    pub scheduling: SchedulingConfig,
}

impl Default for PipelineConfig {
    fn default() -> Self {
        Self {
            lockstep_feature_deadline_ms: 3000,
            realtime_feature_deadline_ms: 150,
            resend_after_ms: 4000,
            max_restarts: 5,
            restart_window_s: 30,
            hang_timeout_ms: 20_000,
            realtime_ba_budget_ms: 40,
            scheduling: SchedulingConfig::default(),
        }
    }
}

/// The built-in configs, by name (the file stem in `configs/`).
const BUILT_IN: &[(&str, &str)] = &[
    ("tum1", include_str!("../../../configs/tum1.toml")),
    ("tum2", include_str!("../../../configs/tum2.toml")),
    ("tum3", include_str!("../../../configs/tum3.toml")),
    ("icl", include_str!("../../../configs/icl.toml")),
    ("7scenes", include_str!("../../../configs/7scenes.toml")),
    ("synthetic", include_str!("../../../configs/synthetic.toml")),
];

/// The config file `gfsvo synth` writes into the folders it renders.
const SYNTHETIC_MARKER: &str = "synthetic.toml";

/// A config could not be found, read or understood.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("cannot read config {path}: {source}")]
    Read {
        /// The file.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The TOML is malformed or a field is wrong; the message names line and field.
    #[error("config {path}: {message}")]
    Parse {
        /// The file (or built-in name).
        path: String,
        /// What is wrong, and where.
        message: String,
    },
    /// The dataset folder name does not say which camera took it.
    #[error(
        "cannot tell the camera of {dataset} from its name (expected fr1/fr2/fr3, freiburg1..3, \
         7scenes, icl/living_room/office or synthetic in it): pass --config FILE"
    )]
    UnknownCamera {
        /// The dataset folder.
        dataset: String,
    },
}

impl Config {
    /// Parses a config from TOML text; `origin` names it in errors.
    ///
    /// # Errors
    /// [`ConfigError::Parse`] naming the line and field that is wrong, including a camera
    /// that cannot exist (non-positive focal length, principal point outside the image).
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, ConfigError> {
        let parse_error = |message: String| ConfigError::Parse {
            path: origin.to_owned(),
            message: clip_lines(&message),
        };
        let config: Config = toml::from_str(text).map_err(|e| parse_error(e.to_string()))?;
        Camera::from_config(&config.camera).map_err(|e| parse_error(e.to_string()))?;
        config.validate_stages().map_err(parse_error)?;
        Ok(config)
    }

    /// Checks the tables the stages validate when they start, so that a bad value is
    /// reported once, here, rather than by a stage that then dies on every restart.
    fn validate_stages(&self) -> Result<(), String> {
        self.points.validate().map_err(|e| e.to_string())?;
        self.lines.detect.validate().map_err(|e| e.to_string())?;
        self.planes.validate().map_err(|e| e.to_string())?;
        self.validate_tables().map_err(|e| e.to_string())?;
        self.pipeline
            .scheduling
            .validate()
            .map_err(|e| e.to_string())?;
        self.imu.validate()?;
        self.ros2.validate()
    }

    /// The config in `path`; else the folder's own `synthetic.toml` (written by
    /// `gfsvo synth` with the camera it rendered with); else the built-in config that the
    /// dataset folder name names.
    ///
    /// # Errors
    /// [`ConfigError`] when the file cannot be read or parsed, or no built-in config fits.
    pub fn load(path: Option<&Path>, dataset: &Path) -> Result<Self, ConfigError> {
        let own = dataset.join(SYNTHETIC_MARKER);
        match path {
            Some(path) => Self::read(path),
            None if own.is_file() => Self::read(&own),
            None => {
                let name = built_in_for(dataset).ok_or_else(|| ConfigError::UnknownCamera {
                    dataset: dataset.display().to_string(),
                })?;
                Self::built_in(name)
            }
        }
    }

    /// The TOML text [`Config::load`] parses, and its origin (for a config derived from
    /// it, such as one with the camera of a bag's CameraInfo).
    ///
    /// # Errors
    /// As [`Config::load`].
    pub fn source_text(
        path: Option<&Path>,
        dataset: &Path,
    ) -> Result<(String, String), ConfigError> {
        let own = dataset.join(SYNTHETIC_MARKER);
        let file = path
            .map(Path::to_path_buf)
            .or_else(|| own.is_file().then_some(own));
        if let Some(file) = file {
            let text = std::fs::read_to_string(&file).map_err(|source| ConfigError::Read {
                path: file.display().to_string(),
                source,
            })?;
            return Ok((file.display().to_string(), text));
        }
        let name = built_in_for(dataset).ok_or_else(|| ConfigError::UnknownCamera {
            dataset: dataset.display().to_string(),
        })?;
        let text = BUILT_IN.iter().find(|(n, _)| *n == name).map(|(_, t)| *t);
        Ok((
            format!("configs/{name}.toml"),
            text.unwrap_or_default().to_owned(),
        ))
    }

    fn read(path: &Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_toml(&text, &path.display().to_string())
    }

    /// A built-in config by name (`tum1`, `tum2`, `tum3`, `icl`, `7scenes`, `synthetic`).
    ///
    /// # Errors
    /// [`ConfigError::Parse`] for an unknown name.
    pub fn built_in(name: &str) -> Result<Self, ConfigError> {
        let (_, text) =
            BUILT_IN
                .iter()
                .find(|(n, _)| *n == name)
                .ok_or_else(|| ConfigError::Parse {
                    path: name.to_owned(),
                    message: "no built-in config of that name".to_owned(),
                })?;
        Self::from_toml(text, &format!("configs/{name}.toml"))
    }

    /// The odometry's part of the config, with the camera's readout time and depth noise.
    pub fn odometry(&self) -> gfs_odometry::OdometryConfig {
        let mut tracking = gfs_odometry::TrackingConfig {
            readout_s: self.camera.readout_s,
            ..self.tracking.clone()
        };
        tracking.set_depth_noise(self.depth_noise());
        gfs_odometry::OdometryConfig {
            tracking,
            keyframes: self.keyframes.clone(),
            mapping: self.mapping.clone(),
            loop_closing: self.loop_closing.clone(),
            imu: self.imu.clone(),
        }
    }

    /// The depth noise of `[depth] sensor`: a stereo pair's from its baseline, matching
    /// error and the camera's focal length (the depth registered to the colour image).
    pub fn depth_noise(&self) -> DepthNoise {
        match self.depth.sensor {
            DepthSensor::StructuredLight => DepthNoise::STRUCTURED_LIGHT,
            DepthSensor::TimeOfFlight => DepthNoise::TIME_OF_FLIGHT,
            DepthSensor::Stereo => DepthNoise::stereo(
                self.camera.fx,
                self.depth.baseline_m,
                self.depth.disparity_sigma_px,
            ),
        }
    }

    /// The validated camera.
    ///
    /// # Errors
    /// [`ConfigError::Parse`] naming the invalid `camera.*` field.
    pub fn camera(&self) -> Result<Camera, ConfigError> {
        Camera::from_config(&self.camera).map_err(|e| ConfigError::Parse {
            path: "[camera]".to_owned(),
            message: e.to_string(),
        })
    }

    /// The camera and ORB pyramid a map file of a run with this config is made with.
    ///
    /// # Errors
    /// [`ConfigError::Parse`] naming the invalid `camera.*` or `points.levels` field.
    pub fn map_camera(&self) -> Result<gfs_odometry::map_file::MapCamera, ConfigError> {
        let levels = u8::try_from(self.points.levels).map_err(|_| ConfigError::Parse {
            path: "[points]".to_owned(),
            message: format!("levels = {} must be below 256", self.points.levels),
        })?;
        Ok(gfs_odometry::map_file::MapCamera {
            camera: self.camera()?.pinhole,
            scale_factor: f64::from(self.points.scale_factor),
            levels,
        })
    }
}

/// Longest line of an error message: a value pasted by mistake (megabytes of it) is
/// cut, not echoed whole.
const MAX_MESSAGE_LINE: usize = 200;

/// `message` with every line longer than [`MAX_MESSAGE_LINE`] characters cut.
fn clip_lines(message: &str) -> String {
    let clip = |line: &str| match line.char_indices().nth(MAX_MESSAGE_LINE) {
        Some((end, _)) => format!(
            "{}... ({} characters in all)",
            &line[..end],
            line.chars().count()
        ),
        None => line.to_owned(),
    };
    message.lines().map(clip).collect::<Vec<_>>().join("\n")
}

/// Which built-in config a dataset folder's name points to, if any.
fn built_in_for(dataset: &Path) -> Option<&'static str> {
    let name = dataset
        .canonicalize()
        .unwrap_or_else(|_| dataset.to_path_buf());
    let name = name.file_name()?.to_string_lossy().to_lowercase();
    let rules: [(&[&str], &str); 6] = [
        (&["freiburg1", "fr1"], "tum1"),
        (&["freiburg2", "fr2"], "tum2"),
        (&["freiburg3", "fr3"], "tum3"),
        (
            &[
                "7scenes",
                "7-scenes",
                "redkitchen",
                "chess",
                "heads",
                "pumpkin",
                "stairs",
            ],
            "7scenes",
        ),
        (
            &[
                "icl",
                "living_room",
                "livingroom",
                "office_room",
                "lr_kt",
                "of_kt",
            ],
            "icl",
        ),
        (&["synth"], "synthetic"),
    ];
    rules
        .iter()
        .find(|(keys, _)| keys.iter().any(|k| name.contains(k)))
        .map(|(_, n)| *n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_built_in_config_parses_into_a_valid_camera() {
        for (name, _) in BUILT_IN {
            let c = Config::built_in(name).unwrap();
            assert!(c.camera().is_ok(), "{name}");
        }
        assert_eq!(Config::built_in("tum1").unwrap().depth.scale, 5000.0);
        assert_eq!(Config::built_in("7scenes").unwrap().depth.scale, 1000.0);
    }

    #[test]
    fn the_rolling_shutter_readout_reaches_the_tracker() {
        let odometry = |name| {
            Config::built_in(name)
                .unwrap()
                .odometry()
                .tracking
                .readout_s
        };
        assert_eq!(odometry("tum1"), 0.02);
        assert_eq!(odometry("tum2"), 0.02);
        for global in ["tum3", "icl", "7scenes", "synthetic"] {
            assert_eq!(odometry(global), 0.0, "{global}");
        }
        let cam = "[camera]\nfx=5.0\nfy=5.0\ncx=1.0\ncy=1.0\nwidth=4\nheight=4\n";
        let e = Config::from_toml(&format!("{cam}readout_s = 2.0\n"), "a.toml").unwrap_err();
        assert!(e.to_string().contains("camera.readout_s"), "{e}");
    }

    #[test]
    fn the_tracker_pose_optimiser_is_configured_by_tracking_pose() {
        let cam = "[camera]\nfx=5.0\nfy=5.0\ncx=1.0\ncy=1.0\nwidth=4\nheight=4\n";
        let text = format!(
            "{cam}[tracking]\nrelocalisation_min_inliers = 30\n[tracking.pose]\nrounds = 3\nbf = 30.0\n"
        );
        let tracking = Config::from_toml(&text, "t.toml")
            .unwrap()
            .odometry()
            .tracking;
        assert_eq!((tracking.pose.rounds, tracking.pose.bf), (3, 30.0));
        assert_eq!(
            tracking.pose.iterations_per_round, 10,
            "the rest keeps its default"
        );
        assert_eq!(tracking.relocalisation_min_inliers, 30);
        let e = Config::from_toml(&format!("{cam}[tracking.pose]\nround = 3\n"), "t.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("round"), "{e}");
    }

    #[test]
    fn the_dataset_name_selects_the_camera() {
        assert_eq!(
            built_in_for(Path::new("/x/tum_fr1_rpy_head300")),
            Some("tum1")
        );
        assert_eq!(
            built_in_for(Path::new("rgbd_dataset_freiburg3_long_office")),
            Some("tum3")
        );
        assert_eq!(
            built_in_for(Path::new("7scenes_redkitchen_head300")),
            Some("7scenes")
        );
        assert_eq!(
            built_in_for(Path::new("living_room_traj0_frei_png")),
            Some("icl")
        );
        assert_eq!(built_in_for(Path::new("/data/unknown")), None);
    }

    #[test]
    fn errors_name_the_field() {
        let e = Config::from_toml("[camera]\nfx = 1.0\n", "a.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("a.toml") && e.contains("fy"), "{e}");
        let cam = "[camera]\nfx=5.0\nfy=5.0\ncx=1.0\ncy=1.0\nwidth=4\nheight=4\n";
        let e = Config::from_toml(&format!("{cam}[points]\nfeatures = 0\n"), "p.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("p.toml") && e.contains("points.features"), "{e}");
        let e = Config::from_toml(&format!("{cam}[imu]\ntime_offset_s = 30.0\n"), "i.toml")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("i.toml") && e.contains("imu.time_offset_s"),
            "{e}"
        );
        let bad = "[camera]\nfx=-5.0\nfy=5.0\ncx=1.0\ncy=1.0\nwidth=4\nheight=4\n";
        let e = Config::from_toml(bad, "b.toml").unwrap_err().to_string();
        assert!(e.starts_with("config b.toml: camera.fx"), "{e}");
        let lens = format!("{bad}model = \"equidistant\"\nk1 = 1e300\n");
        let e = Config::from_toml(&lens.replace("fx=-5.0", "fx=5.0"), "l.toml")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("config l.toml: camera.model"), "{e}");
        let huge = format!("{cam}[ros2]\nodom_topic = \"{}\"\n", "x".repeat(10_000_000));
        let e = Config::from_toml(&huge, "h.toml").unwrap_err().to_string();
        assert!(
            e.len() < 1000 && e.contains("characters in all"),
            "{}",
            &e[..e.len().min(2000)]
        );
        let e = Config::from_toml(
            "[camera]\nfx=5.0\nfy=5.0\ncx=1.0\ncy=1.0\nwidth=4\nheight=4\nzz=1\n",
            "c.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("zz"), "{e}");
    }
}
