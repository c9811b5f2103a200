//! `[ros2]` of a config file: topics, frames, pairing and what to publish when lost
//! (the parameters rtabmap_ros `rgbd_odometry` users know, under the names of REP 105).

use serde::Deserialize;

/// What is published for a frame whose tracking was lost.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WhenLost {
    /// The motion model's prediction, with the covariance scaled by
    /// `lost_covariance_scale` (default).
    #[default]
    Predict,
    /// Nothing on `/odom` and `/tf` (rtabmap's `publish_null_when_lost` publishes an
    /// empty pose instead; a missing message is what navigation stacks time out on).
    Nothing,
}

/// How the camera images travel (`image_transport`'s plugins).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Transport {
    /// `sensor_msgs/Image` on the colour and depth topics (default).
    #[default]
    Raw,
    /// `sensor_msgs/CompressedImage` on `<colour_topic>/compressed` (jpeg or png) and
    /// `<depth_topic>/compressedDepth` (png).
    Compressed,
}

/// `[ros2]`: the ROS 2 interface of `gfsvo ros2` and of bags.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Ros2Config {
    /// `sensor_msgs/Image` colour topic (rgb8, bgr8, rgba8, bgra8, mono8).
    pub colour_topic: String,
    /// `sensor_msgs/Image` depth topic registered to colour (16UC1 mm or 32FC1 m).
    pub depth_topic: String,
    /// `sensor_msgs/CameraInfo` of the colour camera.
    pub camera_info_topic: String,
    /// `sensor_msgs/Imu` with gyroscope and accelerometer together (RealSense's
    /// `unite_imu_method`); read when it has messages.
    pub imu_topic: String,
    /// `sensor_msgs/Imu` with the gyroscope alone, united with `accel_topic` at the
    /// gyroscope's stamps when `imu_topic` is silent.
    pub gyro_topic: String,
    /// `sensor_msgs/Imu` with the accelerometer alone.
    pub accel_topic: String,
    /// Raw or compressed images, live; in a bag, the topics of the other transport are
    /// read when the bag has none of this one, and each topic's schema says how.
    pub transport: Transport,
    /// `nav_msgs/Odometry` output.
    pub odom_topic: String,
    /// `tf2_msgs/TFMessage` output.
    pub tf_topic: String,
    /// `std_msgs/String` tracking status output.
    pub status_topic: String,
    /// `diagnostic_msgs/DiagnosticArray` output, once a second.
    pub diagnostics_topic: String,
    /// `std_srvs/srv/Empty` service: start a new map, the odometry going on from the
    /// last pose.
    pub reset_service: String,
    /// `geometry_msgs/PoseWithCovarianceStamped` input (as rtabmap's `initialpose`):
    /// start a new map with the base at that pose in `odom_frame`.
    pub reset_to_pose_topic: String,
    /// `std_srvs/srv/Trigger` service: write the global map to `--save-map` now.
    pub save_map_service: String,
    /// `geometry_msgs/PoseWithCovarianceStamped` input in `map_frame` (RViz's "2D Pose
    /// Estimate"): while localising, where to look for the camera in the loaded map.
    pub initial_pose_topic: String,
    /// `header.frame_id` of the odometry (REP 105 `odom`).
    pub odom_frame: String,
    /// Parent frame of the loop correction `map -> odom` on `/tf` (REP 105 `map`),
    /// published once a loop closed.
    pub map_frame: String,
    /// `child_frame_id`: the robot body frame (REP 105 `base_link`).
    pub base_frame: String,
    /// Publish `odom -> base_frame` on `/tf`.
    pub publish_tf: bool,
    /// The camera's optical frame in the base frame: x y z (m) then qx qy qz qw. Default:
    /// the optical frame at the base's origin, z forward along the base's x (REP 103).
    pub camera_in_base: [f64; 7],
    /// Largest stamp difference between a colour and its depth image, seconds.
    pub slop_s: f64,
    /// What a lost frame publishes.
    pub when_lost: WhenLost,
    /// Factor on the covariance of a predicted (lost) pose.
    pub lost_covariance_scale: f64,
    /// `[ros2.visualisation]`: the map, structure and path topics.
    pub visualisation: crate::visualisation::VisualisationConfig,
}

/// `camera_in_base` of a camera looking along the base's x axis: optical x right = base
/// -y, optical y down = base -z, optical z forward = base x.
pub const OPTICAL_IN_BASE: [f64; 7] = [0.0, 0.0, 0.0, -0.5, 0.5, -0.5, 0.5];

