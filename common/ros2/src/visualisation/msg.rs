//! The standard message types of the visualisation topics (`sensor_msgs/PointCloud2`,
//! `visualization_msgs/MarkerArray`, `nav_msgs/Path`) as serde structs in `.msg` order
//! (the Humble-and-later `Marker`), with their `ros2msg` schemas for bags.

use crate::msg::{Header, Pose, Time, Vector3};
use crate::schema::{HEADER, MessageSchema, POINT, POSE, QUATERNION, TIME, VECTOR3};
use serde::{Deserialize, Serialize};

/// `sensor_msgs/PointField`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PointField {
    /// Field name (`x`, `rgb`, ...).
    pub name: String,
    /// Byte offset in a point.
    pub offset: u32,
    /// [`FLOAT32`] and friends.
    pub datatype: u8,
    /// Elements in the field.
    pub count: u32,
}

/// `PointField.FLOAT32`.
pub const FLOAT32: u8 = 7;

/// `sensor_msgs/PointCloud2`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PointCloud2 {
    /// Stamp and frame of the points.
    pub header: Header,
    /// 1 for an unordered cloud.
    pub height: u32,
    /// Points per row.
    pub width: u32,
    /// Layout of a point.
    pub fields: Vec<PointField>,
    /// Byte order of `data`.
    pub is_bigendian: bool,
    /// Bytes per point.
    pub point_step: u32,
    /// Bytes per row.
    pub row_step: u32,
    /// `row_step * height` bytes.
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
    /// No invalid (non-finite) point.
    pub is_dense: bool,
}

/// `std_msgs/ColorRGBA`, components in 0..1.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ColorRgba {
    /// Red.
    pub r: f32,
    /// Green.
    pub g: f32,
    /// Blue.
    pub b: f32,
    /// Opacity.
    pub a: f32,
}

/// `sensor_msgs/CompressedImage` (a marker's texture; empty here).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CompressedImage {
    /// Stamp and frame.
    pub header: Header,
    /// `jpeg`, `png`.
    pub format: String,
    /// Encoded image.
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
}

/// `visualization_msgs/UVCoordinate`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct UvCoordinate {
    /// u.
    pub u: f32,
    /// v.
    pub v: f32,
}

/// `visualization_msgs/MeshFile`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MeshFile {
    /// File name.
    pub filename: String,
    /// File contents.
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
}

/// `visualization_msgs/Marker`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Marker {
    /// Stamp and frame of the points.
    pub header: Header,
    /// Namespace: with `id`, what a later marker replaces.
    pub ns: String,
    /// Id within the namespace.
    pub id: i32,
    /// [`LINE_LIST`], [`TRIANGLE_LIST`], ...
    #[serde(rename = "type")]
    pub kind: i32,
    /// [`ADD`] or [`DELETEALL`].
    pub action: i32,
    /// Pose of the points' frame.
    pub pose: Pose,
    /// Line width in `scale.x` for lines.
    pub scale: Vector3,
    /// Colour when `colors` is empty.
    pub color: ColorRgba,
    /// 0 = forever.
    pub lifetime: Time,
    /// Re-transform every frame.
    pub frame_locked: bool,
    /// Vertices.
    pub points: Vec<Vector3>,
    /// A colour per vertex.
    pub colors: Vec<ColorRgba>,
    /// Unused texture.
    pub texture_resource: String,
    /// Unused texture.
    pub texture: CompressedImage,
    /// Unused texture coordinates.
    pub uv_coordinates: Vec<UvCoordinate>,
    /// Text of TEXT_VIEW_FACING.
    pub text: String,
    /// Unused mesh.
    pub mesh_resource: String,
    /// Unused mesh.
    pub mesh_file: MeshFile,
    /// Unused mesh.
    pub mesh_use_embedded_materials: bool,
}

/// `Marker.ARROW`.
pub const ARROW: i32 = 0;
/// `Marker.LINE_LIST`.
pub const LINE_LIST: i32 = 5;
/// `Marker.TRIANGLE_LIST`.
pub const TRIANGLE_LIST: i32 = 11;
/// `Marker.ADD`.
pub const ADD: i32 = 0;
/// `Marker.DELETEALL`.
pub const DELETEALL: i32 = 3;

/// `visualization_msgs/MarkerArray`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MarkerArray {
    /// The markers.
    pub markers: Vec<Marker>,
}

