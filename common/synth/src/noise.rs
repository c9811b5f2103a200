//! Sensor effects applied on top of a clean render: depth error and quantisation (per
//! [`DepthModel`]), missing depth (random blobs, grazing angles, long range, projector
//! shadows, depth discontinuities), flying pixels, gaussian image noise, exposure
//! (drift or auto-exposure, see `sequence`) and vignetting.

use crate::render::{RenderBuffers, for_each_parallel, to_u8};
use crate::rng::SplitMix64;
use crate::sensor::{DepthModel, FieldFrame, Sensor, shadow_row};
use crate::texture::value_noise;
use gfs_core::{DepthImage, RgbImage};
use serde::Deserialize;

/// Depth noise model of the Kinect v1 (axial sigma grows with z^2, Khoshelham & Elberink
/// 2012): sigma = `DEPTH_SIGMA_PER_Z2 * z^2` metres.
pub const DEPTH_SIGMA_PER_Z2: f64 = 1.425e-3;
/// Depth written in TUM layout is in units of 1/5000 m: noisy depth is quantised to that.
pub const DEPTH_SCALE: f64 = 5000.0;

/// What sensor effects to simulate ([`NoiseConfig::of`] gives a [`Sensor`]'s).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NoiseConfig {
    /// Depth error, per [`NoiseConfig::depth_model`]. Default true.
    pub depth_noise: bool,
    /// How the depth error is formed. Default [`DepthModel::Independent`]:
    /// sigma = 1.425e-3 * z^2 m per pixel and frame, then the 1/5000 m steps of the
    /// written depth.
    pub depth_model: DepthModel,
    /// Missing depth: random blobs, surfaces seen at more than `grazing_deg`, and
    /// anything farther than `max_depth_m`. Default true.
    pub holes: bool,
    /// Mean number of random missing-depth blobs per frame (4 to 24 px radius at 640 px
    /// width). Default 3.
    pub hole_blobs: f64,
    /// Incidence angle beyond which depth is missing, degrees. Default 75 (structured
    /// light fails at grazing angles).
    pub grazing_deg: f64,
    /// Width of the band of incidence angles below `grazing_deg` where depth goes
    /// missing with a probability rising from 0 to 1 (quadratically), degrees.
    /// Default 0 (a sharp cut).
    pub grazing_ramp_deg: f64,
    /// Range beyond which depth is missing, metres. Default 8 (Kinect v1 useful range).
    pub max_depth_m: f64,
    /// No depth where the second viewpoint of a triangulating sensor (the depth
    /// model's baseline) cannot see: a shadow beside foreground edges. Default false.
    pub shadows: bool,
    /// Probability that a pixel beside a depth discontinuity (a 4-neighbour more than
    /// 5 % nearer or farther) has no depth, or with a time-of-flight depth model, mixes
    /// its depth with its neighbour's (a flying pixel). Default 0.
    pub edge_dropout: f64,
    /// Standard deviation of (near-)gaussian image noise per channel, gray levels
    /// (0 = none). Default 2.
    pub image_sigma: f64,
    /// Amplitude of the slow exposure gain drift, relative (0 = constant exposure).
    /// Default 0.08: the gain wanders within [0.92, 1.08] over a few seconds.
    pub exposure: f64,
    /// Time constant of the auto-exposure, seconds: the gain follows the one that
    /// brings the scene's mean brightness to [`AUTO_EXPOSURE_TARGET`] with this lag
    /// (0 = no auto-exposure). Default 0.
    pub auto_exposure_s: f64,
    /// Brightness lost in the image corners, relative (`1 - v r^2` with `r` the
    /// distance to the principal point over the corner's). Default 0.
    pub vignetting: f64,
}

/// The mean linear brightness the auto-exposure aims at (mid-gray).
pub const AUTO_EXPOSURE_TARGET: f64 = 0.45;

