//! Malformed, truncated and well-formed but inconsistent variable-size messages reaching a running stage are dropped
//! with a log line; the stage goes on and answers the next valid message. Drives the
//! mapper stage as a thread over iceoryx2 local services.

use gfs_core::ids::FrameId;
use gfs_core::stamp::Stamp;
use gfs_ipc::{
    IpcRun, MAX_VARIABLE_MESSAGE_BYTES, Mode, MsgHeader, RunId, Stage, TopicPublisher,
    TopicSubscriber, encode_message, local, topics,
};
use gfs_odometry::session::{KeyFrameRequest, MapRequest, MapUpdate};
use gfs_odometry::{FrameFeatures, TrackedFrame, TrackingStatus, WorldManhattan};
use gfs_pipeline::Config;
use gfs_pipeline::stages::{StageContext, StageSettings, run_stage};
use gfs_points::KeyPoint;
use nalgebra::Isometry3;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// A first keyframe: 200 keypoints with depth on a grid, distinct descriptors.
fn request() -> KeyFrameRequest {
    let keypoints: Vec<KeyPoint> = (0..200)
        .map(|i| KeyPoint {
            u: 40.0 + (i % 20) as f32 * 28.0,
            v: 40.0 + (i / 20) as f32 * 40.0,
            level: 0,
            angle: 0.0,
            response: 50.0,
            depth: 1.0 + (i % 7) as f32 * 0.3,
        })
        .collect();
    let descriptors = (0..200u64)
        .map(|i| [i.wrapping_mul(0x9E37_79B9_7F4A_7C15), !i, i << 7, i])
        .collect();
    let n = keypoints.len();
    KeyFrameRequest {
        seq: 1,
        frame: TrackedFrame {
            features: FrameFeatures {
                id: FrameId(0),
                timestamp: Stamp::from_nanos(1_000_000_000),
                keypoints,
                point_descriptors: descriptors,
                ..FrameFeatures::default()
            },
            camera_from_world: Isometry3::identity(),
            status: TrackingStatus::Tracked,
            point_ids: vec![None; n],
            line_ids: Vec::new(),
            plane_ids: Vec::new(),
            inliers: Default::default(),
        },
        manhattan: WorldManhattan::new(true),
        reset: false,
        sightings: Default::default(),
        tracked_against: None,
    }
}

#[test]
fn the_mapper_drops_bad_keyframe_messages_and_answers_the_next_good_one() {
    let run_id = RunId::unique("mal").unwrap();
    let settings = StageSettings {
        config: Config::built_in("synthetic").unwrap(),
        mode: Mode::Lockstep,
        state_dir: None,
        dataset: "unused".into(),
        start: 0,
        frames: None,
        max_rate: None,
        map_files: Default::default(),
    };
    let stop = Arc::new(AtomicBool::new(false));
    let mapper = {
        let (run_id, stop) = (run_id.clone(), Arc::clone(&stop));
        std::thread::spawn(move || {
            let run = IpcRun::new(run_id).unwrap();
            let ctx =
                StageContext::<local::Service>::thread(run, Stage::Mapper, settings, stop).unwrap();
            run_stage(Stage::Mapper, &ctx).map_err(|e| e.to_string())
        })
    };
    let run = IpcRun::new(run_id).unwrap();
    let node = run.node::<local::Service>("test").unwrap();
    let qos = topics::KEYFRAME.qos(Mode::Lockstep);
    let publisher = TopicPublisher::<local::Service, u8>::create(
        &run,
        &node,
        topics::KEYFRAME.name,
        &qos,
        1024,
    )
    .unwrap();
    let maps = TopicSubscriber::<local::Service, u8>::create(
        &run,
        &node,
        topics::LOCAL_MAP.name,
        &topics::LOCAL_MAP.qos(Mode::Lockstep),
    )
    .unwrap();
    let mut valid = Vec::new();
    encode_message(&MapRequest::KeyFrame(request()), &mut valid).unwrap();
    let header = MsgHeader::new(FrameId(0), Stamp::from_nanos(1_000_000_000));
    // Garbage until the mapper is subscribed (a message before that reaches no one).
    let deadline = Instant::now() + Duration::from_secs(20);
    while publisher.publish_slice(&header, &[0xFF; 3]).unwrap() == 0 {
        assert!(Instant::now() < deadline, "the mapper never subscribed");
        std::thread::sleep(Duration::from_millis(5));
    }
    publisher
        .publish_slice(&header, &valid[..valid.len() / 2])
        .unwrap();
    let mut trailing = valid.clone();
    trailing.push(0);
    publisher.publish_slice(&header, &trailing).unwrap();
    publisher.publish_slice(&header, &[]).unwrap();
    // Well-formed but inconsistent: one landmark link fewer than keypoints (this
    // indexed out of bounds in the mapper before requests were checked).
    let mut short = request();
    short.frame.point_ids.pop();
    let mut inconsistent = Vec::new();
    encode_message(&MapRequest::KeyFrame(short), &mut inconsistent).unwrap();
    publisher.publish_slice(&header, &inconsistent).unwrap();
    publisher.publish_slice(&header, &valid).unwrap();

    let mut answers = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(30);
    while answers.is_empty() && Instant::now() < deadline {
        if let Some((_, update)) = maps
            .receive_decoded::<MapUpdate>(MAX_VARIABLE_MESSAGE_BYTES)
            .unwrap()
        {
            answers.push(update);
        }
        let _ = maps.wait(Duration::from_millis(10));
    }
    assert!(!mapper.is_finished(), "the mapper is still running");
    stop.store(true, Ordering::Relaxed);
    assert_eq!(mapper.join().unwrap(), Ok(()));
    assert_eq!(answers.len(), 1, "one answer, to the valid request");
    let update = &answers[0];
    assert_eq!((update.seq, update.map.keyframe_count()), (1, 1));
    assert!(
        update.map.point_count() >= 100,
        "{}",
        update.map.point_count()
    );
}
