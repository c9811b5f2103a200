//! The two halves' sequencing: requests, answers, resends, loss and restarts, on a
//! scripted scene seen as exact features.

use super::*;
use crate::config::OdometryConfig;
use crate::testing::{Scene, camera, pose};
use crate::tracking::status::TrackingStatus;
use gfs_lines::grid::GridConfig;

fn halves() -> (TrackingSession, MappingSession) {
    let config = OdometryConfig::default();
    let tracking = TrackingSession::new(config.clone(), camera(), 1.2, 8, &GridConfig::default());
    let mapping = MappingSession::new(&config, camera(), 1.2, 8);
    (tracking, mapping)
}

/// The camera moves 1 cm right and turns 0.2 degrees per frame.
fn truth(k: u64) -> nalgebra::Isometry3<f64> {
    pose(0.01 * k as f64, (0.2f64 * k as f64).to_radians())
}

/// Tracks frame `k` of `scene`; a keyframe request is answered by `mapping` at once.
fn step(
    tracking: &mut TrackingSession,
    mapping: &mut MappingSession,
    scene: &Scene,
    k: u64,
) -> (FramePose, Option<KeyFrameRequest>) {
    let out = tracking
        .process(scene.features(k, &truth(k)))
        .expect("consistent features");
    if let Some(request) = &out.keyframe {
        let update = mapping.insert(request.clone());
        assert!(
            tracking.apply(update),
            "the answer to request {}",
            request.seq
        );
    }
    (out.pose, out.keyframe)
}

#[test]
fn the_first_frame_with_depth_starts_the_map_and_its_answer_sets_the_reference() {
    let (mut tracking, mut mapping) = halves();
    let scene = Scene::new(200, 20);
    let out = tracking
        .process(scene.features(0, &truth(0)))
        .expect("features");
    let request = out.keyframe.expect("the first keyframe");
    assert_eq!((request.seq, request.reset), (1, false));
    assert_eq!(tracking.state(), TrackingState::Tracking);
    assert_eq!(
        tracking.pending_request(),
        Some((1, gfs_core::ids::FrameId(0)))
    );
    assert!(
        tracking.needs_map(),
        "nothing to track against before the answer"
    );
    let update = mapping.insert(request);
    assert_eq!((update.seq, mapping.map().point_count()), (1, 200));
    assert!(tracking.apply(update));
    assert_eq!(tracking.pending_request(), None);
    assert!(!tracking.needs_map());
    assert_eq!(tracking.map().keyframe_count(), 1);
}

#[test]
fn a_frame_with_too_little_depth_does_not_start_a_map() {
    let (mut tracking, _) = halves();
    let out = tracking
        .process(Scene::new(60, 0).features(0, &truth(0)))
        .expect("features");
    assert!(out.keyframe.is_none());
    assert_eq!(out.pose.status, TrackingStatus::Predicted);
    assert_eq!(tracking.state(), TrackingState::NoMap { reset: false });
}

#[test]
fn frames_are_tracked_and_their_sightings_travel_with_the_next_request() {
    let (mut tracking, mut mapping) = halves();
    let scene = Scene::new(200, 20);
    let mut requests = Vec::new();
    // Past max_frames (30): at least one keyframe after the first.
    for k in 0..32 {
        let (pose, request) = step(&mut tracking, &mut mapping, &scene, k);
        assert!(pose.status.is_tracked(), "frame {k}: {}", pose.status);
        let error = pose.world_from_camera * truth(k);
        assert!(error.translation.vector.norm() < 1e-3, "frame {k}: {error}");
        requests.extend(request);
    }
    assert!(requests.len() >= 2, "{} keyframes", requests.len());
    let later = &requests[1];
    assert!(
        !later.sightings.is_empty(),
        "the tracker saw the map's points"
    );
    assert!(mapping.map().keyframe_count() >= 2);
}

#[test]
fn a_request_sent_again_is_applied_once() {
    let (mut tracking, mut mapping) = halves();
    let scene = Scene::new(200, 20);
    let request = tracking
        .process(scene.features(0, &truth(0)))
        .expect("features")
        .keyframe
        .expect("first keyframe");
    let first = mapping.insert(request.clone());
    let again = mapping.insert(request);
    assert_eq!((again.seq, again.keyframe), (first.seq, first.keyframe));
    assert_eq!(mapping.map().keyframe_count(), 1);
    assert!(tracking.apply(first));
    assert!(!tracking.apply(again), "the same answer twice");
}