impl Default for NoiseConfig {
    /// Mild noise independent from pixel to pixel: [`Sensor::Ideal`].
    fn default() -> Self {
        Self {
            depth_noise: true,
            depth_model: DepthModel::Independent,
            holes: true,
            hole_blobs: 3.0,
            grazing_deg: 75.0,
            grazing_ramp_deg: 0.0,
            max_depth_m: 8.0,
            shadows: false,
            edge_dropout: 0.0,
            image_sigma: 2.0,
            exposure: 0.08,
            auto_exposure_s: 0.0,
            vignetting: 0.0,
        }
    }
}

impl NoiseConfig {
    /// No noise at all: exact depth (not quantised), clean images, constant exposure.
    pub fn none() -> Self {
        Self {
            depth_noise: false,
            holes: false,
            image_sigma: 0.0,
            exposure: 0.0,
            ..Self::default()
        }
    }

    /// The effects of `sensor` (see [`crate::sensor`] for the figures): the depth
    /// model, shadows and dropouts of its kind; auto-exposure and vignetting for the
    /// real cameras instead of the ideal sensor's exposure drift.
    pub fn of(sensor: Sensor) -> Self {
        let real = Self {
            depth_model: sensor.depth_model(),
            grazing_ramp_deg: 15.0,
            shadows: sensor.depth_model().baseline_m() > 0.0,
            edge_dropout: 0.5,
            exposure: 0.0,
            auto_exposure_s: 0.3,
            vignetting: 0.3,
            ..Self::default()
        };
        match sensor {
            Sensor::Ideal => Self::default(),
            Sensor::KinectV1 => Self {
                image_sigma: 2.5,
                ..real
            },
            Sensor::RealSense => Self {
                max_depth_m: 10.0,
                edge_dropout: 0.3,
                auto_exposure_s: 0.2,
                vignetting: 0.2,
                ..real
            },
            Sensor::Tof => Self {
                max_depth_m: 5.0,
                grazing_deg: 80.0,
                vignetting: 0.2,
                ..real
            },
        }
    }
}

/// A random elliptic blob of missing depth with a ragged outline.
struct Blob {
    x: f64,
    y: f64,
    rx: f64,
    ry: f64,
    seed: u64,
}

impl Blob {
    fn contains(&self, x: f64, y: f64) -> bool {
        let (dx, dy) = ((x - self.x) / self.rx, (y - self.y) / self.ry);
        // The ragged outline stays within 1.3 radii: skip the noise outside.
        if dx.abs() > 1.3 || dy.abs() > 1.3 {
            return false;
        }
        let ragged = 1.0 + 0.6 * (value_noise(self.seed, x * 0.3, y * 0.3) - 0.5);
        dx * dx + dy * dy < ragged * ragged
    }
}

/// What a frame's sensor effects depend on besides its clean render.
pub(crate) struct FrameSettings {
    /// Seed of the sequence.
    pub seed: u64,
    /// Frame index.
    pub frame: usize,
    /// Seconds since the first frame (the drift of the correlated depth error).
    pub time_s: f64,
    /// Exposure gain.
    pub gain: f64,
    /// Focal length of the rendered camera, pixels (the width of shadows).
    pub fx: f64,
}

/// Relative depth step that makes two neighbouring pixels a discontinuity.
const EDGE_JUMP: f32 = 0.05;

