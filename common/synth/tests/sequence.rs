//! Determinism, trajectories and noise statistics.

use gfs_synth::{
    DEPTH_SIGMA_PER_Z2, MIN_CLEARANCE, NoiseConfig, Scene, SceneKind, SynthConfig, SynthSequence,
    TrajectoryKind,
};
use nalgebra::Point3;

fn small(seed: u64, noise: NoiseConfig) -> SynthConfig {
    SynthConfig {
        frames: 4,
        seed,
        noise,
        camera: SynthConfig::scaled_camera(160),
        ..SynthConfig::default()
    }
}

#[test]
fn same_seed_gives_identical_frames_and_another_seed_differs() {
    let a = SynthSequence::new(small(5, NoiseConfig::default())).render(3);
    let b = SynthSequence::new(small(5, NoiseConfig::default())).render(3);
    assert_eq!(a.rgb, b.rgb);
    assert_eq!(a.depth, b.depth);
    assert_eq!(a.pose, b.pose);
    let c = SynthSequence::new(small(6, NoiseConfig::default())).render(3);
    let changed = a
        .rgb
        .as_slice()
        .iter()
        .zip(c.rgb.as_slice())
        .filter(|(p, q)| p != q)
        .count();
    assert!(
        changed > a.rgb.as_slice().len() / 2,
        "only {changed} pixels differ"
    );
    assert!((a.pose.translation.vector - c.pose.translation.vector).norm() > 0.01);
}

#[test]
fn trajectories_keep_clearance_and_reach_their_speeds() {
    for scene in SceneKind::ALL {
        let s = Scene::new(scene, 1);
        // The free box itself keeps the clearance: check a grid over it.
        let (lo, hi) = (s.free_space().min, s.free_space().max);
        for i in 0..=6 {
            for j in 0..=6 {
                for k in 0..=2 {
                    let p = Point3::new(
                        lo.x + (hi.x - lo.x) * i as f64 / 6.0,
                        lo.y + (hi.y - lo.y) * j as f64 / 6.0,
                        lo.z + (hi.z - lo.z) * k as f64 / 2.0,
                    );
                    let d = s.distance_to_surfaces(&p);
                    assert!(
                        d >= MIN_CLEARANCE,
                        "{scene}: free-space point {p:?} is {d:.3} m from a surface"
                    );
                }
            }
        }
        for kind in TrajectoryKind::ALL {
            for seed in [1, 2, 3] {
                let seq = SynthSequence::new(SynthConfig {
                    scene,
                    trajectory: kind,
                    seed,
                    ..SynthConfig::default()
                });
                let poses = seq.poses();
                assert_eq!(poses.len(), 300);
                for (i, p) in poses.iter().enumerate() {
                    let c = Point3::from(p.translation.vector);
                    let d = seq.scene().distance_to_surfaces(&c);
                    assert!(
                        d >= MIN_CLEARANCE,
                        "{scene} {kind} seed {seed} frame {i}: {d:.3} m from a surface"
                    );
                    // Optical axis never points more than ~50 deg above or below horizontal.
                    let axis = p.rotation * nalgebra::Vector3::z();
                    assert!(
                        axis.z.abs() < 0.77,
                        "{scene} {kind} frame {i}: looks along {axis:?}"
                    );
                }
                let (v, w) = poses.windows(2).fold((0.0, 0.0), |(v, w), p| {
                    let d = p[0].inverse() * p[1];
                    (v + d.translation.vector.norm(), w + d.rotation.angle())
                });
                let rate = 30.0 / (poses.len() - 1) as f64;
                let (v, w) = (v * rate, (w * rate).to_degrees());
                let (tv, tw) = kind.mean_speeds();
                assert!(
                    (v / tv - 1.0).abs() < 0.1,
                    "{scene} {kind} seed {seed}: {v:.3} m/s, target {tv}"
                );
                assert!(
                    (w / tw - 1.0).abs() < 0.1,
                    "{scene} {kind} seed {seed}: {w:.1} deg/s, target {tw}"
                );
            }
        }
    }
}

#[test]
fn timestamps_start_at_the_epoch_and_tick_at_30_hz() {
    let seq = SynthSequence::new(small(1, NoiseConfig::none()));
    assert_eq!(seq.timestamp(0).to_string(), "1000.000000");
    assert_eq!(seq.timestamp(3).to_string(), "1000.100000");
    assert!(
        SynthSequence::new(SynthConfig {
            frames: 0,
            ..small(1, NoiseConfig::none())
        })
        .is_empty()
    );
}

