//! End-to-end accuracy of the in-process odometry on synthetic sequences with exact
//! ground truth: the front end extracts points, lines and planes from the rendered
//! frames, the odometry tracks them, and the ATE (SE(3)-aligned, as `gfsvo eval`) is
//! asserted, with the number of untracked frames.

mod common;

use common::in_process::InProcess;
use gfs_dataset::{EVO_MAX_DIFF_S, Trajectory, evaluate};
use gfs_odometry::{OdometryConfig, TrackingStatus};
use gfs_synth::{NoiseConfig, SceneKind, SynthConfig, SynthSequence, TrajectoryKind};

struct RunResult {
    ate_rmse_m: f64,
    predicted: usize,
    relocalised: usize,
    degraded: usize,
}

fn run(
    scene: SceneKind,
    trajectory: TrajectoryKind,
    frames: usize,
    noise: NoiseConfig,
    config: OdometryConfig,
) -> RunResult {
    run_seed(
        scene,
        trajectory,
        frames,
        noise,
        config,
        SynthConfig::default().seed,
    )
}

fn run_seed(
    scene: SceneKind,
    trajectory: TrajectoryKind,
    frames: usize,
    noise: NoiseConfig,
    config: OdometryConfig,
    seed: u64,
) -> RunResult {
    let sequence = SynthSequence::new(SynthConfig {
        scene,
        trajectory,
        frames,
        noise,
        seed,
        ..SynthConfig::default()
    });
    let mut vo = InProcess::new(sequence.config().camera, config);
    let (mut estimate, mut truth) = (Trajectory::new(), Trajectory::new());
    let (mut predicted, mut relocalised, mut degraded) = (0, 0, 0);
    for i in 0..sequence.len() {
        let frame = sequence.render(i);
        let pose = vo.process(i, &frame);
        predicted += usize::from(pose.status == TrackingStatus::Predicted);
        relocalised += usize::from(pose.status == TrackingStatus::Relocalised);
        degraded += usize::from(pose.status == TrackingStatus::Degraded);
        // The map pose: a relocalisation's jump goes into map -> odom.
        estimate.push(
            frame.timestamp,
            vo.odometry.map_from_odom() * pose.world_from_camera,
        );
        truth.push(frame.timestamp, frame.pose);
    }
    let evaluation = evaluate(&truth, &estimate, EVO_MAX_DIFF_S).unwrap();
    assert_eq!(evaluation.matched(), frames);
    let result = RunResult {
        ate_rmse_m: evaluation.ate.stats.rmse,
        predicted,
        relocalised,
        degraded,
    };
    println!(
        "{scene:?} {trajectory:?} seed {seed}: ATE {:.4} m, predicted {predicted}, relocalised {relocalised}, degraded {degraded}",
        result.ate_rmse_m
    );
    result
}

#[test]
fn textured_room_slow_noise_free_is_tracked_within_a_centimetre() {
    let r = run(
        SceneKind::Room,
        TrajectoryKind::Slow,
        120,
        NoiseConfig::none(),
        OdometryConfig::default(),
    );
    assert_eq!(r.predicted, 0, "no frame may be lost");
    assert!(r.ate_rmse_m <= 0.01, "ATE {} m", r.ate_rmse_m);
}

#[test]
fn textured_room_with_kinect_noise_is_tracked_within_a_centimetre() {
    let r = run(
        SceneKind::Room,
        TrajectoryKind::Slow,
        120,
        NoiseConfig::default(),
        OdometryConfig::default(),
    );
    assert_eq!(r.predicted + r.relocalised, 0, "no frame may be lost");
    assert!(r.ate_rmse_m <= 0.01, "ATE {} m", r.ate_rmse_m);
}

#[test]
fn fast_motion_is_tracked_within_a_centimetre() {
    let r = run(
        SceneKind::Room,
        TrajectoryKind::Fast,
        120,
        NoiseConfig::default(),
        OdometryConfig::default(),
    );
    assert_eq!(r.predicted, 0, "no frame may be lost");
    assert!(r.ate_rmse_m <= 0.01, "ATE {} m", r.ate_rmse_m);
}

