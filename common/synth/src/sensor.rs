//! The depth cameras `gfsvo synth` imitates, with the figures each is built from.
//!
//! A structured-light or stereo camera measures *disparity*, `d = f b / z` pixels for a
//! focal length `f` and a baseline `b`, and its error is a disparity error: a per-pixel
//! part, a smooth part correlated across the image that drifts slowly from frame to
//! frame (calibration residue, temperature, the matching window), and the quantisation
//! of the disparity to a fraction of a pixel. In depth, each grows with `z^2 / (f b)`.
//! The second viewpoint (the projector, or the second imager) sits `b` to the camera's
//! right (+x), so what it cannot see beside a foreground edge has no depth: a shadow on
//! the edge's left. A time-of-flight camera measures the phase of light it sends
//! itself: its error grows with the depth, not its square, it has no shadow, and a pixel
//! straddling an edge mixes the two depths (a flying pixel).
//!
//! Figures, from public sources:
//! - Kinect v1 (structured light): 7.5 cm baseline, IR focal length about 580 px at
//!   640x480, disparity in 1/8 px steps (Khoshelham & Elberink 2012, "Accuracy and
//!   resolution of Kinect depth data", Sensors 12(2); Smisek et al. 2011, "3D with
//!   Kinect"), axial error `1.425e-3 z^2` m (Khoshelham & Elberink), which fixes the
//!   total disparity error at 0.062 px. Most of it is spatially smooth (the disparity
//!   distortion pattern of Herrera et al. 2012, "Joint depth and color camera
//!   calibration with distortion correction", PAMI 34(10)): here 0.045 px smooth,
//!   0.02 px per pixel, the rest the 1/8 px steps.
//! - RealSense D435 (active stereo): 50 mm baseline, 0.08 px subpixel matching error,
//!   depth RMS `z^2 * 0.08 / (f b)` (Intel, "Tuning depth cameras for best performance",
//!   Grunnet-Jepsen et al.; D400 datasheet), focal length about 385 px at 640x480
//!   (87 deg horizontal field of view at 16:9, cropped to 4:3); the disparity steps are
//!   taken as 1/32 px (5 fractional bits, an assumption). The matching window
//!   correlates the error: 0.065 px smooth, 0.045 px per pixel.
//! - Time of flight (Kinect v2 / Azure Kinect like): random error about 0.15 % of the
//!   depth (Fankhauser et al. 2015, "Kinect v2 for mobile robot navigation: evaluation
//!   and modeling"; Azure Kinect DK datasheet: random error <= 17 mm, systematic
//!   < 11 mm + 0.1 % of the distance), here 0.15 % per pixel and a smooth 0.1 %,
//!   millimetre steps, flying pixels at depth edges. Multipath in concave corners is not
//!   modelled.

use crate::rng::SplitMix64;
use serde::Deserialize;
use std::f64::consts::TAU;
use std::fmt;

/// The camera a sequence is rendered with.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Sensor {
    /// Depth error independent from pixel to pixel and from frame to frame,
    /// `1.425e-3 z^2` m: the idealised sensor that `configs/synthetic.toml` and the
    /// end-to-end tests were tuned on (the library's default).
    #[default]
    Ideal,
    /// Structured light like the Kinect v1: correlated disparity error, 1/8 px steps,
    /// projector shadows, auto-exposure, vignetting (`gfsvo synth`'s default).
    KinectV1,
    /// Active stereo like the RealSense D435.
    RealSense,
    /// Time of flight like the Kinect v2 / Azure Kinect.
    Tof,
}

impl Sensor {
    /// All sensors, in CLI order.
    pub const ALL: [Sensor; 4] = [
        Sensor::Ideal,
        Sensor::KinectV1,
        Sensor::RealSense,
        Sensor::Tof,
    ];

