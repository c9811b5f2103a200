//! Property test of the message checks: thousands of random keyframe requests and
//! feature sets, each either consistent or broken in one random way that still encodes
//! and decodes (a vector one entry short or long, a NaN or infinity in a field, an
//! impossible request number). Every one goes through bincode like a real message; the
//! check must refuse exactly the broken ones, and the mapper must take every one it
//! accepts without panicking. Generated with the project's SplitMix64 (fixed seed).

use gfs_core::ids::{FrameId, MapLineId, MapPointId};
use gfs_core::rng::SplitMix64;
use gfs_core::stamp::Stamp;
use gfs_ipc::{MAX_VARIABLE_MESSAGE_BYTES, decode_message, encode_message};
use gfs_lines::{DetectedLine, Line3, Segment};
use gfs_odometry::Sightings;
use gfs_odometry::session::{KeyFrameRequest, MapUpdate, MappingSession};
use gfs_odometry::{FrameFeatures, OdometryConfig, TrackedFrame, TrackingStatus, WorldManhattan};
use gfs_points::KeyPoint;
use nalgebra::{Isometry3, Translation3, UnitQuaternion};

const CASES: usize = 3000;

/// The ways a message is broken (0: it is not).
const BREAKS: u64 = 12;

fn features(rng: &mut SplitMix64, id: u64) -> FrameFeatures {
    let points = rng.below(60) as usize;
    let lines = rng.below(12) as usize;
    let descriptor = |rng: &mut SplitMix64| [0; 4].map(|_: u64| rng.next_u64());
    FrameFeatures {
        id: FrameId(id),
        timestamp: Stamp::from_nanos(id as i64 * 33_333_333),
        keypoints: (0..points)
            .map(|_| KeyPoint {
                u: rng.range(0.0, 640.0) as f32,
                v: rng.range(0.0, 480.0) as f32,
                level: rng.below(8) as u32,
                angle: rng.range(-3.1, 3.1) as f32,
                response: rng.range(0.0, 100.0) as f32,
                depth: if rng.below(4) == 0 {
                    0.0
                } else {
                    rng.range(0.3, 6.0) as f32
                },
            })
            .collect(),
        point_descriptors: (0..points).map(|_| descriptor(rng)).collect(),
        lines: (0..lines)
            .map(|_| DetectedLine {
                segment: Segment {
                    start: [rng.range(0.0, 640.0) as f32, rng.range(0.0, 480.0) as f32],
                    end: [rng.range(0.0, 640.0) as f32, rng.range(0.0, 480.0) as f32],
                },
                mean_gradient: rng.range(10.0, 200.0) as f32,
            })
            .collect(),
        line_descriptors: (0..lines).map(|_| descriptor(rng)).collect(),
        lines3d: (0..lines)
            .map(|_| Line3 {
                start: [0.0, 0.0, 1.0].map(|c: f32| c + rng.range(-1.0, 1.0) as f32),
                end: [0.0, 0.0, 2.0].map(|c: f32| c + rng.range(-1.0, 1.0) as f32),
                valid: rng.below(2) as u32,
            })
            .collect(),
        manhattan: None,
        planes: Vec::new(),
        depth: Default::default(),
    }
}

fn request(rng: &mut SplitMix64, seq: u64) -> KeyFrameRequest {
    let features = features(rng, seq);
    let link = |rng: &mut SplitMix64| (rng.below(3) == 0).then(|| rng.below(500));
    let point_ids = (0..features.keypoints.len())
        .map(|_| link(rng).map(MapPointId))
        .collect();
    let line_ids = (0..features.lines.len())
        .map(|_| link(rng).map(MapLineId))
        .collect();
    let pose = Isometry3::from_parts(
        Translation3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), 0.0),
        UnitQuaternion::from_euler_angles(0.1 * rng.gaussian(), 0.1 * rng.gaussian(), 0.0),
    );
    KeyFrameRequest {
        seq,
        frame: TrackedFrame {
            features,
            camera_from_world: pose,
            status: TrackingStatus::Tracked,
            point_ids,
            line_ids,
            plane_ids: Vec::new(),
            inliers: Default::default(),
        },
        manhattan: WorldManhattan::new(true),
        reset: false,
        sightings: sightings(rng),
        tracked_against: None,
    }
}