#[test]
fn mostly_rotation_is_tracked_within_a_centimetre() {
    let r = run(
        SceneKind::Room,
        TrajectoryKind::Rotation,
        120,
        NoiseConfig::default(),
        OdometryConfig::default(),
    );
    assert_eq!(r.predicted, 0, "no frame may be lost");
    assert!(r.ate_rmse_m <= 0.01, "ATE {} m", r.ate_rmse_m);
}

#[test]
fn low_texture_room_stays_within_a_centimetre() {
    let r = run(
        SceneKind::LowTexture,
        TrajectoryKind::Slow,
        120,
        NoiseConfig::default(),
        OdometryConfig::default(),
    );
    assert!(r.ate_rmse_m <= 0.01, "ATE {} m", r.ate_rmse_m);
}

/// The default odometry with the depth alignment and the plane landmarks switched on,
/// aligned with the newest keyframe's depth: the renders' depth noise is independent
/// from frame to frame (as `configs/synthetic.toml` says for `gfsvo synth`'s).
fn with_depth_and_planes() -> OdometryConfig {
    let mut config = OdometryConfig::default();
    config.tracking.use_depth_alignment = true;
    config.tracking.use_planes = true;
    config.tracking.depth.keyframe_reference = true;
    config
}

/// The depth alignment set for a sensor whose depth and image noise are independent from
/// pixel to pixel and from frame to frame, as the idealised renders here have it: every
/// depth node aligned and sampled, each as 4 independent pixels, against the newest
/// keyframe's depth, the photometric samples at 0.4 gray levels (the record's
/// measurements on these renders; the defaults are for real sensors' correlated noise,
/// and `configs/synthetic.toml` no longer carries these keys), and no vignetting to
/// estimate: on these renders, which have none, the estimate took slow seed 29's bare
/// wall from 2.8 to 4.4 mm.
fn synthetic_sensor_with_depth() -> OdometryConfig {
    let mut config = gfs_pipeline::Config::built_in("synthetic")
        .expect("the built-in synthetic config parses")
        .odometry();
    config.tracking.use_depth_alignment = true;
    config.tracking.use_planes = false;
    let depth = &mut config.tracking.depth;
    depth.source_step = 1;
    depth.independent_pixels_per_node = 4.0;
    depth.photometric_sigma = 0.4;
    depth.keyframe_reference = true;
    depth.estimate_vignetting = false;
    config
}

/// The same with the planes too, as `tests/bench/low_texture.sh all` runs it.
fn synthetic_sensor_with_depth_and_planes() -> OdometryConfig {
    let mut config = synthetic_sensor_with_depth();
    config.tracking.use_planes = true;
    config
}

/// Every frame `tracked` and the ATE within 4 mm: the goal in rooms with few points.
fn assert_every_frame_tracked_within_4_mm(r: &RunResult) {
    assert_eq!(
        r.predicted + r.relocalised + r.degraded,
        0,
        "every frame tracked"
    );
    assert!(r.ate_rmse_m <= 0.004, "ATE {} m", r.ate_rmse_m);
}

#[test]
fn low_texture_room_with_depth_and_planes_is_tracked_within_4_mm() {
    let r = run(
        SceneKind::LowTexture,
        TrajectoryKind::Slow,
        120,
        NoiseConfig::default(),
        with_depth_and_planes(),
    );
    assert_every_frame_tracked_within_4_mm(&r);
}

/// Rotation seed 6 turns from a corner of the room to the next with no keypoint in
/// view: its first keyframe's depth pairs with fewer and fewer of the frame's nodes.
/// Without a keyframe made before that reference stops holding the pose, 38 frames
/// went `degraded`, 4 were lost and the ATE was 11 mm.
#[test]
fn low_texture_rotation_renews_its_depth_reference_and_is_tracked_within_4_mm() {
    let r = run_seed(
        SceneKind::LowTexture,
        TrajectoryKind::Rotation,
        120,
        NoiseConfig::default(),
        with_depth_and_planes(),
        6,
    );
    assert_every_frame_tracked_within_4_mm(&r);
}