/// Turns a clean render into the sensor's images, deterministic for `(seed, frame)`.
pub(crate) fn apply(
    clean: &RenderBuffers,
    noise: &NoiseConfig,
    settings: &FrameSettings,
    rgb: &mut RgbImage,
    depth: &mut DepthImage,
) {
    let (w, h) = (clean.width, clean.height);
    rgb.resize(w, h);
    depth.resize(w, h);
    if w == 0 || h == 0 {
        return;
    }
    let (seed, frame) = (settings.seed, settings.frame as u64);
    let blobs = if noise.holes {
        blobs(noise, w, h, seed, frame)
    } else {
        Vec::new()
    };
    let shadows = shadow_mask(clean, noise, settings.fx);
    let field = match &noise.depth_model {
        DepthModel::Triangulation(t) if noise.depth_noise => {
            Some(FieldFrame::new(&t.field, seed, settings.time_s, w, h))
        }
        DepthModel::TimeOfFlight(t) if noise.depth_noise => {
            Some(FieldFrame::new(&t.field, seed, settings.time_s, w, h))
        }
        _ => None,
    };
    let cos_grazing = noise.grazing_deg.to_radians().cos() as f32;
    let ramp_start = (noise.grazing_deg - noise.grazing_ramp_deg).to_radians();
    let ramp_width = noise.grazing_ramp_deg.to_radians();
    let gain = settings.gain as f32;
    let vignette = Vignette::new(noise.vignetting, w, h);
    let flying = matches!(noise.depth_model, DepthModel::TimeOfFlight(_));
    let tasks: Vec<_> = rgb
        .as_mut_slice()
        .chunks_mut(w)
        .zip(depth.as_mut_slice().chunks_mut(w))
        .enumerate()
        .collect();
    for_each_parallel(tasks, |(y, (rgb_row, depth_row))| {
        let base = y * w;
        let mut pixel_rng = SplitMix64::keyed(seed, &[frame, y as u64, 0]);
        for (x, out) in rgb_row.iter_mut().enumerate() {
            let c = clean.colour[base + x];
            let gain = gain * vignette.at(x, y);
            *out = [0, 1, 2].map(|k| {
                let noise_levels = if noise.image_sigma > 0.0 {
                    (noise.image_sigma * pixel_rng.approx_gaussian()) as f32
                } else {
                    0.0
                };
                to_u8(c[k] * gain + noise_levels / 255.0)
            });
        }
        let mut depth_rng = SplitMix64::keyed(seed, &[frame, y as u64, 1]);
        let mut effect_rng = SplitMix64::keyed(seed, &[frame, y as u64, 3]);
        for (x, out) in depth_row.iter_mut().enumerate() {
            let mut z = clean.depth[base + x];
            *out = z;
            if z <= 0.0 {
                continue;
            }
            let (xf, yf) = (x as f64, y as f64);
            let cos = clean.cos_incidence[base + x];
            if noise.holes
                && (cos < cos_grazing
                    || f64::from(z) > noise.max_depth_m
                    || blobs.iter().any(|b| b.contains(xf, yf)))
            {
                *out = 0.0;
                continue;
            }
            if noise.holes && ramp_width > 0.0 {
                let beyond = (f64::from(cos).clamp(-1.0, 1.0).acos() - ramp_start) / ramp_width;
                if beyond > 0.0 && effect_rng.uniform() < beyond * beyond {
                    *out = 0.0;
                    continue;
                }
            }
            if noise.holes && shadows.as_ref().is_some_and(|s| s[base + x]) {
                *out = 0.0;
                continue;
            }
            if noise.edge_dropout > 0.0
                && let Some(across) = edge_neighbour(&clean.depth, w, h, x, y)
                && effect_rng.uniform() < noise.edge_dropout
            {
                if flying && noise.depth_noise {
                    z += (across - z) * effect_rng.uniform() as f32;
                } else if !flying && noise.holes {
                    *out = 0.0;
                    continue;
                }
            }
            if !noise.depth_noise {
                *out = z;
                continue;
            }
            let z = f64::from(z);
            let noisy = match &noise.depth_model {
                DepthModel::Independent => z + DEPTH_SIGMA_PER_Z2 * z * z * depth_rng.gaussian(),
                DepthModel::Triangulation(t) => {
                    let fb = t.focal_px * t.baseline_m;
                    let error = t.pixel_sigma_px * depth_rng.gaussian()
                        + field.as_ref().map_or(0.0, |f| f.at(x, y));
                    let disparity = quantise(fb / z + error, t.step_px);
                    if disparity <= 0.0 {
                        *out = 0.0;
                        continue;
                    }
                    fb / disparity
                }
                DepthModel::TimeOfFlight(t) => {
                    let relative = t.pixel_sigma_rel * depth_rng.gaussian()
                        + field.as_ref().map_or(0.0, |f| f.at(x, y));
                    quantise(z * (1.0 + relative), t.step_m)
                }
            };
            *out = ((noisy * DEPTH_SCALE).round() / DEPTH_SCALE).max(0.0) as f32;
        }
    });
}

