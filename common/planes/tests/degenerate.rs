//! Frames without structure: missing, garbage, tiny or empty depth never panic and give
//! no planes and "no MA"; lines alone give axes; a gap without MA keeps the labels.

mod common;

use common::{BoxRoom, Rng, angle_deg, fr1_camera, pose, true_axes};
use gfs_core::Image;
use gfs_core::camera::PinholeCamera;
use gfs_planes::{ManhattanEstimator, PlaneConfig, PlaneError, PlaneExtractor, associate_lines};
use nalgebra::{Rotation3, Vector3};

fn extract(depth: &Image<f32>, cam: &PinholeCamera) -> Vec<gfs_planes::Plane> {
    let mut extractor = PlaneExtractor::new(&PlaneConfig::default()).unwrap();
    let mut planes = vec![gfs_planes::Plane::default(); 3];
    extractor.extract(&depth.view(), cam, &mut planes).unwrap();
    planes
}

#[test]
fn all_missing_depth_gives_no_plane_and_no_ma() {
    let cam = fr1_camera();
    let planes = extract(&Image::new(640, 480), &cam);
    assert!(planes.is_empty());
    let mut ma = ManhattanEstimator::new(&PlaneConfig::default()).unwrap();
    assert!(ma.estimate(&planes, &[], &[], None).is_none());
}

#[test]
fn garbage_depth_gives_no_plane_and_no_ma() {
    let cam = fr1_camera();
    let mut rng = Rng::new(3);
    let mut depth = Image::new(640, 480);
    for z in depth.as_mut_slice() {
        *z = match rng.next_u64() % 8 {
            0 => f32::NAN,
            1 => f32::INFINITY,
            2 => -1.0,
            _ => (0.5 + 4.5 * rng.uniform()) as f32,
        };
    }
    let planes = extract(&depth, &cam);
    assert!(planes.is_empty(), "{} planes", planes.len());
    let mut ma = ManhattanEstimator::new(&PlaneConfig::default()).unwrap();
    assert!(ma.estimate(&planes, &[], &[], None).is_none());
}

#[test]
fn tiny_and_empty_images_do_not_panic() {
    let mut extractor = PlaneExtractor::new(&PlaneConfig::default()).unwrap();
    let mut planes = Vec::new();
    for (w, h) in [(0, 0), (0, 5), (1, 1), (3, 2), (7, 7), (13, 9), (640, 3)] {
        let cam = PinholeCamera::new(500.0, 500.0, w as f64 / 2.0, h as f64 / 2.0, w, h);
        let mut depth = Image::new(w, h);
        depth.fill(2.0);
        extractor.extract(&depth.view(), &cam, &mut planes).unwrap();
        assert!(planes.is_empty(), "{w}x{h}");
        assert_eq!(extractor.labels().len(), (w / 4) * (h / 4));
    }
    let cam = fr1_camera();
    let e = extractor.extract(&Image::new(320, 240).view(), &cam, &mut planes);
    assert!(matches!(
        e,
        Err(PlaneError::SizeMismatch {
            depth_width: 320,
            ..
        })
    ));
}

/// Lines only (no plane): 20 lines along the three room axes with 1-2 deg of noise plus
/// 10 random ones give the room axes within 1 deg, and each axis line is associated.
#[test]
fn lines_alone_give_the_axes_and_are_associated() {
    let mut rng = Rng::new(5);
    let truth = Rotation3::from_euler_angles(0.4, -0.7, 1.9);
    let mut dirs = Vec::new();
    let mut axis_of = Vec::new();
    for i in 0..30 {
        let d = if i < 20 {
            let a = truth.matrix().column(i % 3).into_owned();
            let noise = Vector3::new(rng.gaussian(), rng.gaussian(), rng.gaussian()) * 0.02;
            axis_of.push(Some(i % 3));
            (a + noise) * if i % 2 == 0 { 1.0 } else { -2.0 }
        } else {
            axis_of.push(None);
            Vector3::new(rng.gaussian(), rng.gaussian(), rng.gaussian())
        };
        dirs.push(d.cast::<f32>());
    }
    let weights = vec![1.0; dirs.len()];
    let mut ma = ManhattanEstimator::new(&PlaneConfig::default()).unwrap();
    let axes = ma.estimate(&[], &dirs, &weights, None).unwrap();
    assert_eq!(axes.observed_count(), 3);
    let mut worst: f64 = 0.0;
    for i in 0..3 {
        let t = truth.matrix().column(i).into_owned();
        let best = (0..3)
            .map(|j| angle_deg(&t, &axes.axis(j), true))
            .fold(f64::INFINITY, f64::min);
        worst = worst.max(best);
    }
    assert!(worst <= 1.0, "{worst:.3} deg");
    let mut labels = Vec::new();
    associate_lines(&axes, &dirs, 6f32.to_radians(), &mut labels);
    // Every axis line gets an axis, the same one for lines of the same true axis.
    for i in 0..20 {
        assert!(labels[i].is_some(), "line {i}");
        assert_eq!(labels[i], labels[i % 3], "line {i}");
    }
    println!("lines only: worst axis error {worst:.3} deg, labels {labels:?}");
}

