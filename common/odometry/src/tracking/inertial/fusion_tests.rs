use super::*;
use gfs_core::rng::SplitMix64;
use gfs_core::stamp::Stamp;
use gfs_inertial::simulate::{Simulator, world_gravity};
use gfs_inertial::{Bias, ImuNoise};
use nalgebra::{Matrix3, UnitQuaternion};

/// A hand-held walk: 0.5 m/s along x with sway, turning slowly.
fn walk(t: f64) -> (Matrix3<f64>, Vector3<f64>) {
    let r = UnitQuaternion::from_euler_angles(
        0.2 * (1.1 * t).sin(),
        0.15 * (0.7 * t + 0.4).sin(),
        0.3 * t,
    );
    let p = Vector3::new(0.5 * t, 0.1 * (1.3 * t).sin(), 1.2 + 0.03 * (3.0 * t).sin());
    (r.to_rotation_matrix().into_inner(), p)
}

fn velocity(t: f64) -> Vector3<f64> {
    let h = 1e-5;
    (walk(t + h).1 - walk(t - h).1) / (2.0 * h)
}

/// The IMU 2 cm beside the camera, turned to forward-left-up axes.
fn mount() -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(0.02, 0.0, -0.01),
        UnitQuaternion::from_euler_angles(
            -std::f64::consts::FRAC_PI_2,
            0.0,
            -std::f64::consts::FRAC_PI_2,
        ),
    )
}

fn stamp(t: f64) -> Stamp {
    Stamp::from_nanos((t * 1e9).round() as i64)
}

/// What a run of 30 Hz frames over `seconds` gave: the camera position error and the
/// reported standard deviation along the camera's x, per frame.
struct Run {
    errors_x: Vec<f64>,
    sigmas_x: Vec<f64>,
    position_errors: Vec<f64>,
}

/// Frames with visual poses off the truth by `pose_sd` (m, rad) whose information
/// leaves the camera's `x` translation free (one wall and the floor) when `blind_x`,
/// or no visual pose at all when `information` is `None`.
fn run(seconds: f64, information: Option<Matrix6<f64>>, seed: u64) -> Run {
    let noise = ImuNoise::BMI055;
    let bias = Bias {
        gyro: Vector3::new(0.004, -0.003, 0.002),
        accel: Vector3::new(0.04, -0.05, 0.03),
    };
    let samples =
        Simulator::new(noise, bias, seed).run(&walk, (0.0, seconds + 0.1), 200.0, Stamp::default());
    let camera_from_imu = mount();
    let (r0, p0) = walk(0.01);
    let mut state = State {
        rotation: r0,
        position: p0,
        velocity: velocity(0.01),
        bias,
    };
    let mut covariance = Matrix15::identity() * 1e-6;
    let mut rng = SplitMix64::new(seed);
    let pose_sd = (0.001, 0.0005);
    let mut out = Run {
        errors_x: Vec::new(),
        sigmas_x: Vec::new(),
        position_errors: Vec::new(),
    };
    let frames = (seconds * 30.0) as usize;
    for k in 0..frames {
        let (t0, t1) = (0.01 + k as f64 / 30.0, 0.01 + (k + 1) as f64 / 30.0);
        let pre = Preintegrated::between(&samples, stamp(t0), stamp(t1), state.bias, noise, 0.05)
            .expect("covered");
        let (r, p) = walk(t1);
        let truth = State {
            rotation: r,
            position: p,
            velocity: velocity(t1),
            bias,
        };
        let true_camera = camera_from_world(&truth, &camera_from_imu);
        let mut gaussian = || rng.gaussian();
        let noisy = se3::exp(&nalgebra::Vector6::new(
            gaussian() * pose_sd.0,
            gaussian() * pose_sd.0,
            gaussian() * pose_sd.0,
            gaussian() * pose_sd.1,
            gaussian() * pose_sd.1,
            gaussian() * pose_sd.1,
        )) * true_camera;
        // Along a free direction the images give nothing: the visual pose there is
        // whatever the solver was left at, here 5 cm off.
        let visual_pose = se3::exp(&nalgebra::Vector6::new(0.05, 0.0, 0.0, 0.0, 0.0, 0.0)) * noisy;
        let out_step = step(&StepInput {
            preintegrated: &pre,
            gravity: &world_gravity(),
            last: &state,
            last_covariance: &covariance,
            visual: information.as_ref().map(|information| VisualPose {
                camera_from_world: visual_pose,
                information,
            }),
            camera_from_imu: &camera_from_imu,
        });
        state = out_step.state;
        covariance = out_step.covariance;
        let estimate = camera_from_world(&state, &camera_from_imu);
        let error = se3::log(&(estimate * true_camera.inverse()));
        out.errors_x.push(error[0].abs());
        out.sigmas_x.push(out_step.camera_covariance[(0, 0)].sqrt());
        out.position_errors.push(
            (estimate.inverse().translation.vector - true_camera.inverse().translation.vector)
                .norm(),
        );
    }
    out
}

/// Information of a pose measured to 1 mm and 0.03 degrees except along the camera's
/// `x` translation, which it leaves free.
fn blind_along_x() -> Matrix6<f64> {
    let mut information =
        Matrix6::from_diagonal(&nalgebra::Vector6::new(0.0, 1e6, 1e6, 4e6, 4e6, 4e6));
    information[(0, 0)] = 0.0;
    information
}

#[test]
fn a_direction_the_images_leave_free_is_carried_by_the_imu_with_a_growing_sigma() {
    for seed in [1, 2, 3] {
        let run = run(2.0, Some(blind_along_x()), seed);
        let worst = run.errors_x.iter().copied().fold(0.0, f64::max);
        // The visual pose is 5 cm off along x every frame; the IMU keeps the estimate
        // within millimetres of the truth over two seconds.
        assert!(worst < 0.01, "seed {seed}: {worst} m along x");
        // The reported sigma along x grows as the preintegration's does, and the
        // error stays within 3 of it.
        assert!(
            run.sigmas_x[59] > 2.0 * run.sigmas_x[5],
            "{:?}",
            run.sigmas_x
        );
        for (e, s) in run.errors_x.iter().zip(&run.sigmas_x) {
            assert!(*e < 3.0 * s + 2e-4, "seed {seed}: error {e} sigma {s}");
        }
    }
}

#[test]
fn without_any_visual_pose_the_imu_carries_a_second_within_centimetres() {
    for seed in [4, 5] {
        let run = run(1.0, None, seed);
        let last = *run.position_errors.last().expect("frames");
        // Known biases and velocity: only the white noise and the bias walk remain.
        assert!(last < 0.01, "seed {seed}: {last} m after 1 s");
        let sigma = *run.sigmas_x.last().expect("frames");
        assert!(sigma > run.sigmas_x[0], "the sigma grows: {sigma}");
    }
}
