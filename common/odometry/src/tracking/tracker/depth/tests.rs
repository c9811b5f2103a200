use crate::config::TrackingConfig;
use crate::depth::grid::DepthGrid;
use crate::frontend::features::FrameFeatures;
use crate::map::Map;
use crate::testing::{CORNER, camera, planes_depth, scale, textured_planes_depth, unlinked};
use crate::tracking::sightings::Sightings;
use crate::tracking::status::TrackingStatus;
use crate::tracking::tracker::{TrackedFrame, Tracker};
use gfs_core::ids::FrameId;
use gfs_lines::grid::GridConfig;
use nalgebra::{Isometry3, Vector6};

fn tracker() -> Tracker {
    let config = TrackingConfig {
        use_depth_alignment: true,
        ..TrackingConfig::default()
    };
    Tracker::new(config, camera(), scale(), &GridConfig::default())
}

fn frame(k: u64, camera_from_world: &Isometry3<f64>, planes: &[([f64; 3], f64)]) -> FrameFeatures {
    FrameFeatures {
        id: FrameId(k),
        timestamp: crate::testing::frame_stamp(k),
        depth: planes_depth(&camera(), camera_from_world, planes),
        ..FrameFeatures::default()
    }
}

#[test]
fn three_planes_alone_are_tracked_frame_after_frame() {
    // No point, no line: a floor and two walls, the camera moving 1 cm and 0.6
    // degrees per frame about a tilted axis.
    let mut tracker = tracker();
    let map = Map::default();
    let step = gfs_core::se3::exp(&Vector6::new(0.01, -0.004, 0.006, 0.004, 0.008, -0.005));
    let mut truth = Isometry3::identity();
    let mut first = TrackedFrame::untracked(frame(0, &truth, &CORNER), truth);
    first.status = TrackingStatus::Tracked;
    tracker.finish_frame(first);
    let mut sightings = Sightings::default();
    for k in 1..8 {
        truth = step * truth;
        let tracked = tracker.track(&map, frame(k, &truth, &CORNER), &mut sightings);
        let error = tracked.camera_from_world * truth.inverse();
        assert_eq!(tracked.status, TrackingStatus::Tracked, "frame {k}");
        assert!(error.translation.vector.norm() < 1e-3, "frame {k}: {error}");
        assert!(error.rotation.angle() < 0.1f64.to_radians(), "frame {k}");
        tracker.finish_frame(tracked);
    }
}

/// A wall ahead (z = 3) and the floor (y = 1): their geometry leaves the
/// translation along their edge (x) free.
const WALL_AND_FLOOR: [([f64; 3], f64); 2] = [([0.0, 1.0, 0.0], 1.0), ([0.0, 0.0, 1.0], 3.0)];

/// Paint of +-2 % over a metre plus a lamp's smooth shading, gray levels.
fn faint_paint(p: &nalgebra::Vector3<f64>) -> f64 {
    170.0 + 3.0 * (2.3 * p.x + 0.9 * p.z).sin() + 2.5 * (1.7 * p.x - 2.1 * p.y).cos()
        - 4.0 * (p.x - 0.5).powi(2)
}

/// Tracks 10 frames of the wall and the floor moving 1 cm a frame along their edge
/// (and turning 0.2 degrees a frame), on geometry alone, the exposure drifting; the
/// largest translation error, and whether every frame was `Tracked`.
fn track_along_the_edge(photometric_sigma: f64) -> (f64, bool) {
    let mut config = TrackingConfig {
        use_depth_alignment: true,
        ..TrackingConfig::default()
    };
    config.depth.photometric_sigma = photometric_sigma;
    let mut tracker = Tracker::new(config, camera(), scale(), &GridConfig::default());
    let step = gfs_core::se3::exp(&Vector6::new(-0.01, 0.0, 0.0, 0.0, 0.0035, 0.0));
    // The exposure drifts by up to 3 % a frame.
    let (worst, tracked) = track_steps(&mut tracker, &step, 10, |k, pose| {
        let mut depth = textured_planes_depth(&camera(), pose, &WALL_AND_FLOOR, faint_paint, k);
        let gain = 1.0 + 0.03 * (k as f32).sin();
        (depth.intensity.iter_mut())
            .chain(depth.coarse_intensity.iter_mut())
            .for_each(|v| *v *= gain);
        depth
    });
    (worst, tracked == 10)
}