/// Frames with no depth between two box-room frames: no MA in the gap, and the labels
/// after it are those before it (the previous axes are carried by the prediction).
#[test]
fn a_gap_without_ma_keeps_the_labels() {
    let cam = fr1_camera();
    let room = BoxRoom::office();
    let config = PlaneConfig::default();
    let mut extractor = PlaneExtractor::new(&config).unwrap();
    let mut ma = ManhattanEstimator::new(&config).unwrap();
    let mut planes = Vec::new();
    let before = pose(
        Vector3::new(0.3, 0.1, -0.2),
        Rotation3::from_euler_angles(0.3, 0.6, 0.1),
    );
    let after = pose(
        Vector3::new(0.1, 0.0, 0.2),
        Rotation3::from_euler_angles(0.2, 1.2, -0.1),
    );
    let (depth, _) = room.render(&cam, &before);
    extractor.extract(&depth.view(), &cam, &mut planes).unwrap();
    let first = ma.estimate(&planes, &[], &[], None).unwrap();
    assert!(first.observed_count() >= 2);
    // Three empty frames; the motion from `before` to `after` is predicted in the first.
    let step = (after.rotation.inverse() * before.rotation).to_rotation_matrix();
    extractor
        .extract(&Image::new(640, 480).view(), &cam, &mut planes)
        .unwrap();
    assert!(ma.estimate(&planes, &[], &[], Some(&step)).is_none());
    for _ in 0..2 {
        assert!(ma.estimate(&planes, &[], &[], None).is_none());
    }
    let (depth, _) = room.render(&cam, &after);
    extractor.extract(&depth.view(), &cam, &mut planes).unwrap();
    let second = ma.estimate(&planes, &[], &[], None).unwrap();
    // Axis i is the same room direction with the same sign in both frames.
    let label = true_axes(&before).transpose() * first.rotation.matrix();
    let label_after = true_axes(&after).transpose() * second.rotation.matrix();
    assert!((label - label_after).amax() < 0.02, "{label} {label_after}");
}

/// A wall at 3 m cut in two by a pillar at 1.5 m: the two halves merge into one plane
/// (same normal and offset), the pillar stays its own; without merging there are three.
#[test]
fn a_wall_split_by_an_occluder_merges_into_one_plane() {
    let cam = fr1_camera();
    let mut depth = Image::new(640, 480);
    for v in 0..480 {
        for u in 0..640 {
            depth.set(u, v, if (280..360).contains(&u) { 1.5 } else { 3.0 });
        }
    }
    let mut planes = Vec::new();
    for (merge_angle_deg, expected) in [(5.0, 2), (0.0, 3)] {
        let config = PlaneConfig {
            merge_angle_deg,
            ..PlaneConfig::default()
        };
        let mut extractor = PlaneExtractor::new(&config).unwrap();
        extractor.extract(&depth.view(), &cam, &mut planes).unwrap();
        assert_eq!(planes.len(), expected, "merge {merge_angle_deg}");
        for p in &planes {
            assert!(p.normal[2] < -0.9999, "{p:?}");
        }
    }
    // Merged: the wall (both halves, ~72 % of the image) first, then the pillar.
    let config = PlaneConfig::default();
    let mut extractor = PlaneExtractor::new(&config).unwrap();
    extractor.extract(&depth.view(), &cam, &mut planes).unwrap();
    assert!((planes[0].offset - 3.0).abs() < 1e-3 && (planes[1].offset - 1.5).abs() < 1e-3);
    assert!(planes[0].pixels > 200_000, "{}", planes[0].pixels);
    let labels = extractor.labels();
    let (w, _) = extractor.grid_size();
    // A node left of the pillar and one right of it carry the same plane index.
    assert_eq!(labels[60 * w + 20], 0);
    assert_eq!(labels[60 * w + 140], 0);
    assert_eq!(labels[60 * w + 80], 1);
}
