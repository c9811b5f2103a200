//! ROS 2 bags written with this crate's writer, read back as frames; bags with missing
//! topics, missing depth or a cut-off file give errors naming the topic, never a panic.

use gfs_ros2::Transport;
use gfs_ros2::bag::{BagError, BagReader, BagTopics, BagWriter, Compression, scan};
use gfs_ros2::msg::{CameraInfo, Header, Image, Time};
use gfs_ros2::schema;
use gfs_ros2::transport::TransportImage;
use std::path::{Path, PathBuf};

fn topics() -> BagTopics {
    BagTopics {
        colour: "/c".to_owned(),
        depth: "/d".to_owned(),
        camera_info: "/i".to_owned(),
        transport: Transport::Raw,
        imu: None,
    }
}

fn dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("gfs-ros2-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn image(stamp_ms: i64, encoding: &str) -> Image {
    let ns = stamp_ms * 1_000_000;
    Image {
        header: Header {
            stamp: Time {
                sec: (ns / 1_000_000_000) as i32,
                nanosec: (ns % 1_000_000_000) as u32,
            },
            frame_id: "cam".to_owned(),
        },
        height: 2,
        width: 2,
        encoding: encoding.to_owned(),
        is_bigendian: 0,
        step: 6,
        data: vec![7; 12],
    }
}

/// Writes frames at 0, 33, 66 ... ms; `depth_for(k)` says which get a depth image.
fn write(path: &Path, frames: i64, depth_for: impl Fn(i64) -> bool, info: bool) {
    let mut w = BagWriter::create(path, Compression::default()).unwrap();
    for k in 0..frames {
        let t = k * 33;
        let ns = (t * 1_000_000) as u64;
        if info {
            let mut ci = CameraInfo::default();
            ci.k[0] = 500.0;
            w.write("/i", &schema::CAMERA_INFO, ns, &ci).unwrap();
        }
        w.write("/c", &schema::IMAGE, ns, &image(t, "rgb8"))
            .unwrap();
        if depth_for(k) {
            w.write("/d", &schema::IMAGE, ns + 1000, &image(t + 2, "16UC1"))
                .unwrap();
        }
        w.write(
            "/other",
            &schema::STRING,
            ns,
            &gfs_ros2::msg::StringMsg::default(),
        )
        .unwrap();
    }
    w.finish().unwrap();
}

#[test]
fn a_written_bag_reads_back_as_paired_frames() {
    let d = dir("pairs");
    let path = d.join("b.mcap");
    write(&path, 5, |_| true, true);
    let (stamps, info) = scan(&d, &topics(), 0.01).unwrap();
    let ms: Vec<i64> = stamps.iter().map(|s| s.nanos() / 1_000_000).collect();
    assert_eq!(ms, [0, 33, 66, 99, 132]);
    assert_eq!(info.k[0], 500.0);
    let mut reader = BagReader::open(&path, &topics(), 0.01).unwrap();
    let first = reader.next_frame().unwrap().unwrap();
    let (TransportImage::Raw(colour), TransportImage::Raw(depth)) = (first.colour, first.depth)
    else {
        panic!("raw images were written");
    };
    assert_eq!(
        (colour.encoding.as_str(), depth.encoding.as_str()),
        ("rgb8", "16UC1")
    );
    assert_eq!(depth.header.stamp.nanosec, 2_000_000);
    let mut n = 1;
    while reader.next_frame().unwrap().is_some() {
        n += 1;
    }
    assert_eq!(n, 5);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn colour_without_depth_is_skipped_and_a_missing_topic_is_named() {
    let d = dir("missing");
    let path = d.join("b.mcap");
    write(&path, 6, |k| k % 2 == 0, true);
    let (stamps, _) = scan(&path, &topics(), 0.01).unwrap();
    let ms: Vec<i64> = stamps.iter().map(|s| s.nanos() / 1_000_000).collect();
    assert_eq!(ms, [0, 66, 132], "frames 1, 3, 5 have no depth");
    write(&path, 3, |_| false, true);
    match scan(&path, &topics(), 0.01) {
        Err(BagError::MissingTopic { topic, found, .. }) => {
            assert_eq!(topic, "/d");
            assert_eq!(found, "/c, /i, /other");
        }
        other => panic!("expected a missing /d, got {other:?}"),
    }
    write(&path, 3, |_| true, false);
    let e = scan(&path, &topics(), 0.01).unwrap_err();
    assert!(e.to_string().contains("no message on /i"), "{e}");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn not_a_bag_and_a_cut_off_bag_are_errors() {
    let d = dir("bad");
    assert!(matches!(
        BagReader::open(&d, &topics(), 0.01),
        Err(BagError::NotABag { .. })
    ));
    let path = d.join("b.mcap");
    write(&path, 4, |_| true, true);
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
    let e = scan(&path, &topics(), 0.01).unwrap_err();
    assert!(matches!(e, BagError::Truncated { .. }), "{e}");
    std::fs::write(&path, b"not an mcap file").unwrap();
    assert!(scan(&path, &topics(), 0.01).is_err());
    let _ = std::fs::remove_dir_all(&d);
}
