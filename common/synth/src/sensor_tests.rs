//! The sensors' depth and image effects on hand-made clean renders with known depth.

use crate::noise::{self, FrameSettings, NoiseConfig};
use crate::render::RenderBuffers;
use crate::sensor::{DepthModel, Sensor};
use gfs_core::{DepthImage, RgbImage};

const W: usize = 640;
const H: usize = 480;
const FX: f64 = 525.0;

/// A clean render of gray surfaces seen head-on at the depth `depth(x, y)`.
fn buffers(depth: impl Fn(usize, usize) -> f32) -> RenderBuffers {
    let mut b = RenderBuffers::default();
    (b.width, b.height) = (W, H);
    for y in 0..H {
        for x in 0..W {
            b.depth.push(depth(x, y));
            b.colour.push([0.5; 3]);
            b.cos_incidence.push(1.0);
        }
    }
    b
}

/// A plane tilted about the vertical axis: `z0` at the centre, +-10 % at the sides, so
/// that the pixels' disparities fall at every offset from a quantisation step.
fn slanted(z0: f32) -> RenderBuffers {
    buffers(|x, _| z0 * (1.0 + 0.2 * (x as f32 / W as f32 - 0.5)))
}

/// Only the depth error of `sensor` (no holes, no image effects).
fn depth_only(sensor: Sensor) -> NoiseConfig {
    NoiseConfig {
        holes: false,
        image_sigma: 0.0,
        exposure: 0.0,
        auto_exposure_s: 0.0,
        vignetting: 0.0,
        ..NoiseConfig::of(sensor)
    }
}

fn apply(clean: &RenderBuffers, noise: &NoiseConfig, frame: usize, time_s: f64) -> DepthImage {
    let (mut rgb, mut depth) = (RgbImage::new(0, 0), DepthImage::new(0, 0));
    let settings = FrameSettings {
        seed: 7,
        frame,
        time_s,
        gain: 1.0,
        fx: FX,
    };
    noise::apply(clean, noise, &settings, &mut rgb, &mut depth);
    depth
}

/// Depth errors of `frames` frames 7 s apart, each pixel's over its model sigma.
fn normalised_errors(sensor: Sensor, z0: f32, frames: usize) -> Vec<Vec<f64>> {
    let clean = slanted(z0);
    let noise = depth_only(sensor);
    (0..frames)
        .map(|k| {
            let noisy = apply(&clean, &noise, k, 7.0 * k as f64);
            clean
                .depth
                .iter()
                .zip(noisy.as_slice())
                .map(|(&z, &n)| {
                    let z = f64::from(z);
                    (f64::from(n) - z) / noise.depth_model.sigma_at(z)
                })
                .collect()
        })
        .collect()
}

fn std(errors: &[Vec<f64>]) -> f64 {
    let all: Vec<f64> = errors.iter().flatten().copied().collect();
    let mean = all.iter().sum::<f64>() / all.len() as f64;
    (all.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / all.len() as f64).sqrt()
}

#[test]
fn kinect_depth_error_grows_with_the_square_of_the_depth() {
    // sigma(z) = 0.062 px z^2 / (580 px * 0.075 m): 1.42 mm at 1 m, 12.8 mm at 3 m.
    let model = Sensor::KinectV1.depth_model();
    assert!((model.sigma_at(1.0) - 1.425e-3).abs() < 0.05e-3);
    for z0 in [1.0, 3.0] {
        let s = std(&normalised_errors(Sensor::KinectV1, z0, 8));
        assert!(
            (s - 1.0).abs() < 0.2,
            "{z0} m: std {s} of the quadratic law's"
        );
    }
}

#[test]
fn realsense_and_tof_errors_follow_their_laws() {
    // RealSense: quadratic, 0.08 px at 385 px x 50 mm (4.2 mm at 1 m); ToF: 0.18 % of
    // the depth.
    let realsense = Sensor::RealSense.depth_model().sigma_at(1.0);
    assert!((realsense - 0.0042).abs() < 0.0003, "{realsense}");
    let tof = Sensor::Tof.depth_model();
    assert!((tof.sigma_at(3.0) / tof.sigma_at(1.0) - 3.0).abs() < 0.1);
    for sensor in [Sensor::RealSense, Sensor::Tof] {
        for z0 in [1.0, 3.0] {
            let s = std(&normalised_errors(sensor, z0, 8));
            assert!((s - 1.0).abs() < 0.2, "{sensor} {z0} m: std {s}");
        }
    }
}

/// Correlation of the errors of pixels `dx` apart on a row (means removed per frame).
fn correlation(errors: &[Vec<f64>], dx: usize) -> f64 {
    let (mut cross, mut square) = (0.0, 0.0);
    for e in errors {
        let mean = e.iter().sum::<f64>() / e.len() as f64;
        for y in 0..H {
            for x in 0..W - dx {
                let (a, b) = (e[y * W + x] - mean, e[y * W + x + dx] - mean);
                cross += a * b;
                square += a * a;
            }
        }
    }
    cross / square
}

