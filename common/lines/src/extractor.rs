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
use serde::{Deserialize, Serialize};
use std::time::{Duration, Instant};

/// The `[lines]` table of the config file: one sub-table per step.
#[derive(Clone, Debug, Default, PartialEq, Deserialize, Serialize)]
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Segment;
    use crate::fixtures::{H, Rng, Scene, W, Warp, render};
    use gfs_core::Image;
    use gfs_core::descriptor::hamming;

    fn camera() -> PinholeCamera {
        PinholeCamera::new(525.0, 525.0, 319.5, 239.5, W, H)
    }

    /// Line `i` of `q`'s nearest line of `t` by LBD distance among those within 30
    /// degrees, when within 80 bits and clearly better than the runner-up (ratio 0.8).
    fn nearest(q: &LineFeatures, t: &LineFeatures, i: usize) -> Option<usize> {
        let max_angle = 30f32.to_radians();
        let (mut best, mut second, mut best_j) = (u32::MAX, u32::MAX, usize::MAX);
        for (j, line) in t.lines.iter().enumerate() {
            let diff = (q.lines[i].segment.angle() - line.segment.angle())
                .rem_euclid(std::f32::consts::PI);
            if diff.min(std::f32::consts::PI - diff) > max_angle {
                continue;
            }
            let d = hamming(&q.descriptors[i], &t.descriptors[j]);
            if d < best {
                (second, best, best_j) = (best, d, j);
            } else if d < second {
                second = d;
            }
        }
        let clear = second == u32::MAX || (best as f32) < 0.8 * second as f32;
        (best <= 80 && clear).then_some(best_j)
    }

    /// Lines that are each other's nearest: what the descriptor alone can match.
    fn mutual_matches(a: &LineFeatures, b: &LineFeatures) -> Vec<(usize, usize)> {
        (0..a.len())
            .filter_map(|i| {
                let j = nearest(a, b, i)?;
                (nearest(b, a, j) == Some(i)).then_some((i, j))
            })
            .collect()
    }

    fn segments(f: &LineFeatures) -> Vec<Segment> {
        f.lines.iter().map(|l| l.segment).collect()
    }

    /// Same physical line: `b` lies within 2 px of the line of `a` (both ways), the
    /// directions agree within 3 degrees, and the two overlap along the line.
    fn same_line(a: &Segment, b: &Segment) -> bool {
        let dist = |s: &Segment, p: [f32; 2]| {
            let [ca, cb, cc] = s.line_coefficients();
            (ca * p[0] + cb * p[1] + cc).abs()
        };
        let (da, db) = (a.angle(), b.angle());
        let diff = (da - db).rem_euclid(std::f32::consts::PI);
        let angle = diff.min(std::f32::consts::PI - diff).to_degrees();
        let along = |p: [f32; 2]| {
            let (du, dv) = (a.end[0] - a.start[0], a.end[1] - a.start[1]);
            ((p[0] - a.start[0]) * du + (p[1] - a.start[1]) * dv) / (du * du + dv * dv)
        };
        let (t0, t1) = (along(b.start), along(b.end));
        let overlap = t0.max(t1) > 0.0 && t0.min(t1) < 1.0;
        dist(a, b.midpoint()) < 2.0 && dist(b, a.midpoint()) < 2.0 && angle < 3.0 && overlap
    }

    #[test]
    fn detected_lines_match_across_a_known_warp() {
        let mut rng = Rng(5);
        let scene = Scene::new(&mut rng);
        let identity = Warp {
            angle: 0.0,
            scale: 1.0,
            t: [0.0, 0.0],
        };
        let warp = Warp {
            angle: 4f32.to_radians(),
            scale: 1.05,
            t: [10.0, 6.0],
        };
        let (img1, img2) = (
            render(&scene, &identity, &mut rng),
            render(&scene, &warp, &mut rng),
        );
        let depth = Image::<f32>::new(W, H);
        // Every line is kept: this measures the descriptor, not the homogenisation
        // (which may keep different lines of a dense area in the two frames).
        let mut config = LineConfig::default();
        config.homogenise.scheme = crate::homogenise::HomogeniseScheme::None;
        let mut extractor = LineExtractor::new(config);
        let (mut f1, mut f2) = (LineFeatures::default(), LineFeatures::default());
        extractor.extract(&img1.view(), &depth.view(), &camera(), &mut f1);
        let counts = extractor.counts();
        extractor.extract(&img2.view(), &depth.view(), &camera(), &mut f2);
        assert!(counts.kept <= counts.detected && counts.kept == f1.len());
        assert_eq!(
            (f1.descriptors.len(), f1.lines3d.len()),
            (f1.len(), f1.len())
        );
        // No depth at all: every 3D line is invalid.
        assert!(f1.lines3d.iter().all(|l| !l.is_valid()));
        let (s1, s2) = (segments(&f1), segments(&f2));
        let matches = mutual_matches(&f1, &f2);
        let correct = matches
            .iter()
            .filter(|&&(i, j)| {
                let s = &s1[i];
                let warped = Segment {
                    start: warp.apply(s.start),
                    end: warp.apply(s.end),
                };
                same_line(&warped, &s2[j])
            })
            .count();
        println!(
            "{} / {} lines detected, {} / {} kept, {} matches, {correct} correct",
            counts.detected,
            extractor.counts().detected,
            f1.len(),
            f2.len(),
            matches.len()
        );
        assert!(f1.len() >= 100, "{} lines kept", f1.len());
        assert!(matches.len() * 2 >= f1.len(), "{} matches", matches.len());
        assert!(correct as f32 >= 0.9 * matches.len() as f32);
    }

    #[test]
    fn empty_tiny_constant_and_saturated_images_do_not_panic() {
        let mut extractor = LineExtractor::new(LineConfig::default());
        let mut out = LineFeatures::default();
        let cam = camera();
        for (w, h, value) in [
            (0, 0, 0u8),
            (1, 1, 0),
            (2, 3, 255),
            (64, 48, 128),
            (64, 48, 255),
        ] {
            let mut gray = Image::new(w, h);
            gray.fill(value);
            let depth = Image::<f32>::new(w, h);
            extractor.extract(&gray.view(), &depth.view(), &cam, &mut out);
            assert!(out.is_empty(), "{w}x{h} of {value}");
            assert_eq!(extractor.counts(), LineCounts::default());
        }
        // A depth image of the wrong size gives invalid 3D lines, not a panic.
        let mut gray = Image::new(160, 120);
        for v in 30..90 {
            for u in 40..120 {
                gray.set(u, v, 255u8);
            }
        }
        let depth = Image::<f32>::new(10, 10);
        extractor.extract(&gray.view(), &depth.view(), &cam, &mut out);
        assert_eq!(out.len(), 4);
        assert!(out.lines3d.iter().all(|l| !l.is_valid()));
        assert_eq!(extractor.grid().line_count(), 4);
    }

    #[test]
    fn config_parses_from_toml_sub_tables() {
        let text = "[homogenise]\nscheme = \"midpoint\"\nmin_lines = 10\n[grid]\ncell_size = 32\n";
        let config: LineConfig = toml::from_str(text).unwrap();
        assert_eq!(config.grid.cell_size, 32);
        assert_eq!(
            config.homogenise.scheme,
            crate::homogenise::HomogeniseScheme::Midpoint
        );
        assert_eq!(config.lbd, LbdConfig::default());
        assert!(toml::from_str::<LineConfig>("[grid]\ncells = 3\n").is_err());
        // The defaults written out read back unchanged (a full `[lines]` table).
        let written = toml::to_string(&LineConfig::default()).unwrap();
        assert_eq!(
            toml::from_str::<LineConfig>(&written).unwrap(),
            LineConfig::default()
        );
    }
}