#[test]
fn depth_noise_has_the_configured_sigma_and_is_quantised() {
    let only_depth = NoiseConfig {
        holes: false,
        image_sigma: 0.0,
        exposure: 0.0,
        ..NoiseConfig::default()
    };
    let clean = SynthSequence::new(small(3, NoiseConfig::none())).render(2);
    let noisy = SynthSequence::new(small(3, only_depth)).render(2);
    assert_eq!(clean.rgb, noisy.rgb);
    let mut normalised = Vec::new();
    for (&z, &n) in clean.depth.as_slice().iter().zip(noisy.depth.as_slice()) {
        let units = f64::from(n) * 5000.0;
        assert!(
            (units - units.round()).abs() < 0.02 * units / 5000.0 + 1e-3,
            "{n} m is not a 1/5000 m step"
        );
        let sigma = DEPTH_SIGMA_PER_Z2 * f64::from(z).powi(2);
        normalised.push((f64::from(n) - f64::from(z)) / sigma);
    }
    let count = normalised.len() as f64;
    let mean = normalised.iter().sum::<f64>() / count;
    let std = (normalised.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / count).sqrt();
    assert!(mean.abs() < 0.05, "mean {mean} sigma");
    assert!((std - 1.0).abs() < 0.08, "std {std} sigma");
}

#[test]
fn image_noise_and_exposure_follow_the_config() {
    let image_only = NoiseConfig {
        depth_noise: false,
        holes: false,
        image_sigma: 4.0,
        exposure: 0.0,
        ..NoiseConfig::default()
    };
    let clean = SynthSequence::new(small(4, NoiseConfig::none())).render(1);
    let noisy = SynthSequence::new(small(4, image_only)).render(1);
    assert_eq!(clean.depth, noisy.depth);
    let diffs: Vec<f64> = clean
        .rgb
        .as_slice()
        .iter()
        .flatten()
        .zip(noisy.rgb.as_slice().iter().flatten())
        .filter(|(c, _)| (20..235).contains(*c))
        .map(|(&c, &n)| f64::from(n) - f64::from(c))
        .collect();
    let std = (diffs.iter().map(|d| d * d).sum::<f64>() / diffs.len() as f64).sqrt();
    // Rounding to integers adds 1/12 level^2 of variance.
    assert!(
        (std - (16.0f64 + 1.0 / 12.0).sqrt()).abs() < 0.2,
        "image noise std {std}"
    );

    let exposure = NoiseConfig {
        exposure: 0.1,
        ..NoiseConfig::none()
    };
    let seq = SynthSequence::new(SynthConfig {
        frames: 300,
        ..small(4, exposure)
    });
    let gains: Vec<f64> = (0..seq.len()).map(|i| seq.gain(i)).collect();
    let (lo, hi) = gains
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &g| (a.min(g), b.max(g)));
    assert!(
        lo >= 0.9 && hi <= 1.1 && hi - lo > 0.05,
        "gain range {lo}..{hi}"
    );
    let steps = gains
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .fold(0.0, f64::max);
    assert!(
        steps < 0.01,
        "gain jumps by {steps} between frames: not a slow drift"
    );
    let i = (0..seq.len())
        .max_by(|&a, &b| gains[a].total_cmp(&gains[b]))
        .unwrap_or(0);
    let (bright, plain) = (
        seq.render(i),
        SynthSequence::new(small(4, NoiseConfig::none())).render(0),
    );
    let mean =
        |f: &gfs_synth::SynthFrame| f.gray.as_slice().iter().map(|&g| f64::from(g)).sum::<f64>();
    let reference = SynthSequence::new(SynthConfig {
        frames: 300,
        ..small(4, NoiseConfig::none())
    })
    .render(i);
    let ratio = mean(&bright) / mean(&reference);
    assert!(
        (ratio / gains[i] - 1.0).abs() < 0.03,
        "brightness ratio {ratio} for gain {}",
        gains[i]
    );
    assert!(mean(&plain) > 0.0);
}

#[test]
fn holes_cover_blobs_grazing_angles_and_far_range_only() {
    let holes_only = NoiseConfig {
        depth_noise: false,
        image_sigma: 0.0,
        exposure: 0.0,
        hole_blobs: 6.0,
        ..NoiseConfig::default()
    };
    // Corridor: the first frame that sees farther than 8 m down the corridor.
    let config = |noise| SynthConfig {
        scene: SceneKind::Corridor,
        trajectory: TrajectoryKind::Fast,
        noise,
        camera: SynthConfig::scaled_camera(160),
        ..SynthConfig::default()
    };
    let clean_seq = SynthSequence::new(config(NoiseConfig::none()));
    let i = (0..clean_seq.len())
        .step_by(10)
        .find(|&i| {
            clean_seq
                .render(i)
                .depth
                .as_slice()
                .iter()
                .any(|&z| z > 8.5)
        })
        .expect("some frame looks down the corridor");
    let clean = clean_seq.render(i);
    let holed = SynthSequence::new(config(holes_only)).render(i);
    let (mut missing, mut far) = (0, 0);
    for (&z, &h) in clean.depth.as_slice().iter().zip(holed.depth.as_slice()) {
        if z > 8.0 {
            far += 1;
            assert_eq!(h, 0.0, "depth {z} m beyond 8 m must be missing");
        }
        if h == 0.0 {
            missing += 1;
        } else {
            assert_eq!(h, z, "kept depth must be untouched without depth noise");
        }
    }
    let n = clean.depth.as_slice().len();
    assert!(far > 0, "the corridor view should reach beyond 8 m");
    assert!(
        missing > far && missing < n / 3,
        "{missing} missing of {n}, {far} far"
    );
}

