//! [`LineExtractor`]: the whole line front end of one frame, section III-A and III-B:
//! EDLines detection -> joining -> grid + homogenisation -> LBD -> 3D lines.

use crate::DetectedLine;
use crate::detect::{DetectConfig, LineDetector};
use crate::grid::{GridConfig, LineGrid};
use crate::homogenise::{HomogeniseConfig, Homogeniser};
use crate::lbd::{LbdConfig, LbdDescriptor, LbdExtractor};
use crate::lines3d::{Line3, Line3Estimator, Lines3dConfig};
use gfs_core::ImageView;
use gfs_core::camera::PinholeCamera;
use serde::Deserialize;
use std::time::{Duration, Instant};

/// The `[lines]` table of the config file: one sub-table per step.
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LineConfig {
    /// `[lines.detect]`: EDLines and joining.
    pub detect: DetectConfig,
    /// `[lines.grid]`: the cell size of the grid index.
    pub grid: GridConfig,
    /// `[lines.homogenise]`: scheme and target.
    pub homogenise: HomogeniseConfig,
    /// `[lines.lbd]`: the descriptor.
    pub lbd: LbdConfig,
    /// `[lines.lines3d]`: the 3D line fit.
    pub lines3d: Lines3dConfig,
}

/// The line features of one frame as parallel arrays (index `i` of every array is line
/// `i`), reused between frames.
#[derive(Clone, Debug, Default)]
pub struct LineFeatures {
    /// Kept lines (after homogenisation), pixels of the undistorted image.
    pub lines: Vec<DetectedLine>,
    /// LBD descriptor of each line.
    pub descriptors: Vec<LbdDescriptor>,
    /// 3D line of each line in the camera frame (check [`Line3::is_valid`]).
    pub lines3d: Vec<Line3>,
}

impl LineFeatures {
    /// Number of lines.
    pub fn len(&self) -> usize {
        self.lines.len()
    }

    /// True when there is no line.
    pub fn is_empty(&self) -> bool {
        self.lines.is_empty()
    }

    /// Empties every array, keeping the storage.
    pub fn clear(&mut self) {
        self.lines.clear();
        self.descriptors.clear();
        self.lines3d.clear();
    }
}

/// Wall-clock time of each step of the last [`LineExtractor::extract`] call.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LineTimings {
    /// EDLines detection (smoothing, gradients, edge drawing, fitting, validation).
    pub detect: Duration,
    /// Joining of broken segments.
    pub join: Duration,
    /// Grid index and homogenisation.
    pub homogenise: Duration,
    /// LBD descriptors of the kept lines.
    pub lbd: Duration,
    /// 3D lines of the kept lines.
    pub lines3d: Duration,
}

impl LineTimings {
    /// Sum of the steps.
    pub fn total(&self) -> Duration {
        self.detect + self.join + self.homogenise + self.lbd + self.lines3d
    }
}

/// Line counts of the last [`LineExtractor::extract`] call.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LineCounts {
    /// Lines after detection and joining, before homogenisation.
    pub detected: usize,
    /// Lines kept by the homogenisation.
    pub kept: usize,
}

/// Extracts the line features of frames; owns the detector, the grid and every scratch
/// buffer, so that a warm extractor does not allocate.
///
/// ```
/// use gfs_core::{Image, camera::PinholeCamera};
/// use gfs_lines::extractor::{LineConfig, LineExtractor, LineFeatures};
/// let mut gray = Image::new(160, 120);
/// for v in 30..90 {
///     for u in 40..120 {
///         gray.set(u, v, 200u8);
///     }
/// }
/// let mut depth = Image::new(160, 120);
/// depth.fill(2.0f32);
/// let camera = PinholeCamera::new(150.0, 150.0, 79.5, 59.5, 160, 120);
/// let mut extractor = LineExtractor::new(LineConfig::default());
/// let mut features = LineFeatures::default();
/// extractor.extract(&gray.view(), &depth.view(), &camera, &mut features);
/// assert_eq!(features.len(), 4);
/// assert!(features.lines3d.iter().all(|l| l.is_valid() && (l.start[2] - 2.0).abs() < 0.01));
/// ```
#[derive(Debug)]
pub struct LineExtractor {
    config: LineConfig,
    detector: LineDetector,
    grid: LineGrid,
    homogeniser: Homogeniser,
    lbd: LbdExtractor,
    estimator: Line3Estimator,
    detected: Vec<DetectedLine>,
    keep: Vec<u32>,
    timings: LineTimings,
    counts: LineCounts,
}