/// Tracks `frames` frames on geometry alone, each `step` on from the last, `depth`
/// making a frame's depth grid from its index and true pose; frame 0 is taken as
/// tracked at the truth. The largest translation error and the frames `Tracked`.
fn track_steps(
    tracker: &mut Tracker,
    step: &Isometry3<f64>,
    frames: u64,
    depth: impl Fn(u64, &Isometry3<f64>) -> DepthGrid,
) -> (f64, usize) {
    let map = Map::default();
    let features = |k: u64, pose: &Isometry3<f64>| FrameFeatures {
        id: FrameId(k),
        timestamp: crate::testing::frame_stamp(k),
        depth: depth(k, pose),
        ..FrameFeatures::default()
    };
    let mut truth = Isometry3::identity();
    let mut first = TrackedFrame::untracked(features(0, &truth), truth);
    first.status = TrackingStatus::Tracked;
    tracker.finish_frame(first);
    let (mut worst, mut tracked_frames) = (0.0f64, 0);
    for k in 1..=frames {
        truth = step * truth;
        let tracked = tracker.track(&map, features(k, &truth), &mut Sightings::default());
        let error = tracked.camera_from_world.inverse().translation.vector
            - truth.inverse().translation.vector;
        worst = worst.max(error.norm());
        tracked_frames += usize::from(tracked.status == TrackingStatus::Tracked);
        tracker.finish_frame(tracked);
    }
    (worst, tracked_frames)
}

#[test]
fn the_photometric_term_fixes_what_a_wall_and_the_floor_leave_free() {
    let (with, tracked) = track_along_the_edge(1.0);

    assert!(
        tracked && with < 0.002,
        "with the photometric term: {with} m"
    );
    // Geometry alone holds the pose to the prediction along the edge.
    let (without, tracked) = track_along_the_edge(0.0);
    assert!(!tracked && without > 0.01, "depth alone: {without} m");
}

/// Tracks 12 frames of a bare wall 2 m ahead sliding 4 mm a frame along it and
/// turning 0.1 degrees about its normal, on geometry alone. Its painted cells are
/// replaced by a flat gray with their noise (they fix nothing along the wall);
/// the coarse level keeps the paint when `coarse_paint`, else is flat too. The
/// largest translation error and the frames `Tracked`.
fn track_a_wall_on_its_coarse_paint(coarse_paint: bool) -> (f64, usize) {
    const WALL: [([f64; 3], f64); 1] = [([0.0, 0.0, 1.0], 2.0)];
    let paint = |p: &nalgebra::Vector3<f64>| 150.0 + (12.0 * p.x).sin() + (10.0 * p.y + 1.0).cos();
    let flat = |_: &nalgebra::Vector3<f64>| 150.0;
    let step = gfs_core::se3::exp(&Vector6::new(-0.004, 0.002, 0.0, 0.0, 0.0, 0.0017));
    track_steps(&mut tracker(), &step, 12, |k, pose| {
        let mut depth = textured_planes_depth(&camera(), pose, &WALL, flat, k);
        if coarse_paint {
            depth.coarse_intensity =
                textured_planes_depth(&camera(), pose, &WALL, paint, k).coarse_intensity;
        }
        depth
    })
}