/// `v` rounded to the nearest multiple of `step` (`v` itself for a step of 0).
fn quantise(v: f64, step: f64) -> f64 {
    if step > 0.0 {
        (v / step).round() * step
    } else {
        v
    }
}

/// The pixels in the shadow of the depth model's second viewpoint (see
/// [`shadow_row`]), when shadows are on and the model has a baseline.
fn shadow_mask(clean: &RenderBuffers, noise: &NoiseConfig, fx: f64) -> Option<Vec<bool>> {
    let baseline = noise.depth_model.baseline_m();
    if !(noise.holes && noise.shadows && baseline > 0.0) {
        return None;
    }
    let mut mask = vec![false; clean.depth.len()];
    for (row, out) in clean
        .depth
        .chunks(clean.width)
        .zip(mask.chunks_mut(clean.width))
    {
        shadow_row(row, fx, baseline, out);
    }
    Some(mask)
}

/// The depth of the 4-neighbour of (`x`, `y`) across a discontinuity (the most
/// different one), if any.
fn edge_neighbour(depth: &[f32], w: usize, h: usize, x: usize, y: usize) -> Option<f32> {
    let z = depth[y * w + x];
    let mut best: Option<f32> = None;
    let mut check = |n: f32| {
        if n > 0.0
            && (n - z).abs() > EDGE_JUMP * z
            && best.is_none_or(|b| (n - z).abs() > (b - z).abs())
        {
            best = Some(n);
        }
    };
    if x > 0 {
        check(depth[y * w + x - 1]);
    }
    if x + 1 < w {
        check(depth[y * w + x + 1]);
    }
    if y > 0 {
        check(depth[(y - 1) * w + x]);
    }
    if y + 1 < h {
        check(depth[(y + 1) * w + x]);
    }
    best
}

/// Brightness falloff towards the corners: `1 - v r^2 / r_corner^2` about the centre.
struct Vignette {
    strength: f32,
    centre: (f32, f32),
    inverse_corner2: f32,
}

impl Vignette {
    fn new(strength: f64, w: usize, h: usize) -> Self {
        let centre = ((w as f32 - 1.0) / 2.0, (h as f32 - 1.0) / 2.0);
        let corner2 = (centre.0 * centre.0 + centre.1 * centre.1).max(1.0);
        Self {
            strength: strength as f32,
            centre,
            inverse_corner2: 1.0 / corner2,
        }
    }

    #[inline]
    fn at(&self, x: usize, y: usize) -> f32 {
        if self.strength == 0.0 {
            return 1.0;
        }
        let (dx, dy) = (x as f32 - self.centre.0, y as f32 - self.centre.1);
        1.0 - self.strength * (dx * dx + dy * dy) * self.inverse_corner2
    }
}

/// The hole blobs of one frame: a seeded count around `noise.hole_blobs`.
fn blobs(noise: &NoiseConfig, w: usize, h: usize, seed: u64, frame: u64) -> Vec<Blob> {
    let mut rng = SplitMix64::keyed(seed, &[frame, 2]);
    let count = (noise.hole_blobs.max(0.0) * 2.0 * rng.uniform()).round() as usize;
    let scale = w as f64 / 640.0;
    (0..count)
        .map(|_| Blob {
            x: rng.range(0.0, w as f64),
            y: rng.range(0.0, h as f64),
            rx: rng.range(4.0, 24.0) * scale,
            ry: rng.range(4.0, 24.0) * scale,
            seed: rng.next_u64(),
        })
        .collect()
}