/// `geometry_msgs/PoseStamped`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseStamped {
    /// Stamp and frame.
    pub header: Header,
    /// The pose.
    pub pose: Pose,
}

/// `nav_msgs/Path`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Path {
    /// Stamp and frame.
    pub header: Header,
    /// The poses.
    pub poses: Vec<PoseStamped>,
}

const POINT_FIELD: (&str, &str) = (
    "sensor_msgs/PointField",
    "uint8 INT8=1\nuint8 UINT8=2\nuint8 INT16=3\nuint8 UINT16=4\nuint8 INT32=5\n\
     uint8 UINT32=6\nuint8 FLOAT32=7\nuint8 FLOAT64=8\n\
     string name\nuint32 offset\nuint8 datatype\nuint32 count\n",
);
const COLOR_RGBA: (&str, &str) = (
    "std_msgs/ColorRGBA",
    "float32 r\nfloat32 g\nfloat32 b\nfloat32 a\n",
);
const DURATION: (&str, &str) = ("builtin_interfaces/Duration", "int32 sec\nuint32 nanosec\n");
const COMPRESSED_IMAGE: (&str, &str) = (
    "sensor_msgs/CompressedImage",
    "std_msgs/Header header\nstring format\nuint8[] data\n",
);
const UV_COORDINATE: (&str, &str) = ("visualization_msgs/UVCoordinate", "float32 u\nfloat32 v\n");
const MESH_FILE: (&str, &str) = (
    "visualization_msgs/MeshFile",
    "string filename\nuint8[] data\n",
);
const MARKER: (&str, &str) = (
    "visualization_msgs/Marker",
    "int32 ARROW=0\nint32 CUBE=1\nint32 SPHERE=2\nint32 CYLINDER=3\nint32 LINE_STRIP=4\n\
     int32 LINE_LIST=5\nint32 CUBE_LIST=6\nint32 SPHERE_LIST=7\nint32 POINTS=8\n\
     int32 TEXT_VIEW_FACING=9\nint32 MESH_RESOURCE=10\nint32 TRIANGLE_LIST=11\n\
     int32 ARROW_STRIP=12\nint32 ADD=0\nint32 MODIFY=0\nint32 DELETE=2\nint32 DELETEALL=3\n\
     std_msgs/Header header\nstring ns\nint32 id\nint32 type\nint32 action\n\
     geometry_msgs/Pose pose\ngeometry_msgs/Vector3 scale\nstd_msgs/ColorRGBA color\n\
     builtin_interfaces/Duration lifetime\nbool frame_locked\ngeometry_msgs/Point[] points\n\
     std_msgs/ColorRGBA[] colors\nstring texture_resource\n\
     sensor_msgs/CompressedImage texture\nUVCoordinate[] uv_coordinates\nstring text\n\
     string mesh_resource\nMeshFile mesh_file\nbool mesh_use_embedded_materials\n",
);
const POSE_STAMPED: (&str, &str) = (
    "geometry_msgs/PoseStamped",
    "std_msgs/Header header\nPose pose\n",
);

/// `sensor_msgs/msg/PointCloud2`.
pub const POINT_CLOUD2: MessageSchema = MessageSchema {
    name: "sensor_msgs/msg/PointCloud2",
    main: "std_msgs/Header header\nuint32 height\nuint32 width\nPointField[] fields\n\
           bool is_bigendian\nuint32 point_step\nuint32 row_step\nuint8[] data\n\
           bool is_dense\n",
    dependencies: &[HEADER, TIME, POINT_FIELD],
};

/// `visualization_msgs/msg/MarkerArray`.
pub const MARKER_ARRAY: MessageSchema = MessageSchema {
    name: "visualization_msgs/msg/MarkerArray",
    main: "Marker[] markers\n",
    dependencies: &[
        MARKER,
        HEADER,
        TIME,
        POSE,
        POINT,
        QUATERNION,
        VECTOR3,
        COLOR_RGBA,
        DURATION,
        COMPRESSED_IMAGE,
        UV_COORDINATE,
        MESH_FILE,
    ],
};

/// `nav_msgs/msg/Path`.
pub const PATH: MessageSchema = MessageSchema {
    name: "nav_msgs/msg/Path",
    main: "std_msgs/Header header\ngeometry_msgs/PoseStamped[] poses\n",
    dependencies: &[HEADER, TIME, POSE_STAMPED, POSE, POINT, QUATERNION],
};
