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

#[test]
fn frame_points_are_the_matches_with_depth_in_the_camera_frame_coloured_by_inlier() {
    use gfs_core::camera::PinholeCamera;
    use gfs_core::scene::{FramePoint, FrameView};
    let camera = PinholeCamera::new(500.0, 500.0, 320.0, 240.0, 640, 480);
    let point = |uv: [f32; 2], depth: f32, inlier: bool| FramePoint { uv, depth, inlier };
    let view = FrameView {
        points: vec![
            point([320.0, 240.0], 2.0, true),
            point([420.0, 140.0], 1.0, false),
            point([100.0, 100.0], 0.0, true),
            point([100.0, 100.0], f32::NAN, true),
        ],
        lines: Vec::new(),
    };
    let header = frame::camera_header(Time::from(Stamp::from_nanos(3_500_000_000)), "", "cam");
    let cloud = Visualiser::new(&Ros2Config::default()).frame_points(&view, &camera, header);
    assert_eq!(cloud.header.frame_id, "cam");
    // The points without a depth are left out; the others are back-projected.
    assert_eq!(cloud.width, 2);
    let values = floats(&cloud.data);
    assert_eq!(&values[0..3], &[0.0, 0.0, 2.0]);
    assert_eq!(&values[4..7], &[0.2, -0.2, 1.0]);
    let rgb = |v: f32| v.to_bits();
    assert_eq!((rgb(values[3]), rgb(values[7])), (0x0000_E600, 0x00FF_2828));
    let named = frame::camera_header(Time::default(), "camera_color_optical_frame", "cam");
    assert_eq!(named.frame_id, "camera_color_optical_frame");
}

#[test]
fn tracking_images_are_rgb8_or_jpeg_at_their_rate_of_the_data_clock() {
    use frame::{ImageFormat, RateGate, TrackingImage, tracking_image};
    let mut image = gfs_core::RgbImage::new(64, 48);
    image.as_mut_slice().fill([10, 200, 30]);
    let header = frame::camera_header(Time::from(Stamp::from_nanos(1_000_000_000)), "cam", "");
    let TrackingImage::Raw(raw) = tracking_image(&image, header.clone(), ImageFormat::Raw).unwrap()
    else {
        panic!("raw expected")
    };
    assert_eq!(
        (raw.width, raw.height, raw.step, raw.encoding.as_str()),
        (64, 48, 192, "rgb8")
    );
    assert_eq!(&raw.data[..3], &[10, 200, 30]);
    assert_eq!(raw.data.len(), 64 * 48 * 3);
    let TrackingImage::Compressed(jpeg) =
        tracking_image(&image, header, ImageFormat::Jpeg).unwrap()
    else {
        panic!("jpeg expected")
    };
    assert!(jpeg.data.starts_with(&[0xFF, 0xD8]) && jpeg.format.contains("jpeg"));
    let decoded = image::load_from_memory(&jpeg.data).unwrap().to_rgb8();
    assert_eq!(decoded.dimensions(), (64, 48));
    let px = decoded.get_pixel(10, 10).0;
    assert!(
        px.iter()
            .zip([10, 200, 30])
            .all(|(a, b)| a.abs_diff(b) <= 8),
        "{px:?}"
    );
    assert_eq!(
        ImageFormat::Jpeg.topic(),
        "/gfsvo/tracking_image/compressed"
    );

    // 2 Hz of 30 Hz stamps over 3 s: the first frame, then every 0.5 s.
    let mut gate = RateGate::new(2.0);
    let due: Vec<i64> = (0..90)
        .filter(|k| gate.due(Stamp::from_nanos(100_000_000_000 + k * 1_000_000_000 / 30)))
        .collect();
    assert_eq!(due, [0, 15, 30, 45, 60, 75]);
    // A camera that restarted its clock is shown at once.
    assert!(gate.due(Stamp::from_nanos(5_000_000_000)));
    assert!(!gate.due(Stamp::from_nanos(5_100_000_000)));
}

#[test]
fn the_visualisation_table_refuses_rates_and_frames_it_cannot_use() {
    let rate = VisualisationConfig {
        tracking_image_rate_hz: -1.0,
        ..VisualisationConfig::default()
    };
    assert!(
        rate.validate()
            .unwrap_err()
            .contains("tracking_image_rate_hz = -1")
    );
    let frame = VisualisationConfig {
        camera_frame: " ".to_owned(),
        ..VisualisationConfig::default()
    };
    assert!(frame.validate().unwrap_err().contains("camera_frame"));
    let text = "tracking_image_format = \"jpeg\"\ntracking_image_rate_hz = 5.0\n";
    let parsed: VisualisationConfig = toml::from_str(text).unwrap();
    assert_eq!(parsed.tracking_image_format, frame::ImageFormat::Jpeg);
    assert!(toml::from_str::<VisualisationConfig>("tracking_image_format = \"png\"").is_err());
}
