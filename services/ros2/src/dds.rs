//! The DDS side: a participant on the ROS domain as ROS 2 sets it up
//! (`ROS_DOMAIN_ID`; `ROS_LOCALHOST_ONLY=1` or `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`
//! keep discovery and data on 127.0.0.1), the camera subscriptions with sensor-data QoS
//! (best effort, so reliable and best-effort publishers both match) of either image
//! transport, the output publishers (reliable), the reset service and topic, the map
//! saving service and the pose hint topic.

use gfs_ros2::diagnostics::DiagnosticArray;
use gfs_ros2::imu::ImuTopic;
use gfs_ros2::msg::{
    CameraInfo, CompressedImage, Image, Imu, Odometry, PoseWithCovarianceStamped, StringMsg,
    TfMessage,
};
use gfs_ros2::transport::TransportImage;
use gfs_ros2::{Ros2Config, Transport};
use ros2_client::dds::rustdds::DomainParticipantBuilder;
use ros2_client::qos::{History, QosProfile};
use ros2_client::{
    Context, Message, MessageTypeName, Name, Node, NodeName, NodeOptions, Publisher, Server,
    ServiceMapping, ServiceTypeName, Subscription,
};
use serde::{Deserialize, Serialize};
use std::net::Ipv4Addr;

/// What can go wrong setting up DDS.
pub type DdsError = Box<dyn std::error::Error + Send + Sync>;

/// A camera image subscription: raw, or image_transport's compressed plugin.
pub enum ImageSubscription {
    /// `sensor_msgs/Image` on the topic.
    Raw(Subscription<Image>),
    /// `sensor_msgs/CompressedImage` on `<topic>/compressed` or `/compressedDepth`.
    Compressed(Subscription<CompressedImage>),
}

impl ImageSubscription {
    fn new(
        node: &mut Node,
        transport: Transport,
        name: &str,
        qos: &QosProfile,
    ) -> Result<Self, DdsError> {
        Ok(match transport {
            Transport::Raw => {
                let topic = topic(node, name, "sensor_msgs", "Image", qos)?;
                Self::Raw(node.create_subscription(&topic, Some(qos.clone()))?)
            }
            Transport::Compressed => {
                let topic = topic(node, name, "sensor_msgs", "CompressedImage", qos)?;
                Self::Compressed(node.create_subscription(&topic, Some(qos.clone()))?)
            }
        })
    }

    /// The next image received, if any.
    ///
    /// # Errors
    /// A message that could not be decoded, as DDS reports it.
    pub fn take(&self) -> Result<Option<TransportImage>, String> {
        match self {
            Self::Raw(s) => s
                .take()
                .map(|m| m.map(|(image, _)| TransportImage::Raw(image)))
                .map_err(|e| format!("{e:?}")),
            Self::Compressed(s) => s
                .take()
                .map(|m| m.map(|(image, _)| TransportImage::Compressed(image)))
                .map_err(|e| format!("{e:?}")),
        }
    }
}

/// `std_srvs/srv/Empty` request (IDL gives an empty structure one byte).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct EmptyRequest {
    structure_needs_at_least_one_member: u8,
}
impl Message for EmptyRequest {}

/// `std_srvs/srv/Empty` response.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct EmptyResponse {
    structure_needs_at_least_one_member: u8,
}
impl Message for EmptyResponse {}

/// `std_srvs/srv/Trigger` request (empty: one byte, as IDL gives it).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct TriggerRequest {
    structure_needs_at_least_one_member: u8,
}
impl Message for TriggerRequest {}

/// `std_srvs/srv/Trigger` response.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct TriggerResponse {
    /// Whether it was done.
    pub success: bool,
    /// What was done, or why not.
    pub message: String,
}
impl Message for TriggerResponse {}

