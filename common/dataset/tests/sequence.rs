//! Reading TUM-layout folders written by the tests themselves: values, association,
//! undistortion, the read-ahead iterator, and the errors bad input must give.

use gfs_core::camera::{Camera, CameraConfig, UndistortMap};
use gfs_dataset::{DatasetError, DepthConfig, Sequence, gray_bt601};
use image::{ExtendedColorType, ImageFormat};
use std::path::{Path, PathBuf};

const W: usize = 16;
const H: usize = 12;

/// A scratch folder removed when dropped.
struct TempDir(PathBuf);

impl TempDir {
    fn new(name: &str) -> Self {
        let dir = std::env::temp_dir().join(format!("gfs_dataset_{name}_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("rgb")).unwrap();
        std::fs::create_dir_all(dir.join("depth")).unwrap();
        Self(dir)
    }

    fn path(&self) -> &Path {
        &self.0
    }

    fn write(&self, rel: &str, text: &str) {
        std::fs::write(self.0.join(rel), text).unwrap();
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Colour of pixel (x, y) in frame k: a gradient that differs per frame.
fn colour(x: usize, y: usize, k: usize) -> [u8; 3] {
    [(x * 15) as u8, (y * 20) as u8, (k * 50 + 10) as u8]
}

/// Raw depth of pixel (x, y) in frame k: 1 m + 1 mm per column and frame, with a hole
/// at (0, 0) and a saturated 65535 at (1, 0).
fn raw_depth(x: usize, y: usize, k: usize) -> u16 {
    match (x, y) {
        (0, 0) => 0,
        (1, 0) => u16::MAX,
        _ => (5000 + 5 * x + 5 * k) as u16,
    }
}

fn write_rgb(dir: &Path, rel: &str, w: usize, h: usize, k: usize, format: ImageFormat) {
    let mut buf = Vec::with_capacity(w * h * 3);
    for y in 0..h {
        for x in 0..w {
            buf.extend_from_slice(&colour(x, y, k));
        }
    }
    image::save_buffer_with_format(
        dir.join(rel),
        &buf,
        w as u32,
        h as u32,
        ExtendedColorType::Rgb8,
        format,
    )
    .unwrap();
}

fn write_depth16(dir: &Path, rel: &str, w: usize, h: usize, k: usize) {
    let mut img = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::new(w as u32, h as u32);
    for (x, y, p) in img.enumerate_pixels_mut() {
        p.0[0] = raw_depth(x as usize, y as usize, k);
    }
    img.save_with_format(dir.join(rel), ImageFormat::Png)
        .unwrap();
}

fn write_depth8(dir: &Path, rel: &str) {
    let buf = vec![100u8; W * H];
    image::save_buffer_with_format(
        dir.join(rel),
        &buf,
        W as u32,
        H as u32,
        ExtendedColorType::L8,
        ImageFormat::Png,
    )
    .unwrap();
}

fn camera(k1: f64) -> Camera {
    Camera::from_config(&CameraConfig {
        k1,
        ..CameraConfig::pinhole(20.0, 20.0, 7.5, 5.5, W, H)
    })
    .unwrap()
}

/// A folder of `n` frames: colour at 30 Hz from t = 10 s, depth 4 ms later, and one extra
/// depth image 60 ms after the last colour one (associated with nothing).
fn tum_folder(name: &str, n: usize) -> TempDir {
    let dir = TempDir::new(name);
    let mut rgb = String::from("# colour images\n# timestamp filename\n");
    let mut depth = String::from("# depth images\n");
    for k in 0..=n {
        let t = 10.0 + k as f64 / 30.0;
        if k < n {
            rgb += &format!("{t:.6} rgb/{k}.png\n");
            write_rgb(
                dir.path(),
                &format!("rgb/{k}.png"),
                W,
                H,
                k,
                ImageFormat::Png,
            );
        }
        let td = if k < n { t + 0.004 } else { t + 0.06 };
        depth += &format!("{td:.6} depth/{k}.png\n");
        write_depth16(dir.path(), &format!("depth/{k}.png"), W, H, k);
    }
    dir.write("rgb.txt", &rgb);
    dir.write("depth.txt", &depth);
    dir
}

#[test]
fn a_tum_folder_without_associations_is_associated_and_decoded() {
    let dir = tum_folder("plain", 4);
    let seq = Sequence::open(dir.path(), &camera(0.0), &DepthConfig::default()).unwrap();
    assert_eq!(seq.len(), 4);
    assert!((seq.timestamps()[1].secs() - (10.0 + 1.0 / 30.0)).abs() < 1e-6);
    assert_eq!(seq.ground_truth_path(), None);
    let f = seq.load(2).unwrap();
    assert_eq!(f.id.0, 2);
    assert_eq!((f.rgb.width(), f.rgb.height(), f.depth.width()), (W, H, W));
    assert_eq!(f.rgb.get(3, 4), Some(colour(3, 4, 2)));
    assert_eq!(f.gray.get(3, 4), Some(gray_bt601(colour(3, 4, 2))));
    // Raw 5000 + 5 * 3 + 5 * 2 = 5025 -> 1.005 m; the hole and 65535 are missing.
    assert!((f.depth.get(3, 4).unwrap() - 1.005).abs() < 1e-6);
    assert_eq!(f.depth.get(0, 0), Some(0.0));
    assert_eq!(f.depth.get(1, 0), Some(0.0));
    assert!(matches!(
        seq.load(4),
        Err(DatasetError::IndexOutOfRange { index: 4, len: 4 })
    ));
    dir.write("groundtruth.txt", "# nothing\n");
    assert_eq!(
        seq.ground_truth_path(),
        Some(dir.path().join("groundtruth.txt"))
    );
}

#[test]
fn the_reader_thread_yields_every_frame_in_order_and_stops_when_dropped() {
    let dir = tum_folder("reader", 6);
    let seq = Sequence::open(dir.path(), &camera(0.0), &DepthConfig::default()).unwrap();
    let mut reader = seq.frames(None);
    assert_eq!(reader.len(), 6);
    let mut ids = Vec::new();
    while let Some(frame) = reader.next() {
        let frame = frame.unwrap();
        assert_eq!(frame.rgb.get(5, 5), Some(colour(5, 5, frame.id.0 as usize)));
        ids.push(frame.id.0);
        // Lend the buffers back: later frames must still be decoded correctly.
        reader.recycle(frame);
    }
    assert_eq!(ids, vec![0, 1, 2, 3, 4, 5]);
    assert_eq!(seq.frames(Some(2)).count(), 2);
    assert_eq!(seq.frames(Some(100)).count(), 6);
    // Take one frame and drop the reader while its thread is blocked on a full channel.
    let mut early = seq.frames_ahead(None, 1);
    assert!(early.next().unwrap().is_ok());
    drop(early);
}

#[test]
fn associations_txt_is_used_and_depth_first_lines_are_understood() {
    let dir = tum_folder("assoc", 3);
    // ICL-NUIM style: depth first, and only frames 0 and 2.
    dir.write(
        "associations.txt",
        "# icl\n10.000000 depth/0.png 10.000000 rgb/0.png\n10.066667 depth/2.png 10.066667 rgb/2.png\n",
    );
    let seq = Sequence::open(dir.path(), &camera(0.0), &DepthConfig::default()).unwrap();
    assert_eq!(seq.len(), 2);
    let f = seq.load(1).unwrap();
    assert_eq!(f.rgb.get(1, 1), Some(colour(1, 1, 2)));
    assert!((f.depth.get(2, 2).unwrap() - (5000.0 + 10.0 + 10.0) / 5000.0).abs() < 1e-6);
}

#[test]
fn jpeg_colour_decodes() {
    let dir = tum_folder("jpeg", 1);
    write_rgb(dir.path(), "rgb/j.jpg", W, H, 0, ImageFormat::Jpeg);
    dir.write("associations.txt", "1.0 rgb/j.jpg 1.0 depth/0.png\n");
    let seq = Sequence::open(dir.path(), &camera(0.0), &DepthConfig::default()).unwrap();
    let f = seq.load(0).unwrap();
    let (got, want) = (f.rgb.get(8, 6).unwrap(), colour(8, 6, 0));
    for c in 0..3 {
        assert!(
            (i32::from(got[c]) - i32::from(want[c])).abs() <= 12,
            "{got:?} vs {want:?}"
        );
    }
}

#[test]
fn a_distorted_camera_gets_undistorted_colour_and_depth() {
    let dir = tum_folder("distorted", 1);
    let cam = camera(-0.2);
    let seq = Sequence::open(dir.path(), &cam, &DepthConfig::default()).unwrap();
    let f = seq.load(0).unwrap();
    // The same as undistorting the raw images with the camera's table.
    let raw = Sequence::open(dir.path(), &camera(0.0), &DepthConfig::default())
        .unwrap()
        .load(0)
        .unwrap();
    let map = UndistortMap::new(&cam);
    let (mut rgb, mut depth) = (gfs_core::Image::new(0, 0), gfs_core::Image::new(0, 0));
    map.remap_rgb(&raw.rgb.view(), &mut rgb).unwrap();
    map.remap_depth(&raw.depth.view(), &mut depth).unwrap();
    assert_eq!(f.rgb, rgb);
    assert_eq!(f.depth, depth);
    // And it moved pixels: barrel distortion changes the corners.
    assert_ne!(f.rgb, raw.rgb);
}

fn open_err(dir: &Path) -> DatasetError {
    Sequence::open(dir, &camera(0.0), &DepthConfig::default()).unwrap_err()
}

#[test]
fn bad_folders_and_lists_name_the_file_and_line() {
    let empty = TempDir::new("empty");
    let err = open_err(empty.path());
    assert!(
        matches!(&err, DatasetError::MissingList { path } if path.ends_with("rgb.txt")),
        "{err}"
    );

    let dir = tum_folder("lists", 3);
    dir.write("depth.txt", "# only comments\n");
    let err = open_err(dir.path());
    assert!(matches!(err, DatasetError::NoFrames { .. }), "{err}");

    dir.write("depth.txt", "10.0 depth/0.png\n10.1 depth/1.png extra\n");
    let err = open_err(dir.path());
    assert!(
        matches!(err, DatasetError::MalformedLine { line: 2, .. }),
        "{err}"
    );
    assert!(err.to_string().contains("depth.txt:2:"), "{err}");

    dir.write("depth.txt", "# c\n10.0 depth/0.png\nten depth/1.png\n");
    assert!(matches!(
        open_err(dir.path()),
        DatasetError::MalformedLine { line: 3, .. }
    ));

    dir.write("depth.txt", "10.1 depth/0.png\n10.0 depth/1.png\n");
    let err = open_err(dir.path());
    assert!(
        matches!(err, DatasetError::TimestampNotIncreasing { line: 2, .. }),
        "{err}"
    );

    // Nothing within 20 ms.
    dir.write("depth.txt", "50.0 depth/0.png\n");
    assert!(matches!(
        open_err(dir.path()),
        DatasetError::NoFrames { .. }
    ));

    dir.write("associations.txt", "# only comments\n");
    let err = open_err(dir.path()).to_string();
    assert!(
        err.ends_with("no frames (associations.txt lists no frame)"),
        "{err}"
    );

    dir.write("associations.txt", "1.0 rgb/0.png 1.0\n");
    let err = open_err(dir.path());
    assert!(
        matches!(err, DatasetError::MalformedLine { line: 1, .. }),
        "{err}"
    );
}

#[test]
fn bad_images_are_error_items_and_the_iteration_goes_on() {
    let dir = tum_folder("images", 5);
    write_depth8(dir.path(), "depth/8bit.png");
    write_rgb(dir.path(), "rgb/small.png", W / 2, H, 0, ImageFormat::Png);
    write_depth16(dir.path(), "depth/small.png", W / 2, H / 2, 0);
    dir.write("rgb/garbage.png", "not an image");
    dir.write(
        "associations.txt",
        "1.0 rgb/0.png 1.0 depth/8bit.png\n\
         2.0 rgb/missing.png 2.0 depth/1.png\n\
         3.0 rgb/small.png 3.0 depth/2.png\n\
         4.0 rgb/3.png 4.0 depth/small.png\n\
         5.0 rgb/garbage.png 5.0 depth/3.png\n\
         6.0 rgb/4.png 6.0 depth/4.png\n",
    );
    let seq = Sequence::open(dir.path(), &camera(0.0), &DepthConfig::default()).unwrap();
    let items: Vec<_> = seq.frames(None).collect();
    assert_eq!(items.len(), 6);
    assert!(
        matches!(&items[0], Err(DatasetError::DepthNot16Bit { path, .. }) if path.ends_with("8bit.png"))
    );
    match &items[1] {
        Err(DatasetError::MissingImage { path, list, line }) => {
            assert!(path.ends_with("missing.png") && list.ends_with("associations.txt"));
            assert_eq!(*line, 2);
        }
        other => panic!("{other:?}"),
    }
    assert!(matches!(
        &items[2],
        Err(DatasetError::SizeMismatch {
            got: (8, 12),
            expected: (16, 12),
            ..
        })
    ));
    assert!(matches!(
        &items[3],
        Err(DatasetError::SizeMismatch { got: (8, 6), .. })
    ));
    assert!(
        matches!(&items[4], Err(DatasetError::Decode { path, .. }) if path.ends_with("garbage.png"))
    );
    let last = items[5].as_ref().unwrap();
    assert_eq!((last.id.0, last.rgb.get(2, 2)), (5, Some(colour(2, 2, 4))));
    // Each message names its file.
    for item in &items[..5] {
        let msg = item.as_ref().unwrap_err().to_string();
        assert!(msg.contains(dir.path().to_str().unwrap()), "{msg}");
    }
}

#[test]
fn nine_digit_stamps_reach_the_frames_and_the_trajectory_exactly() {
    let dir = TempDir::new("nanos");
    let stamps = ["1305031102.123456789", "1305031102.156790123"];
    let mut rgb = String::new();
    let mut depth = String::new();
    for (k, stamp) in stamps.iter().enumerate() {
        rgb += &format!("{stamp} rgb/{k}.png\n");
        depth += &format!("{stamp} depth/{k}.png\n");
        write_rgb(
            dir.path(),
            &format!("rgb/{k}.png"),
            W,
            H,
            k,
            ImageFormat::Png,
        );
        write_depth16(dir.path(), &format!("depth/{k}.png"), W, H, k);
    }
    dir.write("rgb.txt", &rgb);
    dir.write("depth.txt", &depth);
    let seq = Sequence::open(dir.path(), &camera(0.0), &DepthConfig::default()).unwrap();
    let listed: Vec<String> = seq.timestamps().iter().map(|s| s.to_string()).collect();
    assert_eq!(listed, stamps);
    assert_eq!(
        seq.load(1).unwrap().timestamp.nanos(),
        1_305_031_102_156_790_123
    );
    let mut trajectory = gfs_dataset::Trajectory::new();
    for &stamp in seq.timestamps() {
        trajectory.push(stamp, nalgebra::Isometry3::identity());
    }
    let mut text = Vec::new();
    trajectory.write_tum_to(&mut text).unwrap();
    let firsts: Vec<String> = String::from_utf8(text)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(' ').next().unwrap().to_owned())
        .collect();
    assert_eq!(firsts, stamps);
}