    /// The CLI name (`ideal`, `kinect-v1`, `realsense`, `tof`).
    pub fn name(self) -> &'static str {
        match self {
            Sensor::Ideal => "ideal",
            Sensor::KinectV1 => "kinect-v1",
            Sensor::RealSense => "realsense",
            Sensor::Tof => "tof",
        }
    }

    /// How the sensor's depth error is formed.
    pub fn depth_model(self) -> DepthModel {
        match self {
            Sensor::Ideal => DepthModel::Independent,
            Sensor::KinectV1 => DepthModel::Triangulation(Triangulation {
                focal_px: 580.0,
                baseline_m: 0.075,
                pixel_sigma_px: 0.02,
                field: CorrelatedField {
                    sigma: 0.045,
                    ..CorrelatedField::default()
                },
                step_px: 1.0 / 8.0,
            }),
            Sensor::RealSense => DepthModel::Triangulation(Triangulation {
                focal_px: 385.0,
                baseline_m: 0.05,
                pixel_sigma_px: 0.045,
                field: CorrelatedField {
                    sigma: 0.065,
                    ..CorrelatedField::default()
                },
                step_px: 1.0 / 32.0,
            }),
            Sensor::Tof => DepthModel::TimeOfFlight(TimeOfFlight {
                pixel_sigma_rel: 0.0015,
                field: CorrelatedField {
                    sigma: 0.001,
                    ..CorrelatedField::default()
                },
                step_m: 0.001,
            }),
        }
    }
}

impl fmt::Display for Sensor {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// How the depth error of a sensor is formed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum DepthModel {
    /// Independent gaussian error `DEPTH_SIGMA_PER_Z2 z^2` m per pixel and frame,
    /// then the 1/5000 m steps of the written depth.
    #[default]
    Independent,
    /// A disparity measurement (structured light, stereo).
    Triangulation(Triangulation),
    /// A phase measurement (time of flight).
    TimeOfFlight(TimeOfFlight),
}

impl DepthModel {
    /// The baseline to the second viewpoint, metres (0: none, no shadows).
    pub fn baseline_m(&self) -> f64 {
        match self {
            DepthModel::Triangulation(t) => t.baseline_m,
            _ => 0.0,
        }
    }

    /// The standard deviation of the depth error at `z` metres, from the model's
    /// parts (quantisation counted as a uniform error of one step).
    pub fn sigma_at(&self, z: f64) -> f64 {
        match self {
            DepthModel::Independent => crate::noise::DEPTH_SIGMA_PER_Z2 * z * z,
            DepthModel::Triangulation(t) => {
                let disparity =
                    (t.pixel_sigma_px.powi(2) + t.field.sigma.powi(2) + t.step_px.powi(2) / 12.0)
                        .sqrt();
                disparity * z * z / (t.focal_px * t.baseline_m)
            }
            DepthModel::TimeOfFlight(t) => {
                ((t.pixel_sigma_rel.powi(2) + t.field.sigma.powi(2)) * z * z
                    + t.step_m.powi(2) / 12.0)
                    .sqrt()
            }
        }
    }
}

/// Disparity error of a structured-light or stereo camera.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Triangulation {
    /// Focal length of the camera the disparity is measured in, pixels.
    pub focal_px: f64,
    /// Distance to the second viewpoint (projector or second imager), metres, along +x.
    pub baseline_m: f64,
    /// Independent disparity error per pixel, pixels.
    pub pixel_sigma_px: f64,
    /// Smooth disparity error, pixels.
    pub field: CorrelatedField,
    /// Disparity steps, pixels.
    pub step_px: f64,
}

/// Depth error of a time-of-flight camera.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimeOfFlight {
    /// Independent error per pixel, relative to the depth.
    pub pixel_sigma_rel: f64,
    /// Smooth error, relative to the depth.
    pub field: CorrelatedField,
    /// Depth steps, metres.
    pub step_m: f64,
}

/// A smooth, stationary random field over the image that drifts with time: the sum
/// of [`WAVES`] plane waves of random direction, wavelength and phase, each phase
/// turning at its own slow rate. Its standard deviation is `sigma`, the correlation
/// of two pixels `r` apart the mean of `cos(k . r)` over the waves (about 0.8 at 8 px
/// for the default wavelengths), and of one pixel `t` seconds apart the mean of
/// `cos(2 pi t / period)`.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CorrelatedField {
    /// Standard deviation, in the unit of the error it adds to.
    pub sigma: f64,
    /// Shortest wavelength at 640 px image width (scaled with the width), pixels;
    /// wavelengths are drawn up to three times it. Default 64.
    pub wavelength_px: f64,
    /// Shortest period of a wave's phase, seconds; periods are drawn up to three times
    /// it. Default 4.
    pub period_s: f64,
}

