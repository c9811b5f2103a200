//! The status and the covariance a frame leaves with: a direction its measurements
//! leave weak makes it `degraded` with a large sigma, a frame its features determine
//! is `tracked` with a small one.

use crate::config::{OdometryConfig, TrackingConfig};
use crate::frontend::features::FrameFeatures;
use crate::map::Map;
use crate::testing::{Scene, camera, first_keyframe, pose, relinked, scale, textured_planes_depth};
use crate::tracking::sightings::Sightings;
use crate::tracking::status::TrackingStatus;
use crate::tracking::tracker::{TrackedFrame, Tracker};
use gfs_core::ids::FrameId;
use gfs_lines::grid::GridConfig;
use nalgebra::{Isometry3, Matrix3, Vector3, Vector6};

/// The largest translation standard deviation of `covariance` (metres) and its
/// direction.
fn largest_translation_sigma(covariance: &nalgebra::Matrix6<f64>) -> (f64, Vector3<f64>) {
    let block: Matrix3<f64> = covariance.fixed_view::<3, 3>(0, 0).into_owned();
    let eigen = block.symmetric_eigen();
    let k = eigen.eigenvalues.imax();
    (
        eigen.eigenvalues[k].sqrt(),
        eigen.eigenvectors.column(k).into_owned(),
    )
}

#[test]
fn a_bare_wall_is_degraded_with_its_slide_reported_free() {
    // A wall 2 m ahead (normal z), flat gray with its noise, no point, no line: its
    // depth fixes the distance to it and the tilts, not the slide along it. The frame
    // is posed on what its depth determines (the motion prior holds the slide) and is
    // `degraded`, its covariance decimetres along the wall and millimetres across it.
    const WALL: [([f64; 3], f64); 1] = [([0.0, 0.0, 1.0], 2.0)];
    let flat = |_: &Vector3<f64>| 150.0;
    let config = TrackingConfig {
        use_depth_alignment: true,
        ..TrackingConfig::default()
    };
    let mut tracker = Tracker::new(config, camera(), scale(), &GridConfig::default());
    let features = |k: u64, pose: &Isometry3<f64>| FrameFeatures {
        id: FrameId(k),
        timestamp: crate::testing::frame_stamp(k),
        depth: textured_planes_depth(&camera(), pose, &WALL, flat, k),
        ..FrameFeatures::default()
    };
    let step = gfs_core::se3::exp(&Vector6::new(-0.004, 0.002, 0.0, 0.0, 0.0, 0.0017));
    let mut truth = Isometry3::identity();
    let mut first = TrackedFrame::untracked(features(0, &truth), truth);
    first.status = TrackingStatus::Tracked;
    tracker.finish_frame(first);
    for k in 1..=3 {
        truth = step * truth;
        let frame = tracker.track(
            &Map::default(),
            features(k, &truth),
            &mut Sightings::default(),
        );
        assert_eq!(frame.status, TrackingStatus::Degraded, "frame {k}");
        let c = tracker.pose_covariance(&frame, None).expect("a covariance");
        let sigma = |i: usize| c[(i, i)].sqrt();
        assert!(sigma(0) > 0.1 && sigma(1) > 0.1, "frame {k}: {c}");
        assert!(sigma(2) < 0.005, "frame {k}: {c}");
        // The distance to the wall is measured: the camera's depth within a millimetre.
        let depth_error = (frame.camera_from_world * truth.inverse()).translation.z;
        assert!(depth_error.abs() < 1e-3, "frame {k}: {depth_error}");
        tracker.finish_frame(frame);
    }
}

#[test]
fn a_textured_frame_is_tracked_with_a_millimetre_sigma() {
    let scene = Scene::new(200, 20);
    let (map, _, kf) = first_keyframe(&scene, &OdometryConfig::default());
    let mut tracker = Tracker::new(
        TrackingConfig::default(),
        camera(),
        scale(),
        &GridConfig::default(),
    );
    tracker.set_reference(kf);
    tracker.finish_frame(relinked(map.keyframe(kf).expect("kf")));
    // A millimetre from the keyframe: the first step counts as jitter (from standing
    // still, `PoseJitter`), a millimetre over sqrt(2) per average.
    let truth = pose(0.001, 0.0);
    let frame = tracker.track(&map, scene.features(1, &truth), &mut Sightings::default());
    assert_eq!(frame.status, TrackingStatus::Tracked);
    let covariance = tracker.pose_covariance(&frame, None).expect("a covariance");
    let (sigma, _) = largest_translation_sigma(&covariance);
    assert!(sigma < 0.003, "{sigma} m");
}

#[test]
fn a_distant_facade_is_degraded_with_a_sigma_above_the_bound() {
    // The textured scene twenty times as far (30-70 m): the keypoints fix the rotation,
    // their depths hardly the distance: the translation is left weak.
    let near = Scene::new(200, 0);
    let scene = Scene {
        points: near.points.iter().map(|p| p * 20.0).collect(),
        lines: Vec::new(),
    };
    let (map, _, kf) = first_keyframe(&scene, &OdometryConfig::default());
    let mut tracker = Tracker::new(
        TrackingConfig::default(),
        camera(),
        scale(),
        &GridConfig::default(),
    );
    tracker.set_reference(kf);
    tracker.finish_frame(relinked(map.keyframe(kf).expect("kf")));
    let truth = pose(0.001, 0.0);
    let frame = tracker.track(&map, scene.features(1, &truth), &mut Sightings::default());
    let covariance = tracker.pose_covariance(&frame, None).expect("a covariance");
    let (sigma, direction) = largest_translation_sigma(&covariance);
    assert_eq!(
        frame.status,
        TrackingStatus::Degraded,
        "{sigma} m along {direction}, {:?}",
        frame.inliers
    );
    // Above the 15 mm of `[tracking.depth] max_sigma_m` that makes a frame `degraded`.
    assert!(sigma > 0.015, "{sigma} m along {direction}");
}