impl Default for Ros2Config {
    fn default() -> Self {
        Self {
            colour_topic: "/camera/color/image_raw".to_owned(),
            depth_topic: "/camera/aligned_depth_to_color/image_raw".to_owned(),
            camera_info_topic: "/camera/color/camera_info".to_owned(),
            imu_topic: "/camera/imu".to_owned(),
            gyro_topic: "/camera/gyro/sample".to_owned(),
            accel_topic: "/camera/accel/sample".to_owned(),
            transport: Transport::Raw,
            odom_topic: "/odom".to_owned(),
            tf_topic: "/tf".to_owned(),
            status_topic: "/gfsvo/status".to_owned(),
            diagnostics_topic: "/diagnostics".to_owned(),
            reset_service: "/gfsvo/reset".to_owned(),
            reset_to_pose_topic: "/gfsvo/reset_to_pose".to_owned(),
            save_map_service: "/gfsvo/save_map".to_owned(),
            initial_pose_topic: "/initialpose".to_owned(),
            odom_frame: "odom".to_owned(),
            map_frame: "map".to_owned(),
            base_frame: "base_link".to_owned(),
            publish_tf: true,
            camera_in_base: OPTICAL_IN_BASE,
            slop_s: 0.02,
            when_lost: WhenLost::Predict,
            lost_covariance_scale: 1e4,
            visualisation: crate::visualisation::VisualisationConfig::default(),
        }
    }
}

impl Ros2Config {
    /// The colour and depth topics subscribed to: the raw ones, or
    /// `<colour_topic>/compressed` and `<depth_topic>/compressedDepth`.
    pub fn image_topics(&self) -> (String, String) {
        match self.transport {
            Transport::Raw => (self.colour_topic.clone(), self.depth_topic.clone()),
            Transport::Compressed => (
                format!("{}/compressed", self.colour_topic),
                format!("{}/compressedDepth", self.depth_topic),
            ),
        }
    }

    /// The IMU topics read.
    pub fn imu_topics(&self) -> crate::imu::ImuTopics {
        crate::imu::ImuTopics {
            unified: self.imu_topic.clone(),
            gyro: self.gyro_topic.clone(),
            accel: self.accel_topic.clone(),
        }
    }

    /// Checks the values a run cannot work with.
    ///
    /// # Errors
    /// A message naming the `ros2.*` field.
    pub fn validate(&self) -> Result<(), String> {
        for (field, topic) in [
            ("colour_topic", &self.colour_topic),
            ("depth_topic", &self.depth_topic),
            ("camera_info_topic", &self.camera_info_topic),
            ("imu_topic", &self.imu_topic),
            ("gyro_topic", &self.gyro_topic),
            ("accel_topic", &self.accel_topic),
            ("odom_topic", &self.odom_topic),
            ("tf_topic", &self.tf_topic),
            ("status_topic", &self.status_topic),
            ("diagnostics_topic", &self.diagnostics_topic),
            ("reset_service", &self.reset_service),
            ("reset_to_pose_topic", &self.reset_to_pose_topic),
            ("save_map_service", &self.save_map_service),
            ("initial_pose_topic", &self.initial_pose_topic),
        ] {
            if !topic.starts_with('/') || topic.len() < 2 || topic.contains(char::is_whitespace) {
                return Err(format!(
                    "ros2.{field} = {topic:?} must be an absolute topic name"
                ));
            }
        }
        if !(self.slop_s.is_finite() && self.slop_s >= 0.0) {
            return Err(format!("ros2.slop_s = {} must be >= 0", self.slop_s));
        }
        if !(self.lost_covariance_scale.is_finite() && self.lost_covariance_scale >= 1.0) {
            return Err(format!(
                "ros2.lost_covariance_scale = {} must be >= 1",
                self.lost_covariance_scale
            ));
        }
        self.visualisation.validate()?;
        let q = &self.camera_in_base[3..];
        let norm = q.iter().map(|v| v * v).sum::<f64>().sqrt();
        if !(self.camera_in_base.iter().all(|v| v.is_finite()) && (norm - 1.0).abs() < 1e-3) {
            return Err(format!(
                "ros2.camera_in_base = {:?}: x y z qx qy qz qw with a unit quaternion",
                self.camera_in_base
            ));
        }
        Ok(())
    }
}