/// Breaks `r` in way `how` (1..BREAKS); false when `r` has nothing that way can break.
fn break_request(r: &mut KeyFrameRequest, how: u64, rng: &mut SplitMix64) -> bool {
    let f = &mut r.frame;
    let pick = |rng: &mut SplitMix64, n: usize| rng.below(n as u64) as usize;
    match how {
        1 => {
            f.point_ids.push(None);
            true
        }
        2 => f.point_ids.pop().is_some(),
        3 => {
            f.line_ids.push(Some(MapLineId(1)));
            true
        }
        4 => f.features.point_descriptors.pop().is_some(),
        5 => {
            f.features.lines3d.push(Line3::default());
            true
        }
        6 => {
            let n = f.features.keypoints.len();
            n > 0 && {
                f.features.keypoints[pick(rng, n)].u = f32::NAN;
                true
            }
        }
        7 => {
            let n = f.features.keypoints.len();
            n > 0 && {
                f.features.keypoints[pick(rng, n)].depth = f32::INFINITY;
                true
            }
        }
        8 => {
            f.camera_from_world.translation.vector.x = f64::NAN;
            true
        }
        9 => {
            r.seq = 0;
            true
        }
        10 => {
            let n = f.features.keypoints.len();
            n > 0 && {
                f.features.keypoints[pick(rng, n)].depth = -1.0;
                true
            }
        }
        _ => {
            let n = f.features.lines.len();
            n > 0 && {
                f.features.lines[pick(rng, n)].segment.end[1] = f32::NEG_INFINITY;
                true
            }
        }
    }
}

/// Up to four points and four lines, each predicted in view up to 9 times and found at
/// most as often.
fn sightings(rng: &mut SplitMix64) -> Sightings {
    let mut sightings = Sightings::default();
    for i in 0..rng.below(5) {
        let visible = rng.below(10);
        for _ in 0..visible {
            sightings.points_visible(&[MapPointId(i)]);
        }
        for _ in 0..rng.below(visible + 1) {
            sightings.points_found([&MapPointId(i)]);
        }
    }
    for i in 0..rng.below(5) {
        let visible = rng.below(10);
        for _ in 0..visible {
            sightings.lines_visible(&[MapLineId(i)]);
        }
        for _ in 0..rng.below(visible + 1) {
            sightings.lines_found([&MapLineId(i)]);
        }
    }
    sightings
}

fn round_trip<T: serde::Serialize + serde::de::DeserializeOwned>(value: &T) -> T {
    let mut bytes = Vec::new();
    encode_message(value, &mut bytes).unwrap();
    decode_message(&bytes, MAX_VARIABLE_MESSAGE_BYTES).expect("well-formed messages decode")
}

#[test]
fn checks_refuse_exactly_the_inconsistent_messages_and_the_mapper_takes_the_rest() {
    let mut rng = SplitMix64::new(14);
    let mut config = OdometryConfig::default();
    config.mapping.local_ba = false;
    let camera = gfs_core::camera::PinholeCamera::new(500.0, 500.0, 320.0, 240.0, 640, 480);
    let mut mapper = MappingSession::new(&config, camera, 1.2, 8);
    let (mut accepted, mut refused, mut seq) = (0, 0, 0);
    for case in 0..CASES {
        seq += 1;
        let mut r = request(&mut rng, seq);
        let how = if rng.below(2) == 0 {
            0
        } else {
            1 + rng.below(BREAKS - 1)
        };
        let broken = how > 0 && break_request(&mut r, how, &mut rng);
        let decoded: KeyFrameRequest = round_trip(&r);
        let verdict = decoded.check();
        assert_eq!(
            verdict.is_err(),
            broken,
            "case {case}, break {how}: {verdict:?}"
        );
        if let Err(e) = verdict {
            assert!(e.to_string().contains(&format!("frame {seq}")), "{e}");
            refused += 1;
            continue;
        }
        // What the check lets through must not hurt the mapper, and its answer must
        // pass the tracker's check.
        let update: MapUpdate = round_trip(&mapper.insert(decoded));
        assert_eq!(update.check(), Ok(()), "case {case}");
        accepted += 1;
    }
    println!("{accepted} requests accepted, {refused} refused");
    assert!(accepted > CASES / 4 && refused > CASES / 4);
}

#[test]
fn feature_checks_refuse_exactly_the_inconsistent_feature_sets() {
    let mut rng = SplitMix64::new(41);
    for case in 0..CASES as u64 {
        let mut r = request(&mut rng, case + 1);
        // Breaks 1..=3, 8..=10 are about the request, not the features.
        let how = [0, 4, 5, 6, 7, 11][rng.below(6) as usize];
        let broken = how > 0 && break_request(&mut r, how, &mut rng);
        let decoded: FrameFeatures = round_trip(&r.frame.features);
        assert_eq!(decoded.check().is_err(), broken, "case {case}, break {how}");
    }
}