#[test]
fn kinect_depth_error_is_correlated_across_pixels_and_not_the_ideal_one() {
    let kinect = correlation(&normalised_errors(Sensor::KinectV1, 2.0, 4), 8);
    assert!(kinect > 0.3, "Kinect correlation at 8 px {kinect}");
    let ideal = correlation(&normalised_errors(Sensor::Ideal, 2.0, 4), 8);
    assert!(ideal.abs() < 0.02, "ideal correlation at 8 px {ideal}");
}

#[test]
fn kinect_depth_error_drifts_slowly_from_frame_to_frame() {
    let clean = slanted(2.0);
    let noise = depth_only(Sensor::KinectV1);
    let error = |t: f64| -> Vec<f64> {
        let noisy = apply(&clean, &noise, 0, t);
        clean
            .depth
            .iter()
            .zip(noisy.as_slice())
            .map(|(&z, &n)| f64::from(n - z))
            .collect()
    };
    let corr = |a: &[f64], b: &[f64]| {
        let dot = |u: &[f64], v: &[f64]| u.iter().zip(v).map(|(p, q)| p * q).sum::<f64>();
        dot(a, b) / (dot(a, a) * dot(b, b)).sqrt()
    };
    // Same per-pixel draws (frame 0) at times 1/30 s and 20 s apart: only the smooth
    // part moves.
    let (now, next, later) = (error(10.0), error(10.0 + 1.0 / 30.0), error(30.0));
    let step = corr(&now, &next);
    let far = corr(&now, &later);
    assert!(step > 0.95, "consecutive frames' errors correlate {step}");
    assert!(far < step - 0.2, "20 s apart {far}, next frame {step}");
}

#[test]
fn projector_shadows_fall_beside_foreground_edges_away_from_the_projector() {
    // A box 1 m away in columns 200..440 before a wall 3 m away; the projector 7.5 cm
    // to the right: a shadow fx b (1/1 - 1/3) = 26.25 px wide left of the box.
    let clean = buffers(|x, _| if (200..440).contains(&x) { 1.0 } else { 3.0 });
    let noise = NoiseConfig {
        depth_noise: false,
        hole_blobs: 0.0,
        grazing_ramp_deg: 0.0,
        edge_dropout: 0.0,
        ..NoiseConfig::of(Sensor::KinectV1)
    };
    let depth = apply(&clean, &noise, 0, 0.0);
    for y in [0, 240, 479] {
        let missing: Vec<usize> = (0..W).filter(|&x| depth.get(x, y) == Some(0.0)).collect();
        // Sampled at pixel centres, within a pixel of the 26.25 px.
        assert!((25..=27).contains(&missing.len()), "row {y}: {missing:?}");
        assert!(
            missing.iter().all(|&x| (173..200).contains(&x)),
            "row {y}: {missing:?}"
        );
    }
}

#[test]
fn depth_edges_drop_out_for_triangulation_and_fly_for_time_of_flight() {
    let clean = buffers(|x, _| if x < 320 { 1.0 } else { 2.0 });
    let edges = |sensor| NoiseConfig {
        depth_noise: sensor == Sensor::Tof,
        hole_blobs: 0.0,
        shadows: false,
        ..NoiseConfig::of(sensor)
    };
    let kinect = apply(&clean, &edges(Sensor::KinectV1), 0, 0.0);
    let dropped = (0..H)
        .flat_map(|y| [319, 320].map(|x| kinect.get(x, y)))
        .filter(|&z| z == Some(0.0))
        .count();
    // Probability 0.5 over 960 edge pixels; none elsewhere.
    assert!((430..530).contains(&dropped), "{dropped} of 960 dropped");
    let elsewhere = kinect.as_slice().iter().filter(|&&z| z == 0.0).count() - dropped;
    assert_eq!(elsewhere, 0);
    let tof = apply(&clean, &edges(Sensor::Tof), 0, 0.0);
    let flying = (0..H)
        .flat_map(|y| [319, 320].map(|x| tof.get(x, y).unwrap_or(0.0)))
        .filter(|&z| (1.05..1.9).contains(&z))
        .count();
    assert!(
        (250..530).contains(&flying),
        "{flying} of 960 edge pixels between the depths"
    );
}

#[test]
fn vignetting_darkens_the_corners_by_its_strength() {
    let clean = buffers(|_, _| 2.0);
    let noise = NoiseConfig {
        image_sigma: 0.0,
        ..NoiseConfig::of(Sensor::KinectV1)
    };
    let (mut rgb, mut depth) = (RgbImage::new(0, 0), DepthImage::new(0, 0));
    let settings = FrameSettings {
        seed: 1,
        frame: 0,
        time_s: 0.0,
        gain: 1.0,
        fx: FX,
    };
    noise::apply(&clean, &noise, &settings, &mut rgb, &mut depth);
    let level = |x, y| f64::from(rgb.get(x, y).unwrap_or([0; 3])[1]);
    // 0.5 * 255 = 127.5 at the centre, (1 - 0.3) of it in the corners.
    assert!((level(320, 240) - 127.5).abs() <= 1.0);
    assert!((level(0, 0) - 0.7 * 127.5).abs() <= 1.0, "{}", level(0, 0));
    assert_eq!(noise.depth_model, Sensor::KinectV1.depth_model());
    assert!(matches!(
        NoiseConfig::default().depth_model,
        DepthModel::Independent
    ));
}