#[test]
fn a_long_outage_starts_a_new_map_that_resets_the_mappers_and_the_axes() {
    let (mut tracking, mut mapping) = halves();
    let scene = Scene::new(200, 20);
    let mut first = scene.features(0, &truth(0));
    first.manhattan = Some(gfs_planes::ManhattanAxes {
        rotation: nalgebra::Rotation3::identity(),
        observed: [true, true, false],
        support: [0.5, 0.4, 0.0],
        confidence: 0.9,
    });
    let out = tracking.process(first).expect("features");
    assert!(tracking.apply(mapping.insert(out.keyframe.expect("first keyframe"))));
    assert!(tracking.manhattan().axes().is_some());
    let frames_before_new_map = OdometryConfig::default().tracking.frames_before_new_map;
    let blind = |k: u64| crate::frontend::features::FrameFeatures {
        id: gfs_core::ids::FrameId(k),
        timestamp: crate::testing::frame_stamp(k),
        ..Default::default()
    };
    for k in 1..frames_before_new_map {
        let out = tracking.process(blind(u64::from(k))).expect("features");
        assert_eq!(out.pose.status, TrackingStatus::Predicted);
        assert_eq!(tracking.state(), TrackingState::Lost { frames: k });
    }
    tracking
        .process(blind(u64::from(frames_before_new_map)))
        .expect("features");
    assert_eq!(tracking.state(), TrackingState::NoMap { reset: true });
    assert_eq!(tracking.map().keyframe_count(), 0);
    assert!(
        tracking.manhattan().axes().is_none(),
        "the old map's axes, off by the outage's drift"
    );
    let k = u64::from(frames_before_new_map) + 1;
    let (pose, request) = step(&mut tracking, &mut mapping, &scene, k);
    let request = request.expect("a new first keyframe");
    assert!(request.reset && pose.status.is_tracked());
    assert_eq!(
        mapping.map().keyframe_count(),
        1,
        "the old keyframe was dropped"
    );
}

#[test]
fn a_restored_tracker_goes_on_as_the_one_it_replaces() {
    let (mut tracking, mut mapping) = halves();
    let scene = Scene::new(200, 20);
    for k in 0..5 {
        step(&mut tracking, &mut mapping, &scene, k);
    }
    let checkpoint = tracking.checkpoint();
    let config = bincode::config::standard();
    let bytes = bincode::serde::encode_to_vec(&checkpoint, config).expect("encode");
    let (checkpoint, _): (TrackingCheckpoint, usize) =
        bincode::serde::decode_from_slice(&bytes, config).expect("decode");
    let (mut restored, _) = halves();
    restored.restore(checkpoint, Some(mapping.update()));
    assert_eq!(restored.state(), tracking.state());
    for k in 5..8 {
        let a = tracking
            .process(scene.features(k, &truth(k)))
            .expect("features");
        let b = restored
            .process(scene.features(k, &truth(k)))
            .expect("features");
        assert_eq!(a.pose, b.pose, "frame {k}");
        assert_eq!(a.keyframe.is_some(), b.keyframe.is_some());
        if let (Some(ra), Some(rb)) = (a.keyframe, b.keyframe) {
            assert_eq!(
                (ra.seq, ra.sightings.clone()),
                (rb.seq, rb.sightings.clone())
            );
            let update = mapping.insert(ra);
            assert!(tracking.apply(update.clone()) && restored.apply(update));
        }
    }
}

#[test]
fn a_tracker_restored_without_a_map_starts_a_new_one() {
    let (mut tracking, mut mapping) = halves();
    let scene = Scene::new(200, 20);
    step(&mut tracking, &mut mapping, &scene, 0);
    let (mut restored, _) = halves();
    restored.restore(tracking.checkpoint(), None);
    assert_eq!(restored.state(), TrackingState::NoMap { reset: false });
}

#[test]
fn a_local_ba_stopped_at_once_still_makes_the_keyframe() {
    let (mut tracking, mut full) = halves();
    let (_, mut stopped) = halves();
    let scene = Scene::new(200, 20);
    let mut second = None;
    for k in 0..60 {
        let out = tracking
            .process(scene.features(k, &truth(k)))
            .expect("consistent features");
        match out.keyframe {
            Some(request) if request.seq == 1 => {
                stopped.insert(request.clone());
                assert!(tracking.apply(full.insert(request)));
            }
            Some(request) => {
                second = Some(request);
                break;
            }
            None => {}
        }
    }
    let request = second.expect("a second keyframe request within 60 frames");
    let asked = std::cell::Cell::new(0);
    let update = stopped.insert_until(request.clone(), &|| {
        asked.set(asked.get() + 1);
        true
    });
    let reference = full.insert(request);
    assert!(asked.get() >= 1, "the BA asked whether to stop");
    assert_eq!(
        (update.seq, update.keyframe),
        (reference.seq, reference.keyframe)
    );
    assert_eq!(stopped.map().keyframe_count(), 2);
    assert_eq!(stopped.map().point_count(), full.map().point_count());
}