#[test]
fn a_wall_whose_cells_fix_nothing_is_tracked_on_its_coarse_paint() {
    let (error, tracked) = track_a_wall_on_its_coarse_paint(true);
    assert!(
        tracked == 12 && error < 0.002,
        "{tracked} tracked, {error} m"
    );
    // Flat on both levels the wall leaves its slide and turn to the prediction.
    let (error, tracked) = track_a_wall_on_its_coarse_paint(false);
    assert!(tracked == 0 && error > 0.01, "{tracked} tracked, {error} m");
}

/// A tracker aligning depth with the newest keyframe's, without a motion prior
/// (its centre would come from a drifted last frame too).
fn keyframe_reference_tracker() -> Tracker {
    let mut config = TrackingConfig {
        use_depth_alignment: true,
        ..TrackingConfig::default()
    };
    config.depth.keyframe_reference = true;
    config.depth.motion_prior_accel_m_s2 = 0.0;
    Tracker::new(config, camera(), scale(), &GridConfig::default())
}

/// The corner seen by frames 0-2, beside an older keyframe that shares nothing with
/// them. A keyframe is requested of frame 0; frame 1 is tracked and left 5 mm off.
/// The map holds frame 0's keyframe before frame 1 (which is tracked against it,
/// and then the points' reference moves back to the older keyframe), or only
/// before frame 2 (realtime: the mapper answered late). Returns frame 2's
/// translation error, metres: 5 mm if it is aligned with frame 1's depth.
fn third_frame_error(keyframe_before_second: bool) -> f64 {
    let mut tracker = keyframe_reference_tracker();
    let mut map = Map::default();
    let step = gfs_core::se3::exp(&Vector6::new(0.01, -0.004, 0.006, 0.004, 0.008, -0.005));
    let start = Isometry3::identity();
    let unrelated = FrameFeatures {
        id: FrameId(1000),
        ..FrameFeatures::default()
    };
    let older = map.insert_keyframe(unlinked(unrelated, step.inverse()));
    let mut first = TrackedFrame::untracked(frame(0, &start, &CORNER), start);
    first.status = TrackingStatus::Tracked;
    tracker.keep_requested_keyframe_depth(&first);
    tracker.finish_frame(first);
    let insert_first =
        |map: &mut Map| map.insert_keyframe(unlinked(frame(0, &start, &CORNER), start));
    if keyframe_before_second {
        tracker.set_reference(insert_first(&mut map));
    } else {
        tracker.set_reference(older);
    }
    let mut sightings = Sightings::default();
    let mut truth = step * start;
    let mut second = tracker.track(&map, frame(1, &truth, &CORNER), &mut sightings);
    assert_eq!(second.status, TrackingStatus::Tracked);
    second.camera_from_world = Isometry3::translation(0.005, 0.0, 0.0) * truth;
    tracker.finish_frame(second);

    if keyframe_before_second {
        tracker.set_reference(older);
    } else {
        tracker.set_reference(insert_first(&mut map));
    }
    truth = step * truth;
    let third = tracker.track(&map, frame(2, &truth, &CORNER), &mut sightings);
    assert_eq!(third.status, TrackingStatus::Tracked);
    (third.camera_from_world * truth.inverse())
        .translation
        .vector
        .norm()
}

#[test]
fn the_depth_reference_stays_the_held_keyframe_when_the_points_reference_moves_on() {
    let error = third_frame_error(true);
    assert!(error < 5e-4, "{error} m");
}

#[test]
fn a_keyframe_that_reaches_the_tracker_after_the_next_frame_is_its_depth_reference() {
    let error = third_frame_error(false);
    assert!(error < 5e-4, "{error} m");
}