impl Default for CorrelatedField {
    fn default() -> Self {
        Self {
            sigma: 0.0,
            wavelength_px: 64.0,
            period_s: 4.0,
        }
    }
}

/// Waves of a [`CorrelatedField`]: enough for a near-gaussian sum.
pub const WAVES: usize = 24;
/// Spacing of the grid the field is evaluated on before bilinear interpolation, px.
const FIELD_GRID: usize = 4;

/// One frame's [`CorrelatedField`], sampled on a coarse grid.
pub(crate) struct FieldFrame {
    grid: Vec<f32>,
    columns: usize,
}

impl FieldFrame {
    /// The field of `seed` at time `t` seconds for a `width` x `height` image.
    pub fn new(field: &CorrelatedField, seed: u64, t: f64, width: usize, height: usize) -> Self {
        let columns = width / FIELD_GRID + 2;
        let rows = height / FIELD_GRID + 2;
        let mut rng = SplitMix64::keyed(seed, &[0x66_6965_6c64]);
        let scale = width as f64 / 640.0;
        let amplitude = field.sigma * (2.0 / WAVES as f64).sqrt();
        let waves: Vec<[f64; 3]> = (0..WAVES)
            .map(|_| {
                let angle = rng.range(0.0, TAU);
                let wavelength = field.wavelength_px * scale * rng.range(1.0, 3.0);
                let k = TAU / wavelength.max(1e-9);
                let period = field.period_s * rng.range(1.0, 3.0);
                let phase = rng.range(0.0, TAU) + TAU * t / period.max(1e-9);
                [k * angle.cos(), k * angle.sin(), phase]
            })
            .collect();
        let mut grid = Vec::with_capacity(columns * rows);
        for j in 0..rows {
            for i in 0..columns {
                let (x, y) = ((i * FIELD_GRID) as f64, (j * FIELD_GRID) as f64);
                let sum: f64 = waves
                    .iter()
                    .map(|w| (w[0] * x + w[1] * y + w[2]).cos())
                    .sum();
                grid.push((amplitude * sum) as f32);
            }
        }
        Self { grid, columns }
    }

    /// The field at pixel (`x`, `y`), bilinear between grid nodes.
    pub fn at(&self, x: usize, y: usize) -> f64 {
        let (i, j) = (x / FIELD_GRID, y / FIELD_GRID);
        let fx = (x % FIELD_GRID) as f32 / FIELD_GRID as f32;
        let fy = (y % FIELD_GRID) as f32 / FIELD_GRID as f32;
        let g = |i: usize, j: usize| self.grid[j * self.columns + i];
        let top = g(i, j) + (g(i + 1, j) - g(i, j)) * fx;
        let bottom = g(i, j + 1) + (g(i + 1, j + 1) - g(i, j + 1)) * fx;
        f64::from(top + (bottom - top) * fy)
    }
}

/// Marks in `shadow` the pixels of one row whose surface the second viewpoint,
/// `baseline_m` to the camera's right, cannot see: a pixel `x` at disparity `D(x) =
/// fx b / z` lands at `x - D(x)` in that view, and is hidden when a pixel to its right
/// lands at or left of it (the order of the two flips only behind an occluder).
pub(crate) fn shadow_row(depth: &[f32], fx: f64, baseline_m: f64, shadow: &mut [bool]) {
    // Half a pixel: a slanted surface's own samples never hide each other.
    const TOLERANCE_PX: f64 = 0.5;
    let mut leftmost = f64::INFINITY;
    for x in (0..depth.len()).rev() {
        let z = f64::from(depth[x]);
        shadow[x] = false;
        if z <= 0.0 {
            continue;
        }
        let landing = x as f64 - fx * baseline_m / z;
        shadow[x] = leftmost < landing - TOLERANCE_PX;
        leftmost = leftmost.min(landing);
    }
}
