//! Sensor effects applied on top of a clean render: Kinect-like depth noise and
//! quantisation, missing depth (random blobs, grazing angles, long range), gaussian
//! image noise and slow exposure (gain) drift.

use crate::render::{RenderBuffers, for_each_parallel, to_u8};
use crate::rng::SplitMix64;
use crate::texture::value_noise;
use gfs_core::{DepthImage, RgbImage};
use serde::Deserialize;

/// Depth noise model of the Kinect v1 (axial sigma grows with z^2, Khoshelham & Elberink
/// 2012): sigma = `DEPTH_SIGMA_PER_Z2 * z^2` metres.
pub const DEPTH_SIGMA_PER_Z2: f64 = 1.425e-3;
/// Depth written in TUM layout is in units of 1/5000 m: noisy depth is quantised to that.
pub const DEPTH_SCALE: f64 = 5000.0;

/// What sensor effects to simulate.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NoiseConfig {
    /// Kinect-like depth noise, sigma = 1.425e-3 * z^2 m, then quantisation to the
    /// 1/5000 m steps of the written depth. Default true.
    pub depth_noise: bool,
    /// Missing depth: random blobs, surfaces seen at more than `grazing_deg`, and
    /// anything farther than `max_depth_m`. Default true.
    pub holes: bool,
    /// Mean number of random missing-depth blobs per frame (4 to 24 px radius at 640 px
    /// width). Default 3.
    pub hole_blobs: f64,
    /// Incidence angle beyond which depth is missing, degrees. Default 75 (structured
    /// light fails at grazing angles).
    pub grazing_deg: f64,
    /// Range beyond which depth is missing, metres. Default 8 (Kinect v1 useful range).
    pub max_depth_m: f64,
    /// Standard deviation of (near-)gaussian image noise per channel, gray levels
    /// (0 = none). Default 2.
    pub image_sigma: f64,
    /// Amplitude of the slow exposure gain drift, relative (0 = constant exposure).
    /// Default 0.08: the gain wanders within [0.92, 1.08] over a few seconds.
    pub exposure: f64,
}

impl Default for NoiseConfig {
    /// Mild, realistic noise: what `gfsvo synth` writes by default.
    fn default() -> Self {
        Self {
            depth_noise: true,
            holes: true,
            hole_blobs: 3.0,
            grazing_deg: 75.0,
            max_depth_m: 8.0,
            image_sigma: 2.0,
            exposure: 0.08,
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

/// Turns a clean render into the sensor's images, deterministic for `(seed, frame)`.
pub(crate) fn apply(
    clean: &RenderBuffers,
    noise: &NoiseConfig,
    gain: f64,
    seed: u64,
    frame: usize,
    rgb: &mut RgbImage,
    depth: &mut DepthImage,
) {
    let (w, h) = (clean.width, clean.height);
    rgb.resize(w, h);
    depth.resize(w, h);
    if w == 0 || h == 0 {
        return;
    }
    let frame = frame as u64;
    let blobs = if noise.holes {
        blobs(noise, w, h, seed, frame)
    } else {
        Vec::new()
    };
    let cos_grazing = noise.grazing_deg.to_radians().cos() as f32;
    let gain = gain as f32;
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
        for (x, out) in depth_row.iter_mut().enumerate() {
            let z = clean.depth[base + x];
            *out = z;
            if z <= 0.0 {
                continue;
            }
            let (xf, yf) = (x as f64, y as f64);
            if noise.holes
                && (clean.cos_incidence[base + x] < cos_grazing
                    || f64::from(z) > noise.max_depth_m
                    || blobs.iter().any(|b| b.contains(xf, yf)))
            {
                *out = 0.0;
                continue;
            }
            if noise.depth_noise {
                let z = f64::from(z);
                let noisy = z + DEPTH_SIGMA_PER_Z2 * z * z * depth_rng.gaussian();
                *out = ((noisy * DEPTH_SCALE).round() / DEPTH_SCALE).max(0.0) as f32;
            }
        }
    });
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