/// Fast seed 2 sees 50-150 points and lines, most on walls 3-5 m away, and is tracked
/// on them and its depth. Its error grew with each frame's distance from the reference
/// keyframe, and a reference renewed only at a 6 mm worst direction kept it: 5.1 mm.
/// Renewed at 4 mm: 3.2 mm.
#[test]
fn low_texture_fast_far_points_renew_their_reference_in_time_and_stay_within_4_mm() {
    let r = run_seed(
        SceneKind::LowTexture,
        TrajectoryKind::Fast,
        120,
        NoiseConfig::default(),
        synthetic_sensor_with_depth_and_planes(),
        2,
    );
    assert_every_frame_tracked_within_4_mm(&r);
}

/// Slow seed 9 faces a bare wall for tens of frames (62-75 and 84-85 among them) with
/// no keypoint in view: its paint is coarser than the 4 px intensity cells, whose
/// gradients' noise hid it, and those 23 frames were `degraded` (3.1 mm). Tracked again
/// on the 8 px means of the cells where the cells leave a direction weak: every frame
/// `tracked`, 2.7 mm.
#[test]
fn low_texture_bare_wall_is_tracked_on_the_coarse_intensities_within_4_mm() {
    let r = run_seed(
        SceneKind::LowTexture,
        TrajectoryKind::Slow,
        120,
        NoiseConfig::default(),
        synthetic_sensor_with_depth_and_planes(),
        9,
    );
    assert_every_frame_tracked_within_4_mm(&r);
}

/// Images rendered without noise under the drifting exposure (slow seed 29, all terms,
/// the synthetic sensor's config): their 8-bit rounding is not dithered, and a change
/// of gain moves the rounding contours of its smooth walls, which the photometric term
/// took for motion: every frame `tracked`, 329 mm off (`gfsvo run` on the rendered
/// sequence: 413 mm, up to 36 mm frame to frame on a corner its depth held to a
/// millimetre). Read only where the contours hold, the corner is tracked on its depth
/// and the bare wall after it is reported: 12.7 mm, 33 frames `degraded`, 5 `predicted`
/// (a keyframe's intensities are not averaged over its frames' here: 20.4 mm, 36 and 4
/// when they were).
#[test]
fn images_without_noise_under_a_drifting_exposure_are_not_tracked_far_off() {
    let r = run_seed(
        SceneKind::LowTexture,
        TrajectoryKind::Slow,
        120,
        NoiseConfig {
            image_sigma: 0.0,
            ..NoiseConfig::default()
        },
        synthetic_sensor_with_depth_and_planes(),
        29,
    );
    assert!(r.ate_rmse_m < 0.025, "ATE {} m", r.ate_rmse_m);
    // The frames the images cannot hold say so.
    assert!(r.degraded + r.predicted > 0, "every frame tracked");
}

/// Slow seed 29 ends on a bare wall that only its faint paint holds, every frame tracked
/// against a keyframe whose image noise all of them read: their errors moved together,
/// and each new keyframe took its frame's (`average_reference_views = false`: 5.6 mm,
/// every frame tracked). With the keyframe's intensities averaged over the views of the
/// frames tracked against it: 2.8 mm.
#[test]
fn a_bare_wall_read_against_a_keyframe_averaged_over_its_views_is_tracked_within_4_mm() {
    let r = run_seed(
        SceneKind::LowTexture,
        TrajectoryKind::Slow,
        120,
        NoiseConfig::default(),
        synthetic_sensor_with_depth_and_planes(),
        29,
    );
    assert_every_frame_tracked_within_4_mm(&r);
}

/// Fast seed 21 passes a table against the wall 1 m behind it with little else in view.
/// Its corners are the table's outline, but the pixel under many of them read the wall:
/// mapped at the wall's depth they drew the pose 18 mm along the wall over the first 25
/// frames (5.7 mm with every frame tracked, depth alone). With a corner on an occlusion
/// edge read at the nearer surface's depth, and a T-junction read as a bearing: 1.7 mm.
#[test]
fn a_tables_corners_against_a_wall_are_read_at_the_tables_depth_and_tracked_within_4_mm() {
    let r = run_seed(
        SceneKind::LowTexture,
        TrajectoryKind::Fast,
        120,
        NoiseConfig::default(),
        synthetic_sensor_with_depth(),
        21,
    );
    assert_every_frame_tracked_within_4_mm(&r);
}