/// The node's subscriptions and publishers.
pub struct Endpoints {
    /// Colour images.
    pub colour: ImageSubscription,
    /// Depth images.
    pub depth: ImageSubscription,
    /// Camera info.
    pub camera_info: Subscription<CameraInfo>,
    /// The IMU topics: unified, gyroscope, accelerometer.
    pub imu: [(ImuTopic, Subscription<Imu>); 3],
    /// `/odom`.
    pub odom: Publisher<Odometry>,
    /// `/tf`.
    pub tf: Publisher<TfMessage>,
    /// Status.
    pub status: Publisher<StringMsg>,
    /// `/diagnostics`.
    pub diagnostics: Publisher<DiagnosticArray>,
    /// The reset service (`std_srvs/srv/Empty`).
    pub reset: Server<EmptyRequest, EmptyResponse>,
    /// Resets to a pose.
    pub reset_to_pose: Subscription<PoseWithCovarianceStamped>,
    /// The map saving service (`std_srvs/srv/Trigger`).
    pub save_map: Server<TriggerRequest, TriggerResponse>,
    /// Pose hints in the loaded map.
    pub initial_pose: Subscription<PoseWithCovarianceStamped>,
    _node: Node,
}

/// `ROS_DOMAIN_ID` (0 when unset).
///
/// # Errors
/// A value that is not a domain id 0..=232.
pub fn domain_id() -> Result<u16, DdsError> {
    match std::env::var("ROS_DOMAIN_ID") {
        Ok(v) if !v.trim().is_empty() => {
            let id: u16 = v
                .trim()
                .parse()
                .map_err(|_| format!("ROS_DOMAIN_ID={v:?} is not a number"))?;
            if id > 232 {
                return Err(format!("ROS_DOMAIN_ID={id} is above 232").into());
            }
            Ok(id)
        }
        _ => Ok(0),
    }
}

/// True when ROS 2's environment asks for loopback-only discovery.
pub fn localhost_only() -> bool {
    let var = |name| std::env::var(name).unwrap_or_default();
    var("ROS_LOCALHOST_ONLY").trim() == "1"
        || var("ROS_AUTOMATIC_DISCOVERY_RANGE")
            .trim()
            .eq_ignore_ascii_case("LOCALHOST")
}

/// Sensor-data QoS of the camera subscriptions: best effort, the last few messages.
fn sensor_qos() -> QosProfile {
    QosProfile::subscription_default().history(History::KeepLast { depth: 5 })
}

/// QoS of the IMU subscriptions: best effort, 0.25 s of a 400 Hz IMU (the loop may be
/// busy converting an image for a few milliseconds).
fn imu_qos() -> QosProfile {
    QosProfile::subscription_default().history(History::KeepLast { depth: 100 })
}

/// The participant on the ROS domain and the node `name` on it.
pub(crate) fn node(name: &str) -> Result<Node, DdsError> {
    let mut builder = DomainParticipantBuilder::new(domain_id()?);
    if localhost_only() {
        builder = builder
            .with_only_networks([Ipv4Addr::LOCALHOST])
            .same_host_loopback(true);
    }
    let context = Context::from_domain_participant(builder.build()?)?;
    Ok(context.new_node(
        NodeName::new("/", name)?,
        NodeOptions::new().enable_rosout(false),
    )?)
}

pub(crate) fn topic(
    node: &mut Node,
    name: &str,
    pkg: &str,
    ty: &str,
    qos: &QosProfile,
) -> Result<ros2_client::dds::rustdds::Topic, DdsError> {
    Ok(node.create_topic(&Name::parse(name)?, MessageTypeName::new(pkg, ty), qos)?)
}

/// A node subscribed to the camera info alone (the camera probe: subscribing to the
/// images too would tell a driver waiting for subscribers to start too early).
///
/// # Errors
/// [`DdsError`] when the participant or the subscription cannot be created.
pub fn camera_info_only(config: &Ros2Config) -> Result<(Node, Subscription<CameraInfo>), DdsError> {
    let mut node = node("gfsvo_camera_probe")?;
    let sensor = sensor_qos();
    let info = topic(
        &mut node,
        &config.camera_info_topic,
        "sensor_msgs",
        "CameraInfo",
        &sensor,
    )?;
    let subscription = node.create_subscription(&info, Some(sensor))?;
    Ok((node, subscription))
}

