//! Same-process publish/subscribe through `ipc::Service` and `local::Service`, each
//! test in its own run (unique prefix and root), checked for leftovers at the end.

use std::time::Duration;

use gfs_core::ids::FrameId;
use gfs_core::stamp::Stamp;
use gfs_core::{Image, ImageView};
use gfs_ipc::{
    FrameImages, FrameLayout, IpcRun, Mode, MsgHeader, RunId, Stage, StageStamp, TopicKind,
    TopicPublisher, TopicQos, TopicSubscriber, frame_view, frame_view_mut,
};
use gfs_ipc::{Service, ZeroCopySend, ipc, local};
use serde::{Deserialize, Serialize};

/// FNV-1a over bytes: a payload checksum that any flipped or shifted byte changes.
fn fnv1a(bytes: impl IntoIterator<Item = u8>) -> u64 {
    bytes.into_iter().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

fn view_checksum<T: Copy>(v: &ImageView<'_, T>, bytes: impl Fn(T) -> Vec<u8>) -> u64 {
    fnv1a((0..v.height()).flat_map(|y| v.row(y).iter().flat_map(|&p| bytes(p)).collect::<Vec<_>>()))
}

struct Fixture {
    gray: Image<u8>,
    depth: Image<f32>,
    rgb: Image<[u8; 3]>,
}

/// A `w x h` frame whose pixels all differ from frame to frame (`k`).
fn fixture(w: usize, h: usize, k: usize) -> Fixture {
    let mut f = Fixture {
        gray: Image::new(w, h),
        depth: Image::new(w, h),
        rgb: Image::new(w, h),
    };
    for y in 0..h {
        for x in 0..w {
            let i = x * 7 + y * 13 + k * 31;
            f.gray.set(x, y, (i % 251) as u8);
            f.depth.set(
                x,
                y,
                if i.is_multiple_of(17) {
                    0.0
                } else {
                    0.5 + (i % 1000) as f32 * 0.004
                },
            );
            f.rgb.set(
                x,
                y,
                [(i % 256) as u8, (i / 3 % 256) as u8, (i / 7 % 256) as u8],
            );
        }
    }
    f
}

fn stamped_header(k: u64) -> MsgHeader {
    let mut h = MsgHeader::new(
        FrameId(k),
        Stamp::from_nanos(1_305_031_102_175_000_000 + k as i64 * 33_333_333),
    );
    *h.stamp_mut(Stage::Source) = StageStamp {
        received_ns: 1_000 + k,
        started_ns: 2_000 + k,
        finished_ns: 3_000 + k,
    };
    h.mark_received(Stage::Points);
    h
}

fn assert_no_leftovers(run: &IpcRun) {
    let left = run.finish();
    assert!(
        left.is_empty(),
        "files of run {} left: {left:?}",
        run.run_id()
    );
}

fn frame_round_trip<S: Service>(tag: &str) {
    let run = IpcRun::new(RunId::unique(tag).unwrap()).unwrap();
    {
        let src = run.node::<S>("source").unwrap();
        let pts = run.node::<S>("points").unwrap();
        let qos = TopicQos::new(Mode::Lockstep, TopicKind::Frame);
        let (w, h) = (97, 61); // odd sizes exercise row tails and plane padding
        let layout = FrameLayout::new(w, h, true).unwrap();
        let publisher =
            TopicPublisher::<S, u8>::create(&run, &src, "frame", &qos, layout.byte_len()).unwrap();
        let subscriber = TopicSubscriber::<S, u8>::create(&run, &pts, "frame", &qos).unwrap();
        for k in 0..3usize {
            let f = fixture(w, h, k);
            // Frame 1 comes from strided views, to check the row-wise copy.
            let padded = Image::from_vec(w + 3, h, {
                let mut v = vec![0u8; (w + 3) * h];
                for y in 0..h {
                    v[y * (w + 3)..y * (w + 3) + w].copy_from_slice(f.gray.row(y));
                }
                v
            })
            .unwrap();
            let gray = if k == 1 {
                ImageView::new(w, h, w + 3, padded.as_slice()).unwrap()
            } else {
                f.gray.view()
            };
            let images = FrameImages {
                gray,
                depth: f.depth.view(),
                rgb: Some(f.rgb.view()),
            };
            let reached = publisher
                .publish_frame(&stamped_header(k as u64), &images)
                .unwrap();
            assert_eq!(reached, 1);

            let sample = subscriber.receive().unwrap().expect("frame queued");
            assert_eq!(*sample.user_header(), {
                let mut e = stamped_header(k as u64);
                e.stamps[Stage::Points.index()] = sample.user_header().stamp(Stage::Points);
                e
            });
            assert!(sample.user_header().stamp(Stage::Points).received_ns > 0);
            assert_eq!(
                sample.user_header().stamp(Stage::Source).finished_ns,
                3_000 + k as u64
            );
            let frame = frame_view(&sample).unwrap();
            let rgb = frame.rgb().expect("rgb plane");
            assert_eq!((frame.gray().width(), frame.gray().height()), (w, h));
            let gray_sum = |v: &ImageView<'_, u8>| view_checksum(v, |p| vec![p]);
            let depth_sum = |v: &ImageView<'_, f32>| view_checksum(v, |p| p.to_ne_bytes().to_vec());
            let rgb_sum = |v: &ImageView<'_, [u8; 3]>| view_checksum(v, |p| p.to_vec());
            assert_eq!(
                gray_sum(&frame.gray()),
                gray_sum(&f.gray.view()),
                "gray, frame {k}"
            );
            assert_eq!(
                depth_sum(&frame.depth()),
                depth_sum(&f.depth.view()),
                "depth, frame {k}"
            );
            assert_eq!(rgb_sum(&rgb), rgb_sum(&f.rgb.view()), "rgb, frame {k}");
            // Zero copy: the views point into the sample's shared memory.
            let payload = sample.payload().as_ptr_range();
            assert!(payload.contains(&frame.gray().as_slice().as_ptr()));
            assert!(payload.contains(&(frame.depth().as_slice().as_ptr() as *const u8)));
        }
        assert!(subscriber.receive().unwrap().is_none());

        // In-place path: the producer writes straight into the loaned sample.
        let f = fixture(w, h, 9);
        let mut sample = publisher.loan_frame(&stamped_header(9), &layout).unwrap();
        {
            let planes = frame_view_mut(&mut sample, &layout).unwrap();
            planes.gray.copy_from_slice(f.gray.as_slice());
            planes.depth.copy_from_slice(f.depth.as_slice());
            planes.rgb.unwrap().copy_from_slice(f.rgb.as_slice());
        }
        publisher.send(sample).unwrap();
        let sample = subscriber
            .receive()
            .unwrap()
            .expect("in-place frame queued");
        let frame = frame_view(&sample).unwrap();
        assert_eq!(frame.depth().to_image(), f.depth);
        assert_eq!(frame.rgb().unwrap().to_image(), f.rgb);
        assert_eq!(sample.user_header().frame(), FrameId(9));
    }
    assert_no_leftovers(&run);
}

#[test]
fn frame_round_trip_between_nodes_over_ipc() {
    frame_round_trip::<ipc::Service>("frame-ipc");
}

#[test]
fn frame_round_trip_between_nodes_over_local() {
    frame_round_trip::<local::Service>("frame-local");
}

/// A feature record as a stage would publish it.
#[derive(Clone, Copy, Debug, Default, PartialEq, ZeroCopySend)]
#[type_name("gfsvo::test::Keypoint")]
#[repr(C)]
struct Keypoint {
    u: f32,
    v: f32,
    depth: f32,
    octave: u32,
    descriptor: [u8; 32],
}

#[test]
fn feature_slices_round_trip_and_history_reaches_late_subscribers() {
    let run = IpcRun::new(RunId::unique("features").unwrap()).unwrap();
    {
        let node = run.node::<ipc::Service>("points").unwrap();
        let qos = TopicQos::new(Mode::Lockstep, TopicKind::Features);
        let publisher =
            TopicPublisher::<ipc::Service, Keypoint>::create(&run, &node, "points", &qos, 1000)
                .unwrap();
        let early =
            TopicSubscriber::<ipc::Service, Keypoint>::create(&run, &node, "points", &qos).unwrap();
        let kps = |k: u32, n: usize| -> Vec<Keypoint> {
            (0..n)
                .map(|i| Keypoint {
                    u: i as f32 + 0.25,
                    v: k as f32,
                    depth: 1.5,
                    octave: k,
                    descriptor: [(i % 256) as u8; 32],
                })
                .collect()
        };
        // Nothing sent yet: the wait ends by its (short) timeout.
        assert!(!early.wait(Duration::from_millis(1)).unwrap());
        // Frame 2 is longer than the initial slice length: the segment grows.
        for (k, n) in [(0u32, 500usize), (1, 0), (2, 3000)] {
            publisher
                .publish_slice(&stamped_header(u64::from(k)), &kps(k, n))
                .unwrap();
        }
        // The sends woke the subscriber: this returns at once (the bound is a safety net).
        assert!(early.wait(Duration::from_secs(10)).unwrap());
        for (k, n) in [(0u32, 500usize), (1, 0), (2, 3000)] {
            let s = early.receive().unwrap().expect("features queued");
            assert_eq!(s.user_header().frame_id, u64::from(k));
            assert_eq!(s.payload(), kps(k, n).as_slice());
        }
        // A restarted stage gets the last `history` (2) messages once the publisher
        // updates its connections.
        let late =
            TopicSubscriber::<ipc::Service, Keypoint>::create(&run, &node, "points", &qos).unwrap();
        assert!(late.receive().unwrap().is_none());
        publisher.update_connections().unwrap();
        let ids: Vec<u64> = std::iter::from_fn(|| late.receive().unwrap())
            .map(|s| s.user_header().frame_id)
            .collect();
        assert_eq!(ids, vec![1, 2]);
    }
    assert_no_leftovers(&run);
}

#[derive(Debug, PartialEq, Serialize, Deserialize)]
struct KeyFrameMsg {
    kf_id: u64,
    pose: [f64; 7],
    point_ids: Vec<u64>,
}

#[test]
fn malformed_variable_messages_are_dropped_not_fatal() {
    let run = IpcRun::new(RunId::unique("variable").unwrap()).unwrap();
    {
        let node = run.node::<local::Service>("mapper").unwrap();
        let qos = TopicQos::new(Mode::Lockstep, TopicKind::Variable);
        let publisher =
            TopicPublisher::<local::Service, u8>::create(&run, &node, "keyframe", &qos, 256)
                .unwrap();
        let subscriber =
            TopicSubscriber::<local::Service, u8>::create(&run, &node, "keyframe", &qos).unwrap();
        let msg = |kf_id: u64, n: u64| KeyFrameMsg {
            kf_id,
            pose: [0.0, 0.0, 0.0, 1.0, 0.1, 0.2, 0.3],
            point_ids: (0..n).collect(),
        };
        let mut scratch = Vec::new();
        let mut good = Vec::new();
        gfs_ipc::encode_message(&msg(1, 10), &mut good).unwrap();
        let header = stamped_header(4);
        let max = 4096;
        // garbage, valid; then truncated, oversized, valid-with-trailing-byte, valid
        // (each batch within the subscriber's queue of 4)
        publisher.publish_slice(&header, &[0xFF; 40]).unwrap();
        publisher
            .publish_encoded(&header, &msg(1, 10), &mut scratch)
            .unwrap();
        let (h1, m1) = subscriber
            .receive_decoded::<KeyFrameMsg>(max)
            .unwrap()
            .unwrap();
        assert_eq!((h1.frame_id, m1), (4, msg(1, 10)));
        publisher
            .publish_slice(&header, &good[..good.len() - 5])
            .unwrap();
        publisher.publish_slice(&header, &vec![0u8; 5000]).unwrap();
        let mut trailing = good.clone();
        trailing.push(0);
        publisher.publish_slice(&header, &trailing).unwrap();
        publisher
            .publish_encoded(&header, &msg(2, 300), &mut scratch)
            .unwrap();
        let (_, m2) = subscriber
            .receive_decoded::<KeyFrameMsg>(max)
            .unwrap()
            .unwrap();
        assert_eq!(m2, msg(2, 300));
        assert!(
            subscriber
                .receive_decoded::<KeyFrameMsg>(max)
                .unwrap()
                .is_none()
        );
    }
    assert_no_leftovers(&run);
}

#[test]
fn runs_do_not_see_each_other() {
    let a = IpcRun::new(RunId::unique("iso-a").unwrap()).unwrap();
    let b = IpcRun::new(RunId::unique("iso-b").unwrap()).unwrap();
    {
        let qos = TopicQos::new(Mode::Realtime, TopicKind::Features);
        let na = a.node::<ipc::Service>("source").unwrap();
        let nb = b.node::<ipc::Service>("source").unwrap();
        let pa = TopicPublisher::<ipc::Service, u64>::create(&a, &na, "pose", &qos, 4).unwrap();
        let sb = TopicSubscriber::<ipc::Service, u64>::create(&b, &nb, "pose", &qos).unwrap();
        pa.publish_slice(&MsgHeader::default(), &[1, 2, 3]).unwrap();
        assert!(sb.receive().unwrap().is_none());
        let names: Vec<String> = a
            .nodes::<ipc::Service>()
            .unwrap()
            .into_iter()
            .map(|n| n.name)
            .collect();
        assert_eq!(names, vec!["source".to_string()]);
        assert!(!a.leftovers().is_empty(), "a live run has files");
    }
    assert_no_leftovers(&a);
    assert_no_leftovers(&b);
}

#[test]
fn local_services_connect_threads_of_one_process() {
    // `threads` mode: each stage thread owns its node and ports (ports are not `Send`).
    // The publishing thread stays alive until its messages are read: samples a subscriber
    // has not connected to yet vanish with their publisher.
    let run = IpcRun::new(RunId::unique("threads").unwrap()).unwrap();
    {
        let qos = TopicQos::new(Mode::Lockstep, TopicKind::Features);
        let node = run.node::<local::Service>("tracker").unwrap();
        let poses =
            TopicSubscriber::<local::Service, f64>::create(&run, &node, "pose", &qos).unwrap();
        let (done_tx, done_rx) = std::sync::mpsc::channel::<()>();
        let stage = {
            let run = run.clone();
            std::thread::spawn(move || {
                let node = run.node::<local::Service>("source").unwrap();
                let publisher =
                    TopicPublisher::<local::Service, f64>::create(&run, &node, "pose", &qos, 7)
                        .unwrap();
                for k in 0..3u32 {
                    let pose = [f64::from(k), 0.0, 0.0, 0.0, 0.0, 0.0, 1.0];
                    publisher
                        .publish_slice(&stamped_header(u64::from(k)), &pose)
                        .unwrap();
                }
                // Bounded: the main thread answers at once or has failed.
                let _ = done_rx.recv_timeout(Duration::from_secs(30));
            })
        };
        let mut got = Vec::new();
        while got.len() < 3 {
            // Bounded: a lost message fails the test instead of hanging it.
            assert!(
                poses.wait(Duration::from_secs(10)).unwrap(),
                "no pose after 10 s"
            );
            while let Some(s) = poses.receive().unwrap() {
                got.push((s.user_header().frame_id, s.payload()[0]));
            }
        }
        done_tx.send(()).unwrap();
        stage.join().unwrap();
        assert_eq!(got, vec![(0, 0.0), (1, 1.0), (2, 2.0)]);
    }
    assert_no_leftovers(&run);
}