#[test]
fn a_config_reads_from_a_toml_table_with_defaults_for_missing_fields() {
    let config: SynthConfig = toml::from_str(
        "scene = 'low-texture'\ntrajectory = 'rotation'\nframes = 12\n[noise]\nimage_sigma = 0.5\n",
    )
    .unwrap();
    assert_eq!(config.scene, SceneKind::LowTexture);
    assert_eq!(config.trajectory, TrajectoryKind::Rotation);
    assert_eq!((config.frames, config.seed), (12, 1));
    assert_eq!(config.noise.image_sigma, 0.5);
    assert!(config.noise.depth_noise);
    assert_eq!(config.camera, SynthConfig::default_camera());
    assert!(toml::from_str::<SynthConfig>("scenery = 'room'").is_err());
}

#[test]
fn degenerate_cameras_render_without_panicking() {
    for camera in [
        gfs_core::camera::PinholeCamera::new(10.0, 10.0, 0.0, 0.0, 0, 0),
        gfs_core::camera::PinholeCamera::new(10.0, 10.0, 0.0, 0.0, 1, 1),
        gfs_core::camera::PinholeCamera::new(0.0, 0.0, 0.0, 0.0, 4, 3),
    ] {
        let f = SynthSequence::new(SynthConfig {
            frames: 1,
            camera,
            ..SynthConfig::default()
        })
        .render(0);
        assert_eq!(f.rgb.width() * f.rgb.height(), camera.width * camera.height);
    }
}

#[test]
fn gray_is_rounded_bt601_luma_of_the_colour() {
    assert_eq!(gfs_synth::luma([255, 255, 255]), 255);
    assert_eq!(gfs_synth::luma([255, 0, 0]), 76);
    assert_eq!(gfs_synth::luma([0, 255, 0]), 150);
    assert_eq!(gfs_synth::luma([0, 0, 255]), 29);
    let f = SynthSequence::new(small(1, NoiseConfig::default())).render(0);
    for (g, c) in f.gray.as_slice().iter().zip(f.rgb.as_slice()) {
        assert_eq!(*g, gfs_synth::luma(*c));
    }
}

/// The auto-exposure of the real sensors holds the image's mean brightness nearer its
/// target than a fixed exposure does as the view moves between dark and bright
/// surfaces, and follows with its lag: the gain moves at most a share
/// `1 - exp(-1 / (30 Hz * 0.3 s))` (11 %) of the way to its target each frame.
#[test]
fn auto_exposure_follows_the_scene_with_lag() {
    let config = |noise| SynthConfig {
        frames: 90,
        trajectory: TrajectoryKind::Fast,
        ..small(2, noise)
    };
    let automatic = NoiseConfig {
        auto_exposure_s: 0.3,
        ..NoiseConfig::none()
    };
    let fixed = SynthSequence::new(config(NoiseConfig::none()));
    let auto = SynthSequence::new(config(automatic));
    let brightness = |seq: &SynthSequence, i: usize| {
        let f = seq.render(i);
        f.gray.as_slice().iter().map(|&g| f64::from(g)).sum::<f64>()
            / f.gray.as_slice().len() as f64
    };
    let spread = |values: &[f64]| {
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        (values.iter().map(|v| (v / mean).ln().powi(2)).sum::<f64>() / values.len() as f64).sqrt()
    };
    let frames: Vec<usize> = (0..90).step_by(3).collect();
    let fixed_levels: Vec<f64> = frames.iter().map(|&i| brightness(&fixed, i)).collect();
    let auto_levels: Vec<f64> = frames.iter().map(|&i| brightness(&auto, i)).collect();
    let (s_fixed, s_auto) = (spread(&fixed_levels), spread(&auto_levels));
    assert!(
        s_fixed > 0.03,
        "the fixed exposure's brightness varies by {s_fixed}"
    );
    assert!(
        s_auto < 0.7 * s_fixed,
        "auto {s_auto} against fixed {s_fixed}"
    );
    // Each frame's gain: the target would be reached in one step without the lag.
    let gains: Vec<f64> = (0..90).map(|i| auto.gain(i)).collect();
    let (lo, hi) = gains
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &g| (a.min(g), b.max(g)));
    let step = gains
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .fold(0.0, f64::max);
    assert!(hi - lo > 0.05, "gain range {lo}..{hi}");
    assert!(
        step < 0.115 * (hi - lo) + 1e-9,
        "largest step {step} of a range {}",
        hi - lo
    );
}
