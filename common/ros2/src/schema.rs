//! The `ros2msg` schemas of the messages written to bags: the `.msg` text of the type,
//! then each dependency after a line of `=` and `MSG: pkg/Type`, as `ros2 bag` writes
//! them (Foxglove, `rosbags` and `mcap-ros2-support` parse them).

const SEPARATOR: &str =
    "================================================================================\n";

pub(crate) const TIME: (&str, &str) = ("builtin_interfaces/Time", "int32 sec\nuint32 nanosec\n");
pub(crate) const HEADER: (&str, &str) = (
    "std_msgs/Header",
    "builtin_interfaces/Time stamp\nstring frame_id\n",
);
pub(crate) const POINT: (&str, &str) = ("geometry_msgs/Point", "float64 x\nfloat64 y\nfloat64 z\n");
pub(crate) const VECTOR3: (&str, &str) =
    ("geometry_msgs/Vector3", "float64 x\nfloat64 y\nfloat64 z\n");
pub(crate) const QUATERNION: (&str, &str) = (
    "geometry_msgs/Quaternion",
    "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n",
);
pub(crate) const POSE: (&str, &str) = (
    "geometry_msgs/Pose",
    "Point position\nQuaternion orientation\n",
);
const POSE_COV: (&str, &str) = (
    "geometry_msgs/PoseWithCovariance",
    "Pose pose\nfloat64[36] covariance\n",
);
const TWIST: (&str, &str) = ("geometry_msgs/Twist", "Vector3 linear\nVector3 angular\n");
const TWIST_COV: (&str, &str) = (
    "geometry_msgs/TwistWithCovariance",
    "Twist twist\nfloat64[36] covariance\n",
);
const TRANSFORM: (&str, &str) = (
    "geometry_msgs/Transform",
    "Vector3 translation\nQuaternion rotation\n",
);
const TRANSFORM_STAMPED: (&str, &str) = (
    "geometry_msgs/TransformStamped",
    "std_msgs/Header header\nstring child_frame_id\nTransform transform\n",
);
const ROI: (&str, &str) = (
    "sensor_msgs/RegionOfInterest",
    "uint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\nbool do_rectify\n",
);

/// A message type of a bag: its name and its `ros2msg` schema with dependencies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MessageSchema {
    /// `pkg/msg/Type`, as `ros2 bag` names schemas.
    pub name: &'static str,
    pub(crate) main: &'static str,
    pub(crate) dependencies: &'static [(&'static str, &'static str)],
}

impl MessageSchema {
    /// The schema text.
    pub fn text(&self) -> String {
        let mut out = self.main.to_owned();
        for (name, text) in self.dependencies {
            out.push_str(SEPARATOR);
            out.push_str("MSG: ");
            out.push_str(name);
            out.push('\n');
            out.push_str(text);
        }
        out
    }
}

/// `nav_msgs/msg/Odometry`.
pub const ODOMETRY: MessageSchema = MessageSchema {
    name: "nav_msgs/msg/Odometry",
    main: "std_msgs/Header header\nstring child_frame_id\n\
           geometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist\n",
    dependencies: &[
        HEADER, TIME, POSE_COV, POSE, POINT, QUATERNION, TWIST_COV, TWIST, VECTOR3,
    ],
};

/// `tf2_msgs/msg/TFMessage`.
pub const TF_MESSAGE: MessageSchema = MessageSchema {
    name: "tf2_msgs/msg/TFMessage",
    main: "geometry_msgs/TransformStamped[] transforms\n",
    dependencies: &[
        TRANSFORM_STAMPED,
        HEADER,
        TIME,
        TRANSFORM,
        VECTOR3,
        QUATERNION,
    ],
};

/// `std_msgs/msg/String`.
pub const STRING: MessageSchema = MessageSchema {
    name: "std_msgs/msg/String",
    main: "string data\n",
    dependencies: &[],
};

/// `sensor_msgs/msg/Image`.
pub const IMAGE: MessageSchema = MessageSchema {
    name: "sensor_msgs/msg/Image",
    main: "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\n\
           uint8 is_bigendian\nuint32 step\nuint8[] data\n",
    dependencies: &[HEADER, TIME],
};

/// `sensor_msgs/msg/CameraInfo`.
pub const CAMERA_INFO: MessageSchema = MessageSchema {
    name: "sensor_msgs/msg/CameraInfo",
    main: "std_msgs/Header header\nuint32 height\nuint32 width\nstring distortion_model\n\
           float64[] d\nfloat64[9] k\nfloat64[9] r\nfloat64[12] p\nuint32 binning_x\n\
           uint32 binning_y\nRegionOfInterest roi\n",
    dependencies: &[HEADER, TIME, ROI],
};

/// `diagnostic_msgs/msg/DiagnosticArray`.
pub const DIAGNOSTIC_ARRAY: MessageSchema = MessageSchema {
    name: "diagnostic_msgs/msg/DiagnosticArray",
    main: "std_msgs/Header header\nDiagnosticStatus[] status\n",
    dependencies: &[
        HEADER,
        TIME,
        (
            "diagnostic_msgs/DiagnosticStatus",
            "byte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\nbyte level\nstring name\n\
             string message\nstring hardware_id\nKeyValue[] values\n",
        ),
        ("diagnostic_msgs/KeyValue", "string key\nstring value\n"),
    ],
};

/// `sensor_msgs/msg/CompressedImage`.
pub const COMPRESSED_IMAGE: MessageSchema = MessageSchema {
    name: "sensor_msgs/msg/CompressedImage",
    main: "std_msgs/Header header\nstring format\nuint8[] data\n",
    dependencies: &[HEADER, TIME],
};

/// `sensor_msgs/msg/Imu`.
pub const IMU: MessageSchema = MessageSchema {
    name: "sensor_msgs/msg/Imu",
    main: "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\n\
           float64[9] orientation_covariance\ngeometry_msgs/Vector3 angular_velocity\n\
           float64[9] angular_velocity_covariance\ngeometry_msgs/Vector3 linear_acceleration\n\
           float64[9] linear_acceleration_covariance\n",
    dependencies: &[HEADER, TIME, QUATERNION, VECTOR3],
};