/// Creates the participant, the node `gfsvo` and its endpoints.
///
/// # Errors
/// [`DdsError`] when the participant, a topic name or an endpoint cannot be created.
pub fn endpoints(config: &Ros2Config) -> Result<Endpoints, DdsError> {
    let mut node = node("gfsvo")?;
    let sensor = sensor_qos();
    let output = QosProfile::publisher_default().history(History::KeepLast { depth: 50 });
    let (colour_topic, depth_topic) = config.image_topics();
    let colour = ImageSubscription::new(&mut node, config.transport, &colour_topic, &sensor)?;
    let depth = ImageSubscription::new(&mut node, config.transport, &depth_topic, &sensor)?;
    let info_topic = topic(
        &mut node,
        &config.camera_info_topic,
        "sensor_msgs",
        "CameraInfo",
        &sensor,
    )?;
    let imu_qos = imu_qos();
    let mut imu = Vec::with_capacity(3);
    for (which, name) in [
        (ImuTopic::Unified, &config.imu_topic),
        (ImuTopic::Gyro, &config.gyro_topic),
        (ImuTopic::Accel, &config.accel_topic),
    ] {
        let t = topic(&mut node, name, "sensor_msgs", "Imu", &imu_qos)?;
        imu.push((which, node.create_subscription(&t, Some(imu_qos.clone()))?));
    }
    let imu: [(ImuTopic, Subscription<Imu>); 3] = imu
        .try_into()
        .map_err(|_| "three IMU subscriptions expected")?;
    let odom_topic = topic(
        &mut node,
        &config.odom_topic,
        "nav_msgs",
        "Odometry",
        &output,
    )?;
    let tf_topic = topic(
        &mut node,
        &config.tf_topic,
        "tf2_msgs",
        "TFMessage",
        &output,
    )?;
    let status_topic = topic(
        &mut node,
        &config.status_topic,
        "std_msgs",
        "String",
        &output,
    )?;
    let diagnostics_topic = topic(
        &mut node,
        &config.diagnostics_topic,
        "diagnostic_msgs",
        "DiagnosticArray",
        &output,
    )?;
    let reset_to_pose_topic = topic(
        &mut node,
        &config.reset_to_pose_topic,
        "geometry_msgs",
        "PoseWithCovarianceStamped",
        &output,
    )?;
    let initial_pose_topic = topic(
        &mut node,
        &config.initial_pose_topic,
        "geometry_msgs",
        "PoseWithCovarianceStamped",
        &output,
    )?;
    // Services as rmw_cyclonedds maps them onto DDS (`rq/<name>Request`,
    // `rr/<name>Reply`, the request id in a header of the payload), reliable.
    let reset = node.create_server(
        ServiceMapping::Cyclone,
        &Name::parse(&config.reset_service)?,
        &ServiceTypeName::new("std_srvs", "Empty"),
        output.clone(),
        output.clone(),
    )?;
    let save_map = node.create_server(
        ServiceMapping::Cyclone,
        &Name::parse(&config.save_map_service)?,
        &ServiceTypeName::new("std_srvs", "Trigger"),
        output.clone(),
        output.clone(),
    )?;
    Ok(Endpoints {
        reset,
        save_map,
        initial_pose: node.create_subscription(&initial_pose_topic, Some(output.clone()))?,
        reset_to_pose: node.create_subscription(&reset_to_pose_topic, Some(output.clone()))?,
        colour,
        depth,
        camera_info: node.create_subscription(&info_topic, Some(sensor))?,
        imu,
        odom: node.create_publisher(&odom_topic, Some(output.clone()))?,
        tf: node.create_publisher(&tf_topic, Some(output.clone()))?,
        status: node.create_publisher(&status_topic, Some(output.clone()))?,
        diagnostics: node.create_publisher(&diagnostics_topic, Some(output))?,
        _node: node,
    })
}
