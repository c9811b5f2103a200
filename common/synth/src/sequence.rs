//! A synthetic sequence: a scene, a trajectory and a noise model, rendered on demand.

use crate::lens::Lens;
use crate::noise::{self, AUTO_EXPOSURE_TARGET, FrameSettings, NoiseConfig};
use crate::render::{RenderBuffers, render_into};
use crate::rng::SplitMix64;
use crate::scene::{Scene, SceneKind};
use crate::trajectory::{self, TrajectoryKind};
use gfs_core::camera::{Distortion, PinholeCamera};
use gfs_core::{DepthImage, GrayImage, RgbImage};
use nalgebra::Isometry3;
use serde::Deserialize;
use std::f64::consts::TAU;

/// Everything that defines a synthetic sequence. Same config, same images, bit for bit.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SynthConfig {
    /// The scene. Default [`SceneKind::Room`].
    pub scene: SceneKind,
    /// The camera motion. Default [`TrajectoryKind::Slow`].
    pub trajectory: TrajectoryKind,
    /// Number of frames. Default 300 (10 s at 30 Hz).
    pub frames: usize,
    /// Seed of the textures, trajectory and noise. Default 1.
    pub seed: u64,
    /// Sensor effects. Default [`NoiseConfig::default`] (mild); tests that need exact
    /// geometry use [`NoiseConfig::none`].
    pub noise: NoiseConfig,
    /// Intrinsics and image size. Default 640x480, fx = fy = 525, cx = 319.5,
    /// cy = 239.5 (`configs/synthetic.toml`, the TUM / Kinect nominal values).
    pub camera: PinholeCamera,
    /// The lens the frames are recorded through. Default none (an ideal pinhole).
    pub distortion: Distortion,
    /// Frame rate, Hz. Default 30 (Kinect).
    pub rate_hz: f64,
    /// Timestamp of frame 0, seconds. Default 1000.0 (a fixed epoch, so that file names
    /// and ground truth are reproducible).
    pub start_time: f64,
    /// The camera's IMU, written as `imu.txt`. Default none.
    #[serde(skip)]
    pub imu: Option<crate::imu::SynthImu>,
}

impl Default for SynthConfig {
    fn default() -> Self {
        Self {
            scene: SceneKind::default(),
            trajectory: TrajectoryKind::default(),
            frames: 300,
            seed: 1,
            noise: NoiseConfig::default(),
            camera: Self::default_camera(),
            distortion: Distortion::default(),
            rate_hz: 30.0,
            start_time: 1000.0,
            imu: None,
        }
    }
}

impl SynthConfig {
    /// The camera of `configs/synthetic.toml`: 640x480, fx = fy = 525, cx = 319.5,
    /// cy = 239.5.
    pub fn default_camera() -> PinholeCamera {
        PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480)
    }

    /// The default camera scaled to `width` pixels wide (same field of view, same 4:3
    /// aspect), e.g. 160 for fast tests: fx = fy = 525 * width / 640.
    pub fn scaled_camera(width: usize) -> PinholeCamera {
        let k = width as f64 / 640.0;
        let height = width * 3 / 4;
        PinholeCamera::new(
            525.0 * k,
            525.0 * k,
            (width as f64 - 1.0) / 2.0,
            (height as f64 - 1.0) / 2.0,
            width,
            height,
        )
    }
}

/// One rendered frame with its ground truth.
#[derive(Clone, Debug)]
pub struct SynthFrame {
    /// Frame index in the sequence.
    pub index: usize,
    /// Capture time, seconds.
    pub timestamp: f64,
    /// Ground-truth pose `T_wc`.
    pub pose: Isometry3<f64>,
    /// Colour image.
    pub rgb: RgbImage,
    /// Gray image (BT.601 luma of `rgb`, see [`luma`]).
    pub gray: GrayImage,
    /// Depth in metres, 0 = missing.
    pub depth: DepthImage,
}