#[test]
fn two_parallel_walls_leave_the_corridor_axis_free() {
    // A corridor's two walls (x = -1, x = 1) leave its axis free: the frame is
    // `degraded`, its covariance a metre along the axis and millimetres across it.
    let walls = [([1.0, 0.0, 0.0], -1.0), ([1.0, 0.0, 0.0], 1.0)];
    let mut tracker = tracker();
    let map = Map::default();
    let start = Isometry3::identity();
    let mut first = TrackedFrame::untracked(frame(0, &start, &walls), start);
    first.status = TrackingStatus::Tracked;
    tracker.finish_frame(first);
    // Two steps along the corridor: the second has a velocity, whose prior holds the
    // axis.
    for k in 1..=2 {
        let moved = Isometry3::translation(0.0, 0.0, -0.02 * k as f64);
        let tracked = tracker.track(&map, frame(k, &moved, &walls), &mut Sightings::default());
        assert_eq!(tracked.status, TrackingStatus::Degraded, "frame {k}");
        // Across the walls the frame is where it is.
        let error = (tracked.camera_from_world * moved.inverse()).translation.x;
        assert!(error.abs() < 1e-3, "frame {k}: {error} m");
        if k == 2 {
            let c = tracker
                .pose_covariance(&tracked, None)
                .expect("a covariance");
            assert!(c[(2, 2)].sqrt() > 0.5, "{c}");
            assert!(c[(0, 0)].sqrt() < 0.005, "{c}");
        }
        tracker.finish_frame(tracked);
    }
}

/// Walks a bare corner (a floor, a wall ahead and a cabinet's side: `CORNER`, no point
/// or line) 1 cm a frame for four frames, then jumps 0.15 m and 7 degrees, which the
/// motion model does not know, and walks on. The jump frame's status and its camera
/// centre's and rotation's errors, metres and degrees, with the coarse registration's
/// gates `registration`.
fn jump_in_a_bare_corner(registration: Vec<f64>) -> (TrackingStatus, f64, f64) {
    let mut config = TrackingConfig::default();
    config.depth.registration_distance_m = registration;
    let mut tracker = Tracker::new(config, camera(), scale(), &GridConfig::default());
    let map = Map::default();
    let walk = gfs_core::se3::exp(&Vector6::new(0.01, 0.0, 0.0, 0.0, 0.0, 0.0));
    let axis = nalgebra::Vector3::new(0.3, 1.0, 0.2).normalize();
    let turn = axis * 7f64.to_radians();
    let jump = gfs_core::se3::exp(&Vector6::new(0.12, 0.03, -0.085, turn.x, turn.y, turn.z));
    assert!((jump.translation.vector.norm() - 0.15).abs() < 1e-3);
    let mut truth = Isometry3::identity();
    let mut first = TrackedFrame::untracked(frame(0, &truth, &CORNER), truth);
    first.status = TrackingStatus::Tracked;
    tracker.finish_frame(first);
    let mut at_jump = None;
    for k in 1..8 {
        truth = if k == 5 { jump * truth } else { walk * truth };
        let tracked = tracker.track(&map, frame(k, &truth, &CORNER), &mut Sightings::default());
        if k == 5 {
            let centre = tracked.camera_from_world.inverse().translation.vector
                - truth.inverse().translation.vector;
            let turn = (tracked.camera_from_world * truth.inverse())
                .rotation
                .angle();
            at_jump = Some((tracked.status, centre.norm(), turn.to_degrees()));
        }
        tracker.finish_frame(tracked);
    }
    at_jump.expect("frame 5 tracked")
}

#[test]
fn a_jump_in_a_bare_corner_is_registered_coarse_to_fine() {
    let (status, metres, degrees) = jump_in_a_bare_corner(vec![0.4, 0.3, 0.2, 0.12]);
    assert_eq!(status, TrackingStatus::Tracked);
    assert!(metres < 0.01 && degrees < 0.5, "{metres} m, {degrees} deg");
    // Without the coarse registration the frame is not tracked where it is.
    let (status, metres, degrees) = jump_in_a_bare_corner(Vec::new());
    assert!(
        status != TrackingStatus::Tracked || metres > 0.01 || degrees > 0.5,
        "{status:?}, {metres} m, {degrees} deg"
    );
}