#[test]
fn a_request_tracked_before_a_correction_goes_into_the_map_corrected() {
    let (mut tracking, mut mapping) = halves();
    let scene = Scene::new(200, 20);
    let mut k = 0;
    while mapping.map().keyframe_count() < 2 {
        assert!(k < 60, "a second keyframe");
        step(&mut tracking, &mut mapping, &scene, k);
        k += 1;
    }
    // A loop correction the tracker has not seen yet (realtime): every keyframe 5 cm along x.
    let shift = nalgebra::Isometry3::translation(0.05, 0.0, 0.0);
    let map = mapping.map();
    let ids = map.keyframe_ids();
    let correction = crate::loop_closing::LoopCorrection {
        current: ids[ids.len() - 1],
        candidate: ids[0],
        inliers: 100,
        by_appearance: true,
        poses: ids
            .iter()
            .filter_map(|id| Some((*id, shift * map.keyframe(*id)?.world_from_camera())))
            .collect(),
        matches: Vec::new(),
        map_corrections: map.corrections(),
    };
    assert!(mapping.apply(&correction));
    let request = loop {
        assert!(k < 120, "a keyframe request");
        let out = tracking
            .process(scene.features(k, &truth(k)))
            .expect("features");
        k += 1;
        if let Some(request) = out.keyframe {
            break request;
        }
    };
    let tracked = request.frame.camera_from_world.inverse();
    let update = mapping.insert(request);
    let kf = update.keyframe.expect("a keyframe");
    let inserted = update
        .map
        .keyframe(kf)
        .expect("in the map")
        .world_from_camera();
    let expected = shift * tracked;
    assert!((inserted.translation.vector - expected.translation.vector).norm() < 1e-9);
    assert!(tracking.apply(update));
    let taken = tracking.map_from_odom().translation.vector - shift.translation.vector;
    assert!(taken.norm() < 1e-9, "map_from_odom off by {taken}");
    // The published odometry goes on where it was: the truth, uncorrected.
    let (next, _) = step(&mut tracking, &mut mapping, &scene, k);
    let error = (next.world_from_camera * truth(k))
        .translation
        .vector
        .norm();
    assert!(error < 1e-4, "odometry off by {error} m");
}

#[test]
fn a_lost_frame_is_found_through_the_mapping_half_when_the_trackers_map_lacks_its_place() {
    let (mut tracking, mut mapping) = halves();
    let scene = Scene::new(200, 20);
    for k in 0..6 {
        step(&mut tracking, &mut mapping, &scene, k);
    }
    // A tracker that holds none of that place (as one given only a neighbourhood of a
    // global map elsewhere): restarted with an empty map.
    let (mut restored, _) = halves();
    let mut elsewhere = mapping.update().to_owned();
    elsewhere.map = crate::map::Map::default();
    restored.restore(tracking.checkpoint(), Some(elsewhere));
    // Moved while blind: 30 cm and 12 degrees on, seeing the mapped place.
    let moved = pose(0.35, 12f64.to_radians());
    let out = restored
        .process(scene.features(20, &moved))
        .expect("features");
    assert_eq!(out.pose.status, TrackingStatus::Predicted);
    assert_eq!(restored.state(), TrackingState::Lost { frames: 1 });
    assert!(out.keyframe.is_none());
    let request = out.relocalisation.expect("the mapping half is asked");
    assert_eq!(
        restored.pending_request(),
        Some((request.seq, gfs_core::ids::FrameId(20)))
    );
    let update = mapping.relocalise(&request);
    let found = update.relocalised.clone().expect("found in the whole map");
    assert_eq!(update.check(), Ok(()));
    assert!(restored.apply(update));
    let pose_20 = restored.take_relocalised().expect("the frame's pose");
    assert_eq!(
        (pose_20.id, pose_20.status),
        (gfs_core::ids::FrameId(20), TrackingStatus::Relocalised)
    );
    // Found: the map pose is the truth; the jump from the prediction went into
    // map -> odom, and the published odometry is the prediction it had (REP 105).
    let error = (restored.map_from_odom() * pose_20.world_from_camera) * moved;
    assert!(error.translation.vector.norm() < 0.01, "{error}");
    assert!(error.rotation.angle().to_degrees() < 0.5, "{error}");
    let odom_jump = pose_20.world_from_camera.inverse() * out.pose.world_from_camera;
    assert!(odom_jump.translation.vector.norm() < 1e-9, "{odom_jump}");
    let in_map = restored.map_from_odom() * pose_20.world_from_camera;
    let jumped = (in_map.inverse() * out.pose.world_from_camera)
        .translation
        .vector
        .norm();
    assert!(
        jumped > 0.2,
        "the map pose moved {jumped} m from the prediction"
    );
    assert_eq!(restored.state(), TrackingState::Tracking);
    assert_eq!(restored.reference(), Some(found.keyframe));
    assert!(restored.take_relocalised().is_none(), "taken once");
    // The request sent again (a restarted tracker), to this mapping half or to one
    // restarted from the map it sent: the same answer, nothing new.
    let again = mapping.relocalise(&request);
    assert_eq!(again.relocalised.as_ref(), Some(&found));
    let (_, mut restarted) = halves();
    restarted.restore(mapping.checkpoint().to_owned());
    let from_restarted = restarted.relocalise(&request);
    assert_eq!(
        (from_restarted.seq, from_restarted.relocalised),
        (request.seq, Some(found))
    );
    assert!(!restored.apply(again));
    // Tracking goes on from the relocalised frame.
    let next = pose(0.36, 12.2f64.to_radians());
    let out = restored
        .process(scene.features(21, &next))
        .expect("features");
    assert_eq!(out.pose.status, TrackingStatus::Tracked);
    let error = (restored.map_from_odom() * out.pose.world_from_camera) * next;
    assert!(error.translation.vector.norm() < 1e-3, "{error}");
}