/// A deterministic synthetic RGB-D sequence: poses are computed up front, images are
/// rendered on demand by [`SynthSequence::render`].
///
/// ```
/// use gfs_synth::{NoiseConfig, SynthConfig, SynthSequence};
/// let seq = SynthSequence::new(SynthConfig {
///     frames: 3,
///     camera: SynthConfig::scaled_camera(160),
///     noise: NoiseConfig::none(),
///     ..SynthConfig::default()
/// });
/// let frame = seq.render(2);
/// assert_eq!((frame.rgb.width(), frame.depth.height()), (160, 120));
/// assert_eq!(frame.timestamp, 1000.0 + 2.0 / 30.0);
/// assert!(frame.depth.as_slice().iter().all(|&z| z > 0.1 && z < 15.0));
/// ```
#[derive(Clone, Debug)]
pub struct SynthSequence {
    config: SynthConfig,
    scene: Scene,
    motion: trajectory::Motion,
    poses: Vec<Isometry3<f64>>,
    gains: Vec<f64>,
    lens: Option<Lens>,
}

impl SynthSequence {
    /// Builds the scene and the trajectory of `config` (no rendering yet).
    pub fn new(config: SynthConfig) -> SynthSequence {
        let scene = Scene::new(config.scene, config.seed);
        let rate = if config.rate_hz > 0.0 && config.rate_hz.is_finite() {
            config.rate_hz
        } else {
            30.0
        };
        let motion =
            trajectory::motion(&scene, config.trajectory, config.frames, config.seed, rate);
        let poses: Vec<Isometry3<f64>> = (0..config.frames)
            .map(|i| motion.pose(i as f64 / rate))
            .collect();
        let mut rng = SplitMix64::keyed(config.seed, &[0x6761_696e]);
        let (p1, p2) = (rng.range(0.0, TAU), rng.range(0.0, TAU));
        let automatic = auto_exposure(&scene, &config, &poses, rate);
        let gains = (0..config.frames)
            .map(|i| {
                let t = i as f64 / rate;
                let drift = 0.6 * (TAU * t / 7.7 + p1).sin() + 0.4 * (TAU * t / 3.3 + p2).sin();
                let gain = 1.0 + config.noise.exposure * drift;
                automatic.as_ref().map_or(gain, |a| gain * a[i])
            })
            .collect();
        let lens =
            (!config.distortion.is_zero()).then(|| Lens::new(&config.camera, config.distortion));
        SynthSequence {
            lens,
            config: SynthConfig {
                rate_hz: rate,
                ..config
            },
            scene,
            motion,
            poses,
            gains,
        }
    }

    /// The config the sequence was built from.
    pub fn config(&self) -> &SynthConfig {
        &self.config
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.poses.len()
    }

    /// True when the sequence has no frame.
    pub fn is_empty(&self) -> bool {
        self.poses.is_empty()
    }

    /// Ground-truth pose `T_wc` of frame `i`. Panics when `i >= len()` (a caller bug).
    pub fn pose(&self, i: usize) -> Isometry3<f64> {
        self.poses[i]
    }

    /// All ground-truth poses `T_wc`.
    pub fn poses(&self) -> &[Isometry3<f64>] {
        &self.poses
    }

    /// The pose `T_wc` at `t` seconds after frame 0 (between and beyond the frames).
    pub(crate) fn pose_at(&self, t: f64) -> Isometry3<f64> {
        self.motion.pose(t)
    }

    /// Timestamp of frame `i`, seconds: `start_time + i / rate_hz`.
    pub fn timestamp(&self, i: usize) -> f64 {
        self.config.start_time + i as f64 / self.config.rate_hz
    }

    /// Exposure gain of frame `i` (1 without exposure drift).
    pub fn gain(&self, i: usize) -> f64 {
        self.gains[i]
    }

    /// The scene and its ground truth (planes, edges, Manhattan axes).
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// Renders frame `i` with the configured noise. Panics when `i >= len()`.
    pub fn render(&self, i: usize) -> SynthFrame {
        let mut frame = SynthFrame {
            index: i,
            timestamp: self.timestamp(i),
            pose: self.pose(i),
            rgb: RgbImage::new(0, 0),
            gray: GrayImage::new(0, 0),
            depth: DepthImage::new(0, 0),
        };
        self.render_into(i, &mut RenderBuffers::default(), &mut frame);
        frame
    }

