//! A 100-frame box-room sequence of a smoothly rotating and moving camera: the Manhattan
//! axes keep their identity and sign in every frame (no swap, no flip), and stay within
//! 1 deg of the room's axes.

mod common;

use common::{BoxRoom, Rng, add_kinect_noise, angle_deg, pose, true_axes};
use gfs_core::camera::PinholeCamera;
use gfs_planes::{ManhattanAxes, ManhattanEstimator, PlaneConfig, PlaneExtractor};
use nalgebra::{Isometry3, Matrix3, Rotation3, Vector3};

const FRAMES: usize = 100;

/// Camera `k` of `n`: yaw sweeps 180 deg about the room's vertical (y) axis while
/// pitch and roll wobble and the camera circles the centre, `speed` times faster than
/// the base trajectory (1.8 deg of yaw per frame at speed 1).
fn trajectory(k: usize, speed: f64) -> Isometry3<f64> {
    let s = speed * k as f64 / (FRAMES - 1) as f64;
    let tau = std::f64::consts::TAU;
    let yaw = (-40.0 + 180.0 * s).to_radians();
    let pitch = (-15.0 + 25.0 * (tau * s).sin()).to_radians();
    let roll = (8.0 * (1.5 * tau * s).sin()).to_radians();
    let r = Rotation3::from_axis_angle(&Vector3::y_axis(), yaw)
        * Rotation3::from_axis_angle(&Vector3::x_axis(), pitch)
        * Rotation3::from_axis_angle(&Vector3::z_axis(), roll);
    let p = Vector3::new(
        0.8 * (tau * s).sin(),
        0.3 * (2.0 * tau * s).sin(),
        0.8 * (tau * s).cos() - 0.4,
    );
    pose(p, r)
}

/// The signed permutation `P` with `estimated ~ truth * P` (rounded entries).
fn labelling(truth: &Matrix3<f64>, estimated: &Matrix3<f64>) -> Matrix3<f64> {
    (truth.transpose() * estimated).map(f64::round)
}

/// What one estimator did along a sequence.
#[derive(Default)]
struct Run {
    /// Frames with MA.
    with_ma: usize,
    /// Worst angle between a known estimated axis and its labelled true axis (deg),
    /// signed: a sign flip or a swap shows as ~180 or ~90 deg.
    worst_deg: f64,
    /// Frames with a known axis more than 45 deg from its labelled true axis.
    swaps_or_flips: usize,
    /// The first frame's signed permutation from the true to the estimated axes.
    label: Option<Matrix3<f64>>,
}

impl Run {
    fn check(&mut self, k: usize, axes: &ManhattanAxes, world_from_camera: &Isometry3<f64>) {
        self.with_ma += 1;
        let truth = true_axes(world_from_camera);
        let p = *self.label.get_or_insert_with(|| {
            assert!(
                axes.observed_count() >= 2,
                "frame {k}: the first frame must fix all axes"
            );
            labelling(&truth, axes.rotation.matrix())
        });
        let expected = truth * p;
        let mut swapped = false;
        for i in (0..3).filter(|&i| axes.is_known(i)) {
            let e = angle_deg(&expected.column(i).into_owned(), &axes.axis(i), false);
            self.worst_deg = self.worst_deg.max(e);
            swapped |= e > 45.0;
        }
        self.swaps_or_flips += usize::from(swapped);
    }
}

/// Runs `frames` frames through one extractor and two estimators, one given the true
/// predicted rotation (as a tracker's motion model would) and one given none.
fn run(speed: f64, frames: usize, noisy: bool) -> (Run, Run) {
    // Half-resolution fr1 camera: the same field of view at a quarter of the rendering.
    let cam = PinholeCamera::new(258.65, 258.25, 159.3, 127.65, 320, 240);
    let room = BoxRoom::office();
    let config = PlaneConfig::default();
    let mut extractor = PlaneExtractor::new(&config).unwrap();
    let mut with_prediction = ManhattanEstimator::new(&config).unwrap();
    let mut without_prediction = ManhattanEstimator::new(&config).unwrap();
    let mut rng = Rng::new(11);
    let mut planes = Vec::new();
    let mut previous_pose: Option<Isometry3<f64>> = None;
    let (mut with, mut without) = (Run::default(), Run::default());
    for k in 0..frames {
        let world_from_camera = trajectory(k, speed);
        let (mut depth, _) = room.render(&cam, &world_from_camera);
        if noisy {
            add_kinect_noise(&mut depth, &mut rng, 0.1, 3);
        }
        extractor.extract(&depth.view(), &cam, &mut planes).unwrap();
        // current_from_previous = R_wc_k^T R_wc_{k-1}.
        let predicted = previous_pose.map(|prev| {
            (world_from_camera.rotation.inverse() * prev.rotation).to_rotation_matrix()
        });
        previous_pose = Some(world_from_camera);
        if let Some(axes) = with_prediction.estimate(&planes, &[], &[], predicted.as_ref()) {
            with.check(k, &axes, &world_from_camera);
        }
        if let Some(axes) = without_prediction.estimate(&planes, &[], &[], None) {
            without.check(k, &axes, &world_from_camera);
        }
    }
    (with, without)
}

#[test]
fn axes_keep_identity_and_sign_along_a_smooth_sequence() {
    for noisy in [false, true] {
        let (with, without) = run(1.0, FRAMES, noisy);
        for (name, r) in [("with", &with), ("without", &without)] {
            println!(
                "noisy {noisy}, {name} prediction: MA in {}/{FRAMES} frames, worst known-axis error {:.3} deg, {} swapped/flipped frames",
                r.with_ma, r.worst_deg, r.swaps_or_flips
            );
            assert_eq!(r.with_ma, FRAMES, "noisy {noisy}, {name}");
            assert_eq!(r.swaps_or_flips, 0, "noisy {noisy}, {name}");
            assert!(
                r.worst_deg <= 1.0,
                "noisy {noisy}, {name}: {:.3} deg",
                r.worst_deg
            );
        }
    }
}

/// 12 frames at 25x the speed (45 deg of yaw per frame): the predicted rotation keeps
/// the labels; without it, matching to the previous axes is ambiguous and fails.
#[test]
fn fast_rotation_keeps_labels_only_with_the_predicted_rotation() {
    let (with, without) = run(25.0, 12, true);
    println!(
        "45 deg/frame, noisy: with prediction {} swapped/flipped of {} MA frames (worst {:.3} deg); without {} of {}",
        with.swaps_or_flips, with.with_ma, with.worst_deg, without.swaps_or_flips, without.with_ma
    );
    assert_eq!(with.with_ma, 12);
    assert_eq!(with.swaps_or_flips, 0);
    assert!(with.worst_deg <= 1.0, "{:.3} deg", with.worst_deg);
    assert!(without.swaps_or_flips > 0);
}
