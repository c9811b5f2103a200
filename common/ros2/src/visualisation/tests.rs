use super::*;
use crate::cdr::{decode, encode_into};
use gfs_core::scene::{SceneLine, ScenePlane};
use nalgebra::Vector3 as NaVector3;

/// Two map points in front of the first camera, one not finite; a line along axis 0,
/// a floor patch, two keyframes.
fn scene() -> Scene {
    Scene {
        points: vec![
            Point3::new(1.0, 2.0, 3.0),
            Point3::new(0.0, -1.0, 2.0),
            Point3::new(f64::NAN, 0.0, 1.0),
        ],
        lines: vec![SceneLine {
            ends: [Point3::new(0.0, 0.0, 2.0), Point3::new(1.0, 0.0, 2.0)],
            axis: Some(0),
        }],
        planes: vec![ScenePlane {
            corners: [
                Point3::new(-1.0, 1.0, 1.0),
                Point3::new(1.0, 1.0, 1.0),
                Point3::new(1.0, 1.0, 3.0),
                Point3::new(-1.0, 1.0, 3.0),
            ],
            normal: -NaVector3::y(),
            axis: Some(1),
        }],
        keyframes: vec![Isometry3::identity(), Isometry3::translation(0.0, 0.0, 0.5)],
        axes: Some([NaVector3::x(), NaVector3::y(), NaVector3::z()]),
    }
}

fn floats(data: &[u8]) -> Vec<f32> {
    data.chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect()
}

#[test]
fn landmarks_are_x_y_z_rgb_float32_in_odom_without_invalid_points() {
    let cloud = Visualiser::new(&Ros2Config::default())
        .landmarks(&scene(), Stamp::from_nanos(12_500_000_001));
    assert_eq!(cloud.header.frame_id, "odom");
    assert_eq!(
        cloud.header.stamp,
        Time {
            sec: 12,
            nanosec: 500_000_001
        }
    );
    let layout: Vec<(&str, u32, u8, u32)> = cloud
        .fields
        .iter()
        .map(|f| (f.name.as_str(), f.offset, f.datatype, f.count))
        .collect();
    assert_eq!(
        layout,
        [
            ("x", 0, 7, 1),
            ("y", 4, 7, 1),
            ("z", 8, 7, 1),
            ("rgb", 12, 7, 1)
        ]
    );
    // The NaN point is left out; the cloud is dense.
    assert_eq!((cloud.height, cloud.width, cloud.point_step), (1, 2, 16));
    assert_eq!(cloud.row_step, 32);
    assert_eq!(cloud.data.len(), 32);
    assert!(cloud.is_dense && !cloud.is_bigendian);
    let values = floats(&cloud.data);
    // Optical (x right, y down, z forward) to base (x forward, y left, z up):
    // (1, 2, 3) -> (3, -1, -2).
    assert_eq!(&values[0..3], &[3.0, -1.0, -2.0]);
    assert_eq!(&values[4..7], &[2.0, 0.0, 1.0]);
    // The lower point gets viridis' first colour, the higher its last.
    let rgb = |v: f32| v.to_bits().to_be_bytes();
    assert_eq!(rgb(values[3]), [0, 68, 1, 84]);
    assert_eq!(rgb(values[7]), [0, 253, 231, 37]);
    assert!(
        values
            .iter()
            .enumerate()
            .all(|(i, v)| i % 4 == 3 || v.is_finite())
    );
    // The CDR payload decodes back to the same cloud.
    let mut bytes = Vec::new();
    encode_into(&cloud, "PointCloud2", &mut bytes).unwrap();
    assert_eq!(decode::<PointCloud2>(&bytes, "PointCloud2").unwrap(), cloud);
}

