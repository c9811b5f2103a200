//! Loop closure end to end (slow: renders two laps of the synthetic room, 721 frames,
//! and runs the in-process odometry twice on them, with and without loop closing).
//!
//! Covers: a loop is found when the camera comes back to where it started and none
//! without loop closing; the final trajectory (each frame with the loop corrections of
//! its reference keyframe) has at most half the ATE of the run without loop closing;
//! the published odometry stays continuous: around each correction no frame-to-frame
//! step exceeds the true step by more than one frame's mean motion, while the map pose
//! jumps by the correction; elsewhere its steps are as noisy as without loop closing.
//! The global map outlives the tracker's neighbourhood: back at the start, the
//! tracker's map and its local map hold keyframes of the first frames, and the second
//! lap leaves fewer keyframes in the map than the first (its landmarks are matched
//! again).

mod common;

use common::in_process::InProcess;
use gfs_core::stamp::Stamp;
use gfs_dataset::{EVO_MAX_DIFF_S, Trajectory, evaluate};
use gfs_odometry::{FinalTrajectory, FramePose, OdometryConfig};
use gfs_synth::{SynthConfig, SynthSequence, TrajectoryKind};
use nalgebra::Isometry3;

/// Two laps and back at the start (a lap is 360 frames).
const FRAMES: usize = 721;
const LAP: usize = 360;
/// The frames whose keyframes the tracker must hold again back at the start.
const FIRST_FRAMES: usize = 30;

/// One odometry with its front end and what it published.
struct Run {
    vo: InProcess,
    finals: FinalTrajectory,
    published: Vec<FramePose>,
    map_poses: Vec<Isometry3<f64>>,
    /// Frames after which a loop correction was taken in.
    corrected_after: Vec<usize>,
}

impl Run {
    fn new(sequence: &SynthSequence, config: OdometryConfig) -> Self {
        Self {
            vo: InProcess::new(sequence.config().camera, config),
            finals: FinalTrajectory::with_capacity(FRAMES),
            published: Vec::with_capacity(FRAMES),
            map_poses: Vec::with_capacity(FRAMES),
            corrected_after: Vec::new(),
        }
    }

    fn step(&mut self, i: usize, frame: &gfs_synth::SynthFrame) {
        let before = *self.vo.odometry.map_from_odom();
        let pose = self.vo.process(i, frame);
        if before != *self.vo.odometry.map_from_odom() {
            self.corrected_after.push(i);
        }
        self.finals.record(
            self.vo.odometry.anchor(&pose),
            self.vo.odometry.map_from_odom() * pose.world_from_camera,
        );
        self.map_poses
            .push(self.vo.odometry.map_from_odom() * pose.world_from_camera);
        self.published.push(pose);
    }
}

fn ate(truth: &Trajectory, poses: impl Iterator<Item = (Stamp, Isometry3<f64>)>) -> f64 {
    let mut estimate = Trajectory::new();
    for (t, pose) in poses {
        estimate.push(t, pose);
    }
    let evaluation = evaluate(truth, &estimate, EVO_MAX_DIFF_S).unwrap();
    assert_eq!(evaluation.matched(), FRAMES);
    evaluation.ate.stats.rmse
}

/// The excess of each frame-to-frame translation of `poses` over the true one (entry
/// `k`: from frame `k` to `k + 1`).
fn step_excess(poses: &[Isometry3<f64>], truth: &[Isometry3<f64>]) -> Vec<f64> {
    let step = |a: &Isometry3<f64>, b: &Isometry3<f64>| (a.inverse() * b).translation.vector.norm();
    poses
        .windows(2)
        .zip(truth.windows(2))
        .map(|(p, t)| step(&p[0], &p[1]) - step(&t[0], &t[1]))
        .collect()
}

/// The largest of `excess` over the steps around frame `k` (into it, out of it, and
/// the next).
fn around(excess: &[f64], k: usize) -> f64 {
    excess[k.saturating_sub(1)..(k + 2).min(excess.len())]
        .iter()
        .copied()
        .fold(f64::MIN, f64::max)
}