impl LineExtractor {
    /// An extractor with `config`; buffers are allocated on the first frame.
    pub fn new(config: LineConfig) -> Self {
        Self {
            detector: LineDetector::new(config.detect.clone()),
            grid: LineGrid::new(&config.grid),
            homogeniser: Homogeniser::new(config.homogenise.clone()),
            lbd: LbdExtractor::new(config.lbd.clone()),
            estimator: Line3Estimator::new(config.lines3d.clone()),
            config,
            detected: Vec::new(),
            keep: Vec::new(),
            timings: LineTimings::default(),
            counts: LineCounts::default(),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &LineConfig {
        &self.config
    }

    /// Runs detection, joining, homogenisation, LBD and 3D lines on one frame and
    /// writes the kept lines into `out` (cleared first). `depth` (metres, 0 = missing) is
    /// registered with `gray`; both are undistorted images of `camera`. A depth image
    /// of another size gives invalid 3D lines, never a panic.
    pub fn extract(
        &mut self,
        gray: &ImageView<'_, u8>,
        depth: &ImageView<'_, f32>,
        camera: &PinholeCamera,
        out: &mut LineFeatures,
    ) {
        out.clear();
        let t0 = Instant::now();
        self.detector.detect(gray, &mut self.detected);
        let t1 = Instant::now();
        self.detector.join(&mut self.detected);
        let t2 = Instant::now();

        // Grid + homogenisation (section III-B); the grid is then rebuilt over the
        // kept lines so that it indexes `out.lines` for the tracker.
        let (w, h) = (gray.width(), gray.height());
        self.grid
            .build(w, h, self.detected.iter().map(|l| &l.segment));
        self.homogeniser
            .select(&self.detected, &self.grid, &mut self.keep);
        out.lines
            .extend(self.keep.iter().map(|&i| self.detected[i as usize]));
        self.grid.build(w, h, out.lines.iter().map(|l| &l.segment));
        let t3 = Instant::now();

        let (gx, gy) = (self.detector.gradient_x(), self.detector.gradient_y());
        self.lbd.describe(
            &gx,
            &gy,
            out.lines.iter().map(|l| &l.segment),
            &mut out.descriptors,
        );
        let t4 = Instant::now();
        self.estimator.estimate(
            depth,
            camera,
            out.lines.iter().map(|l| &l.segment),
            &mut out.lines3d,
        );
        let t5 = Instant::now();

        self.timings = LineTimings {
            detect: t1 - t0,
            join: t2 - t1,
            homogenise: t3 - t2,
            lbd: t4 - t3,
            lines3d: t5 - t4,
        };
        self.counts = LineCounts {
            detected: self.detected.len(),
            kept: out.lines.len(),
        };
    }

    /// Step timings of the last [`LineExtractor::extract`] call.
    pub fn timings(&self) -> LineTimings {
        self.timings
    }

    /// Line counts of the last [`LineExtractor::extract`] call.
    pub fn counts(&self) -> LineCounts {
        self.counts
    }

    /// Every line of the last frame before homogenisation (after joining).
    pub fn detected_lines(&self) -> &[DetectedLine] {
        &self.detected
    }

    /// The grid index of the kept lines of the last frame (line `i` = `out.lines[i]`).
    pub fn grid(&self) -> &LineGrid {
        &self.grid
    }
}
