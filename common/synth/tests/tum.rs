//! Writing a sequence in TUM layout and reading it back.

use gfs_core::camera::CameraConfig;
use gfs_synth::{NoiseConfig, SynthConfig, SynthSequence};
use std::fs;
use std::path::PathBuf;

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("gfs-synth-{name}-{}", std::process::id()));
    let _ = fs::remove_dir_all(&dir);
    dir
}

#[test]
fn write_tum_round_trips_images_depth_lists_and_ground_truth() {
    let seq = SynthSequence::new(SynthConfig {
        frames: 3,
        camera: SynthConfig::scaled_camera(64),
        noise: NoiseConfig::default(),
        ..SynthConfig::default()
    });
    let dir = temp_dir("tum");
    let mut calls = Vec::new();
    seq.write_tum(&dir, |n| calls.push(n)).unwrap();
    assert_eq!(calls, [1, 2, 3]);

    let lines = |file: &str| -> Vec<String> {
        fs::read_to_string(dir.join(file))
            .unwrap()
            .lines()
            .filter(|l| !l.starts_with('#'))
            .map(str::to_owned)
            .collect()
    };
    let rgb_list = lines("rgb.txt");
    assert_eq!(
        rgb_list,
        [
            "1000.000000 rgb/1000.000000.png",
            "1000.033333 rgb/1000.033333.png",
            "1000.066667 rgb/1000.066667.png"
        ]
    );
    assert_eq!(lines("depth.txt")[2], "1000.066667 depth/1000.066667.png");
    assert_eq!(
        lines("associations.txt")[1],
        "1000.033333 rgb/1000.033333.png 1000.033333 depth/1000.033333.png"
    );

    let gt = lines("groundtruth.txt");
    assert_eq!(gt.len(), 3);
    for (i, line) in gt.iter().enumerate() {
        let v: Vec<f64> = line
            .split_whitespace()
            .map(|s| s.parse().unwrap())
            .collect();
        let pose = seq.pose(i);
        let q = pose.rotation.coords;
        let expected = [
            seq.timestamp(i).secs(),
            pose.translation.x,
            pose.translation.y,
            pose.translation.z,
            q.x,
            q.y,
            q.z,
            q.w,
        ];
        for (a, b) in v.iter().zip(expected) {
            assert!((a - b).abs() < 1e-6, "frame {i}: {a} vs {b}");
        }
    }

    for i in 0..3 {
        let frame = seq.render(i);
        let stamp = seq.timestamp(i);
        let rgb = image::open(dir.join("rgb").join(format!("{stamp}.png"))).unwrap();
        let rgb = rgb.as_rgb8().expect("8-bit RGB");
        assert_eq!((rgb.width(), rgb.height()), (64, 48));
        let read: Vec<[u8; 3]> = rgb.pixels().map(|p| p.0).collect();
        assert_eq!(read.as_slice(), frame.rgb.as_slice());
        let depth = image::open(dir.join("depth").join(format!("{stamp}.png"))).unwrap();
        let depth = depth.as_luma16().expect("16-bit gray depth");
        let mut holes = 0;
        for (raw, &z) in depth.pixels().zip(frame.depth.as_slice()) {
            // Noisy depth is already on the 1/5000 m grid: the file holds it exactly.
            assert_eq!(u32::from(raw.0[0]), (f64::from(z) * 5000.0).round() as u32);
            holes += usize::from(raw.0[0] == 0);
        }
        assert!(holes < 64 * 48 / 3);
    }

    #[derive(serde::Deserialize)]
    struct Marker {
        camera: CameraConfig,
        depth: toml::Table,
        #[serde(default)]
        tracking: toml::Table,
    }
    let marker: Marker =
        toml::from_str(&fs::read_to_string(dir.join("synthetic.toml")).unwrap()).unwrap();
    let cam = seq.config().camera;
    assert_eq!(
        (marker.camera.fx, marker.camera.cx, marker.camera.width),
        (cam.fx, cam.cx, 64)
    );
    assert_eq!(marker.depth["scale"].as_float(), Some(5000.0));
    // Nothing tuned to the rendered noise: the odometry's defaults hold every camera.
    assert!(marker.tracking.is_empty(), "{:?}", marker.tracking);
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn write_tum_into_an_unwritable_place_is_an_error_naming_it() {
    let seq = SynthSequence::new(SynthConfig {
        frames: 1,
        camera: SynthConfig::scaled_camera(16),
        ..SynthConfig::default()
    });
    let file = temp_dir("not-a-dir");
    fs::write(&file, b"x").unwrap();
    let err = seq.write_tum(&file, |_| {}).unwrap_err().to_string();
    assert!(err.contains("not-a-dir"), "{err}");
    fs::remove_file(&file).unwrap();
}

#[test]
fn the_project_dataset_reader_reads_back_what_was_rendered() {
    let seq = SynthSequence::new(SynthConfig {
        frames: 4,
        camera: SynthConfig::scaled_camera(64),
        ..SynthConfig::default()
    });
    let dir = temp_dir("reader");
    seq.write_tum(&dir, |_| {}).unwrap();
    let camera = gfs_core::camera::Camera {
        pinhole: seq.config().camera,
        distortion: Default::default(),
    };
    let dataset =
        gfs_dataset::Sequence::open(&dir, &camera, &gfs_dataset::DepthConfig::default()).unwrap();
    assert_eq!(dataset.len(), 4);
    for i in 0..4 {
        let (read, rendered) = (dataset.load(i).unwrap(), seq.render(i));
        assert_eq!(read.timestamp, rendered.timestamp);
        assert_eq!(read.rgb, rendered.rgb, "frame {i}");
        assert_eq!(read.gray, rendered.gray, "frame {i}");
        for (a, b) in read.depth.as_slice().iter().zip(rendered.depth.as_slice()) {
            assert!(
                (a - b).abs() < 1e-6,
                "frame {i}: depth {a} read, {b} rendered"
            );
        }
    }
    let gt = gfs_dataset::Trajectory::read_tum(&dir.join("groundtruth.txt")).unwrap();
    for (i, pose) in gt.poses().iter().enumerate() {
        assert!((pose.translation.vector - seq.pose(i).translation.vector).norm() < 1e-8);
        assert!(pose.rotation.angle_to(&seq.pose(i).rotation) < 1e-8);
    }
    fs::remove_dir_all(&dir).unwrap();
}