#[test]
fn two_laps_of_the_room_close_a_loop_halve_the_ate_and_keep_the_odometry_continuous() {
    let sequence = SynthSequence::new(SynthConfig {
        trajectory: TrajectoryKind::Loop,
        frames: FRAMES,
        ..SynthConfig::default()
    });
    let mut off_config = OdometryConfig::default();
    off_config.loop_closing.enabled = false;
    let mut on = Run::new(&sequence, OdometryConfig::default());
    let mut off = Run::new(&sequence, off_config);
    let mut truth = Trajectory::new();
    let mut true_poses = Vec::with_capacity(FRAMES);
    let (mut first_keyframes, mut after_lap) = (Vec::new(), 0);
    for i in 0..FRAMES {
        let frame = sequence.render(i);
        on.step(i, &frame);
        off.step(i, &frame);
        truth.push(frame.timestamp, frame.pose);
        true_poses.push(frame.pose);
        match i {
            FIRST_FRAMES => first_keyframes = on.vo.odometry.map().keyframe_ids(),
            LAP => after_lap = on.vo.odometry.map().keyframe_count(),
            _ => {}
        }
    }
    let tracking = on.vo.odometry.tracking();
    let old_in = |ids: &[gfs_core::ids::KeyFrameId]| {
        ids.iter().filter(|k| first_keyframes.contains(k)).count()
    };
    let at_end = on.vo.odometry.map().keyframe_count();
    println!(
        "keyframes: {} made in the first {FIRST_FRAMES} frames, {after_lap} in the map after          one lap, {at_end} after two; back at the start the tracker's map holds {}          keyframes ({} of the first), its local map {:?}",
        first_keyframes.len(),
        tracking.map().keyframe_count(),
        old_in(&tracking.map().keyframe_ids()),
        tracking.local_keyframes(),
    );
    assert!(old_in(&tracking.map().keyframe_ids()) >= 1);
    assert!(old_in(tracking.local_keyframes()) >= 1);
    assert!(tracking.map().keyframe_count() <= OdometryConfig::default().mapping.tracker_keyframes);
    // The first lap maps the room (34 keyframes); the second, matching the first lap's
    // landmarks again once the loop is closed, leaves 18 more in the map.
    assert!(
        at_end - after_lap <= 2 * after_lap / 3,
        "{after_lap} keyframes after one lap, {at_end} after two"
    );
    let loops = on.vo.odometry.loops();
    assert!(!loops.is_empty(), "no loop closed");
    assert!(off.vo.odometry.loops().is_empty());
    let finals = on.finals.finish(on.vo.odometry.map(), &on.published);
    let ate_on = ate(
        &truth,
        finals.iter().map(|p| (p.timestamp, p.world_from_camera)),
    );
    let ate_off = ate(
        &truth,
        off.published
            .iter()
            .map(|p| (p.timestamp, p.world_from_camera)),
    );
    let poses =
        |run: &Run| -> Vec<_> { run.published.iter().map(|p| p.world_from_camera).collect() };
    let mean_step = TrajectoryKind::Loop.mean_speeds().0 / 30.0;
    let odometry = step_excess(&poses(&on), &true_poses);
    let map = step_excess(&on.map_poses, &true_poses);
    let without = step_excess(&poses(&off), &true_poses);
    let largest = |e: &[f64]| e.iter().copied().fold(f64::MIN, f64::max);
    println!(
        "loops {loops:?}, taken in after frames {:?}\nATE {ate_on:.4} m with loop closing, \
         {ate_off:.4} m without; largest step excess: odometry {:.4} m, map pose {:.4} m, \
         without loop closing {:.4} m (one frame's mean motion {mean_step:.4} m)",
        on.corrected_after,
        largest(&odometry),
        largest(&map),
        largest(&without),
    );
    assert!(ate_on <= 0.5 * ate_off, "{ate_on} against {ate_off}");
    assert_eq!(on.corrected_after.len(), loops.len());
    for &k in &on.corrected_after {
        let (odometry_jump, map_jump) = (around(&odometry, k), around(&map, k));
        println!(
            "after frame {k}: odometry step excess {odometry_jump:.4} m, map pose {map_jump:.4} m"
        );
        assert!(
            odometry_jump <= mean_step,
            "odometry jumps {odometry_jump} m at frame {k}"
        );
    }
    assert!(largest(&odometry) <= largest(&without) + mean_step);
}
