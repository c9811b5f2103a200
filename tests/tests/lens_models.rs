//! Every lens model a camera driver publishes, end to end: a synthetic sequence recorded
//! through a rational_polynomial (Azure Kinect) or an equidistant (fisheye) lens is
//! undistorted through the source's lookup table and tracked; its ATE is asserted
//! within 10 % of the same sequence recorded through an ideal pinhole.

mod common;

use common::in_process::InProcess;
use gfs_core::camera::{Camera, Distortion, DistortionModel, UndistortMap};
use gfs_core::{DepthImage, RgbImage};
use gfs_dataset::{EVO_MAX_DIFF_S, Trajectory, evaluate};
use gfs_odometry::{OdometryConfig, TrackingStatus};
use gfs_synth::{NoiseConfig, SynthConfig, SynthSequence, luma, typical_lens};

const FRAMES: usize = 120;

/// ATE (m) and frames without a tracked pose of the room sequence through `distortion`.
fn ate_through(distortion: Distortion) -> (f64, usize) {
    let sequence = SynthSequence::new(SynthConfig {
        frames: FRAMES,
        noise: NoiseConfig::default(),
        distortion,
        ..SynthConfig::default()
    });
    let camera = Camera {
        pinhole: sequence.config().camera,
        distortion,
    };
    // Built once, as the source stage builds it; the ideal pinhole needs none.
    let undistort = (!distortion.is_zero()).then(|| UndistortMap::new(&camera));
    let mut vo = InProcess::new(camera.pinhole, OdometryConfig::default());
    let (mut estimate, mut truth) = (Trajectory::new(), Trajectory::new());
    let (mut rgb, mut depth) = (RgbImage::new(0, 0), DepthImage::new(0, 0));
    let mut predicted = 0;
    for i in 0..sequence.len() {
        let mut frame = sequence.render(i);
        if let Some(map) = &undistort {
            map.remap_rgb(&frame.rgb.view(), &mut rgb).unwrap();
            map.remap_depth(&frame.depth.view(), &mut depth).unwrap();
            std::mem::swap(&mut frame.rgb, &mut rgb);
            std::mem::swap(&mut frame.depth, &mut depth);
            for (g, c) in frame
                .gray
                .as_mut_slice()
                .iter_mut()
                .zip(frame.rgb.as_slice())
            {
                *g = luma(*c);
            }
        }
        let pose = vo.process(i, &frame);
        predicted += usize::from(pose.status == TrackingStatus::Predicted);
        estimate.push(
            frame.timestamp,
            vo.odometry.map_from_odom() * pose.world_from_camera,
        );
        truth.push(frame.timestamp, frame.pose);
    }
    let evaluation = evaluate(&truth, &estimate, EVO_MAX_DIFF_S).unwrap();
    assert_eq!(evaluation.matched(), FRAMES);
    (evaluation.ate.stats.rmse, predicted)
}

#[test]
fn distorted_sequences_are_tracked_within_ten_percent_of_the_ideal_pinhole() {
    let (ideal, lost) = ate_through(Distortion::default());
    println!("ideal pinhole: ATE {ideal:.5} m, {lost} frames predicted");
    assert_eq!(lost, 0);
    let results = [
        DistortionModel::RationalPolynomial,
        DistortionModel::Equidistant,
    ]
    .map(|model| {
        let (ate, lost) = ate_through(typical_lens(model));
        println!(
            "{}: ATE {ate:.5} m ({:+.1} %), {lost} frames predicted",
            model.name(),
            100.0 * (ate / ideal - 1.0)
        );
        (model, ate, lost)
    });
    for (model, ate, lost) in results {
        assert_eq!(lost, 0, "{}", model.name());
        assert!(
            ate <= 1.1 * ideal,
            "{}: ATE {ate} m, ideal pinhole {ideal} m",
            model.name()
        );
    }
}