#[test]
fn structure_has_lines_planes_and_axes_coloured_by_axis() {
    let markers = Visualiser::new(&Ros2Config::default()).structure(&scene(), Stamp::default());
    let by_ns = |ns: &str| markers.markers.iter().find(|m| m.ns == ns).unwrap();
    let lines = by_ns("lines");
    assert_eq!(
        (lines.kind, lines.points.len(), lines.colors.len()),
        (LINE_LIST, 2, 2)
    );
    assert_eq!((lines.points[1].x, lines.points[1].y), (2.0, -1.0));
    assert_eq!(lines.colors[0].r, AXIS_COLORS[0][0]);
    let planes = by_ns("planes");
    assert_eq!((planes.kind, planes.points.len()), (TRIANGLE_LIST, 6));
    // The floor 1 m below the camera: z = -1 in odom for every vertex.
    assert!(planes.points.iter().all(|p| p.z == -1.0));
    assert!(
        planes
            .colors
            .iter()
            .all(|c| c.g == AXIS_COLORS[1][1] && c.a == PLANE_ALPHA)
    );
    let axes = by_ns("axes");
    assert_eq!(axes.points.len(), 6);
    // Optical z (axis 2) is the base's x.
    assert_eq!(
        (axes.points[5].x, axes.points[5].y, axes.points[5].z),
        (AXIS_LENGTH_M, 0.0, 0.0)
    );
    assert!(
        markers
            .markers
            .iter()
            .all(|m| m.header.frame_id == "odom" && m.scale.x > 0.0)
    );
    let mut bytes = Vec::new();
    encode_into(&markers, "MarkerArray", &mut bytes).unwrap();
    assert_eq!(
        decode::<MarkerArray>(&bytes, "MarkerArray").unwrap(),
        markers
    );
}

#[test]
fn paths_hold_base_poses_in_their_frames() {
    let visualiser = Visualiser::new(&Ros2Config::default());
    let keyframes = visualiser.keyframes(&scene(), Stamp::default());
    assert_eq!(keyframes.header.frame_id, "map");
    assert_eq!(keyframes.poses.len(), 2);
    // 0.5 m along the optical axis: 0.5 m forward (x) of the base, no rotation.
    let p = keyframes.poses[1].pose;
    assert!((p.position.x - 0.5).abs() < 1e-12 && p.position.y.abs() < 1e-12);
    assert!((p.orientation.w.abs() - 1.0).abs() < 1e-12);
    let poses: Vec<(Stamp, Isometry3<f64>)> = (0..3)
        .map(|k| {
            (
                Stamp::from_nanos(10_000_000_000 + i64::from(k) * 33_333_333),
                Isometry3::translation(0.0, 0.0, 0.1 * f64::from(k)),
            )
        })
        .collect();
    let path = visualiser.path(&poses, poses[2].0);
    assert_eq!(path.header.frame_id, "odom");
    assert_eq!(path.poses.len(), 3);
    assert_eq!(
        path.poses[2].header.stamp,
        Time {
            sec: 10,
            nanosec: 66_666_666
        }
    );
    let mut bytes = Vec::new();
    encode_into(&path, "Path", &mut bytes).unwrap();
    assert_eq!(decode::<Path>(&bytes, "Path").unwrap(), path);
}

#[test]
fn the_schemas_name_every_type_they_use() {
    for schema in [msg::POINT_CLOUD2, msg::MARKER_ARRAY, msg::PATH] {
        let text = schema.text();
        for used in [
            "Header",
            "PointField",
            "Marker",
            "ColorRGBA",
            "PoseStamped",
            "MeshFile",
        ] {
            let referenced = text.lines().any(|l| {
                l.split_whitespace()
                    .next()
                    .is_some_and(|t| t.trim_end_matches("[]").ends_with(used))
            });
            let defined = text.contains(&format!("/{used}\n"));
            assert!(
                !referenced || defined,
                "{} uses {used} without defining it",
                schema.name
            );
        }
    }
    assert!(VisualisationConfig::default().validate().is_ok());
    let zero = VisualisationConfig {
        path_rate_hz: 0.0,
        ..VisualisationConfig::default()
    };
    assert!(zero.validate().unwrap_err().contains("path_rate_hz"));
}