    /// Renders frame `i` into `frame`, reusing `scratch` and the frame's buffers.
    pub(crate) fn render_into(
        &self,
        i: usize,
        scratch: &mut RenderBuffers,
        frame: &mut SynthFrame,
    ) {
        let pose = self.pose(i);
        match &self.lens {
            Some(lens) => lens.render(&self.scene, &pose, scratch),
            None => render_into(&self.scene, &self.config.camera, &pose, scratch),
        }
        let settings = FrameSettings {
            seed: self.config.seed,
            frame: i,
            time_s: i as f64 / self.config.rate_hz,
            gain: self.gains[i],
            fx: self.config.camera.fx,
        };
        noise::apply(
            scratch,
            &self.config.noise,
            &settings,
            &mut frame.rgb,
            &mut frame.depth,
        );
        frame.index = i;
        frame.timestamp = self.timestamp(i);
        frame.pose = pose;
        frame.gray.resize(frame.rgb.width(), frame.rgb.height());
        for (g, c) in frame
            .gray
            .as_mut_slice()
            .iter_mut()
            .zip(frame.rgb.as_slice())
        {
            *g = luma(*c);
        }
    }
}

/// Width of the preview the auto-exposure meters the scene on, pixels.
const METER_WIDTH: usize = 64;
/// Range of the auto-exposure gain.
const AUTO_GAIN: (f64, f64) = (0.5, 2.0);

/// The auto-exposure gain of every frame (`None` when off): the gain that brings the
/// mean brightness of a small clean preview to [`AUTO_EXPOSURE_TARGET`], followed by
/// a first-order lag of `auto_exposure_s` (the first frame starts settled).
fn auto_exposure(
    scene: &Scene,
    config: &SynthConfig,
    poses: &[Isometry3<f64>],
    rate: f64,
) -> Option<Vec<f64>> {
    let tau = config.noise.auto_exposure_s;
    if !(tau > 0.0 && tau.is_finite()) {
        return None;
    }
    let k = METER_WIDTH as f64 / config.camera.width.max(1) as f64;
    let c = &config.camera;
    let meter = PinholeCamera::new(
        c.fx * k,
        c.fy * k,
        (METER_WIDTH as f64 - 1.0) / 2.0,
        ((c.height as f64 * k).round() - 1.0) / 2.0,
        METER_WIDTH,
        (c.height as f64 * k).round().max(1.0) as usize,
    );
    let follow = 1.0 - (-1.0 / (rate * tau)).exp();
    let mut buffers = RenderBuffers::default();
    let mut gain: Option<f64> = None;
    let weights = LUMA_WEIGHTS.map(|w| w as f32);
    Some(
        poses
            .iter()
            .map(|pose| {
                render_into(scene, &meter, pose, &mut buffers);
                let sum: f64 = buffers
                    .colour
                    .iter()
                    .map(|p| f64::from(weights[0] * p[0] + weights[1] * p[1] + weights[2] * p[2]))
                    .sum();
                let mean = sum / buffers.colour.len().max(1) as f64;
                let target =
                    (AUTO_EXPOSURE_TARGET / mean.max(1e-6)).clamp(AUTO_GAIN.0, AUTO_GAIN.1);
                let next = gain.map_or(target, |g| g + follow * (target - g));
                gain = Some(next);
                next
            })
            .collect(),
    )
}

/// BT.601 luma weights of red, green and blue.
pub const LUMA_WEIGHTS: [f64; 3] = [0.299, 0.587, 0.114];

/// BT.601 luma, weights [`LUMA_WEIGHTS`], rounded: the same integer formula as
/// `gfs_dataset::gray_bt601`, so the gray of a rendered frame equals the gray of the
/// same frame read back from its PNG.
#[inline]
pub fn luma(c: [u8; 3]) -> u8 {
    ((299 * u32::from(c[0]) + 587 * u32::from(c[1]) + 114 * u32::from(c[2]) + 500) / 1000) as u8
}