#[test]
fn the_tracker_gets_a_bounded_neighbourhood_while_the_global_map_grows() {
    let mut config = OdometryConfig::default();
    config.mapping.tracker_keyframes = 3;
    config.keyframes.max_frames = 4;
    // Nothing redundant: every keyframe stays in the global map.
    config.keyframes.redundant_observers = 1000;
    let mut tracking =
        TrackingSession::new(config.clone(), camera(), 1.2, 8, &GridConfig::default());
    let mut mapping = MappingSession::new(&config, camera(), 1.2, 8);
    let scene = Scene::new(200, 20);
    let mut largest = 0;
    for k in 0..60 {
        let out = tracking
            .process(scene.features(k, &truth(k)))
            .expect("consistent features");
        assert!(out.pose.status.is_tracked(), "frame {k}");
        if let Some(request) = out.keyframe {
            let update = mapping.insert(request);
            let kf = update.keyframe.expect("the new keyframe");
            assert!(update.map.keyframe(kf).is_some(), "{kf:?} not sent");
            assert!(update.recent_points.is_empty());
            largest = largest.max(update.map.keyframe_count());
            assert!(tracking.apply(update));
        }
    }
    let global = mapping.map().keyframe_count();
    println!("global map {global} keyframes, tracker's map at most {largest}");
    assert!(global >= 10, "{global} keyframes");
    assert_eq!(largest, 3);
    assert!(tracking.map().keyframe_count() <= 3);
    // The whole map is the checkpoint; a neighbourhood can be centred anywhere.
    assert_eq!(mapping.checkpoint().map.keyframe_count(), global);
    let first = mapping.map().keyframe_ids()[0];
    let around_first = mapping.update_around(first);
    assert!(around_first.map.keyframe(first).is_some());
    assert!(around_first.map.keyframe_count() <= 3);
}

#[test]
fn a_frame_found_again_around_its_reference_keeps_the_odometry_continuous() {
    let (mut tracking, mut mapping) = halves();
    let scene = Scene::new(200, 20);
    let mut last = None;
    for k in 0..6 {
        last = Some(step(&mut tracking, &mut mapping, &scene, k).0);
    }
    let last = last.expect("frame 5").world_from_camera;
    // Moved while blind, 30 cm and 12 degrees on, still seeing the mapped place: the
    // tracker's strategies miss it, its relocalisation around the reference finds it.
    let moved = pose(0.35, 12f64.to_radians());
    let out = tracking
        .process(scene.features(20, &moved))
        .expect("features");
    assert_eq!(out.pose.status, TrackingStatus::Relocalised);
    let in_map = tracking.map_from_odom() * out.pose.world_from_camera;
    let error = in_map * moved;
    assert!(error.translation.vector.norm() < 0.01, "{error}");
    // The published odometry goes on from frame 5 by the prediction (at most four
    // steps of 1 cm), the jump is in map -> odom.
    let odom_step = (last.inverse() * out.pose.world_from_camera)
        .translation
        .vector
        .norm();
    assert!(odom_step < 0.045, "the odometry moved {odom_step} m");
    let jumped = (in_map.inverse() * out.pose.world_from_camera)
        .translation
        .vector
        .norm();
    assert!(jumped > 0.2, "the map pose moved {jumped} m");
}
