//! The ORB extractor: pyramid, FAST per cell with a retry threshold, quadtree
//! distribution under a per-level budget, orientation, steered BRIEF, depth lookup.

use crate::blur::GaussianBlur;
use crate::brief::{MAX_STRIDE, REACH, SteeredBrief};
use crate::config::{OrbConfig, OrbConfigError};
use crate::distribute::Distributor;
use crate::fast::{self, Corner, Rect};
use crate::keypoint::{KeyPoint, OrbFeatures};
use crate::keypoint_depth::keypoint_depth;
use crate::orientation::{Disc, HALF_PATCH};
use crate::pyramid::Pyramid;
use gfs_core::{GrayImage, ImageView};
use std::time::{Duration, Instant};
use thiserror::Error;

/// Keypoints keep this many pixels from the border of their level, so that the steered
/// pattern (`REACH` = 18) plus one pixel fits without padding (ORB-SLAM2 `EDGE_THRESHOLD`).
pub const EDGE: usize = 19;
const _: () = assert!(EDGE > REACH && EDGE > HALF_PATCH + 2 && EDGE > fast::RING_RADIUS + 1);

/// Smallest level side that still has a detection area.
const MIN_LEVEL_SIDE: usize = 2 * EDGE + 1;

/// A frame could not be processed.
#[derive(Debug, Error, PartialEq)]
pub enum OrbError {
    /// The depth image does not have the size of the gray image.
    #[error("depth image is {depth_width}x{depth_height}, gray image is {width}x{height}")]
    DepthSize {
        /// Gray width.
        width: usize,
        /// Gray height.
        height: usize,
        /// Depth width.
        depth_width: usize,
        /// Depth height.
        depth_height: usize,
    },
}

/// Wall-clock time of the steps of the last [`OrbExtractor::extract`] call.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct OrbTimings {
    /// Building levels 1.. of the pyramid.
    pub pyramid: Duration,
    /// FAST scores, cell retries, non-maximum suppression and quadtree distribution.
    pub detect: Duration,
    /// Orientation, Gaussian smoothing, descriptors and depth lookup.
    pub describe: Duration,
}

impl OrbTimings {
    /// Sum of the steps.
    pub fn total(&self) -> Duration {
        self.pyramid + self.detect + self.describe
    }
}

/// A selected corner of some level.
#[derive(Clone, Copy, Debug)]
struct Selected {
    level: u32,
    corner: Corner,
}

/// Scratch of the detection step (FAST, suppression, distribution).
#[derive(Debug)]
struct Detector {
    scores: GrayImage,
    hits: Vec<(u32, u32)>,
    corners: Vec<Corner>,
    cell_counts: Vec<u32>,
    distributor: Distributor,
    picked: Vec<u32>,
}

/// ORB feature extractor owning all per-frame scratch (pyramid, score map, smoothed
/// level, quadtree nodes), reused on every call. Single-threaded.
#[derive(Debug)]
pub struct OrbExtractor {
    config: OrbConfig,
    scales: Vec<f32>,
    budget: Vec<usize>,
    disc: Disc,
    pyramid: Pyramid,
    detector: Detector,
    smoothed: GrayImage,
    blur: GaussianBlur,
    brief: SteeredBrief,
    selected: Vec<Selected>,
    timings: OrbTimings,
}

impl OrbExtractor {
    /// An extractor for `config`.
    ///
    /// # Errors
    /// [`OrbConfigError`] naming the first invalid field.
    pub fn new(config: OrbConfig) -> Result<Self, OrbConfigError> {
        config.validate()?;
        Ok(Self {
            scales: (0..config.levels).map(|k| config.scale(k)).collect(),
            budget: config.features_per_level(),
            disc: Disc::default(),
            config,
            pyramid: Pyramid::default(),
            detector: Detector {
                scores: GrayImage::new(0, 0),
                hits: Vec::new(),
                corners: Vec::new(),
                cell_counts: Vec::new(),
                distributor: Distributor::default(),
                picked: Vec::new(),
            },
            smoothed: GrayImage::new(0, 0),
            blur: GaussianBlur::default(),
            brief: SteeredBrief::default(),
            selected: Vec::new(),
            timings: OrbTimings::default(),
        })
    }

    /// The configuration.
    pub fn config(&self) -> &OrbConfig {
        &self.config
    }

    /// Scale of each level relative to level 0 (`scale_factor^level`).
    pub fn scales(&self) -> &[f32] {
        &self.scales
    }

    /// Step timings of the last call to [`OrbExtractor::extract`].
    pub fn timings(&self) -> &OrbTimings {
        &self.timings
    }

    /// Extracts the features of `gray` into `out` (cleared first). With `depth` (metres,
    /// same size as `gray`), each keypoint gets the depth at its rounded pixel, or else at
    /// the nearest valid 3x3 neighbour, 0 when none is in the configured range.
    ///
    /// An image too small for one patch (under 39 pixels a side), empty, without texture
    /// or with an absurd row stride (over 2^26 pixels) gives an empty set.
    ///
    /// # Errors
    /// [`OrbError::DepthSize`] when `depth` does not have the size of `gray`.
    pub fn extract(
        &mut self,
        gray: ImageView<'_, u8>,
        depth: Option<ImageView<'_, f32>>,
        out: &mut OrbFeatures,
    ) -> Result<(), OrbError> {
        out.clear();
        self.timings = OrbTimings::default();
        if let Some(d) = depth
            && (d.width() != gray.width() || d.height() != gray.height())
        {
            return Err(OrbError::DepthSize {
                width: gray.width(),
                height: gray.height(),
                depth_width: d.width(),
                depth_height: d.height(),
            });
        }
        if gray.stride() > MAX_STRIDE {
            return Ok(());
        }
        let t0 = Instant::now();
        let levels = self.pyramid.build(gray, &self.scales, MIN_LEVEL_SIDE);
        let t1 = Instant::now();
        self.selected.clear();
        for level in 0..levels {
            let image = if level == 0 {
                gray
            } else {
                self.pyramid.level(level)
            };
            self.detector.detect_level(
                image,
                &self.config,
                self.budget[level],
                level,
                &mut self.selected,
            );
        }
        let t2 = Instant::now();
        self.describe(gray, depth, levels, out);
        let t3 = Instant::now();
        self.timings = OrbTimings {
            pyramid: t1 - t0,
            detect: t2 - t1,
            describe: t3 - t2,
        };
        Ok(())
    }

    /// Orientation on the level image, descriptor on its smoothed copy, position mapped
    /// to level 0, depth lookup.
    fn describe(
        &mut self,
        gray: ImageView<'_, u8>,
        depth: Option<ImageView<'_, f32>>,
        levels: usize,
        out: &mut OrbFeatures,
    ) {
        out.keypoints.reserve(self.selected.len());
        out.descriptors.reserve(self.selected.len());
        let (w0, h0) = (gray.width() as f32, gray.height() as f32);
        let mut start = 0;
        for level in 0..levels {
            let end = start
                + self.selected[start..]
                    .iter()
                    .take_while(|s| s.level as usize == level)
                    .count();
            if end == start {
                continue;
            }
            let image = if level == 0 {
                gray
            } else {
                self.pyramid.level(level)
            };
            self.blur.apply(image, &mut self.smoothed);
            // Pixel-centre mapping of the resize chain: u0 + 0.5 = (u + 0.5) * w0 / w.
            let sx = w0 / image.width() as f32;
            let sy = h0 / image.height() as f32;
            for s in &self.selected[start..end] {
                let (x, y) = (s.corner.x as usize, s.corner.y as usize);
                let angle = self.disc.angle(image, x, y);
                let descriptor = self.brief.describe(self.smoothed.view(), x, y, angle);
                let u = (x as f32 + 0.5) * sx - 0.5;
                let v = (y as f32 + 0.5) * sy - 0.5;
                let depth = depth.map_or(0.0, |d| {
                    keypoint_depth(d, u, v, self.config.depth_min_m, self.config.depth_max_m)
                });
                out.keypoints.push(KeyPoint {
                    u,
                    v,
                    level: s.level,
                    angle,
                    response: f32::from(s.corner.score),
                    depth,
                });
                out.descriptors.push(descriptor);
            }
            start = end;
        }
    }
}

impl Detector {
    /// FAST on the cells of one level (threshold, then the minimum threshold in cells
    /// that found nothing), then the quadtree keeps the level's budget.
    fn detect_level(
        &mut self,
        image: ImageView<'_, u8>,
        config: &OrbConfig,
        budget: usize,
        level: usize,
        selected: &mut Vec<Selected>,
    ) {
        let (w, h) = (image.width(), image.height());
        let area = Rect {
            x0: EDGE,
            x1: w - EDGE,
            y0: EDGE,
            y1: h - EDGE,
        };
        // Scores are computed one pixel beyond the area so that suppression at its edge
        // sees all 8 neighbours.
        let scored = Rect {
            x0: EDGE - 1,
            x1: w - EDGE + 1,
            y0: EDGE - 1,
            y1: h - EDGE + 1,
        };
        self.scores.resize(w, h);
        self.hits.clear();
        fast::score_rect(
            image,
            config.fast_threshold,
            scored,
            self.scores.as_mut_slice(),
            w,
            &mut self.hits,
        );
        // Clear the frame around `scored` that suppression reads but FAST did not write.
        for y in [scored.y0 - 1, scored.y1] {
            self.scores.row_mut(y)[scored.x0 - 1..=scored.x1].fill(0);
        }
        for y in scored.y0..scored.y1 {
            let row = self.scores.row_mut(y);
            row[scored.x0 - 1] = 0;
            row[scored.x1] = 0;
        }

        let cell = config.cell_size;
        let (aw, ah) = (area.x1 - area.x0, area.y1 - area.y0);
        let cols = (aw / cell).max(1);
        let rows = (ah / cell).max(1);
        let cell_w = aw.div_ceil(cols);
        let cell_h = ah.div_ceil(rows);
        self.corners.clear();
        fast::local_maxima(
            self.scores.as_slice(),
            w,
            area,
            &self.hits,
            &mut self.corners,
        );
        self.cell_counts.clear();
        self.cell_counts.resize(cols * rows, 0);
        for c in &self.corners {
            let cx = ((c.x as usize - area.x0) / cell_w).min(cols - 1);
            let cy = ((c.y as usize - area.y0) / cell_h).min(rows - 1);
            self.cell_counts[cy * cols + cx] += 1;
        }
        if config.fast_min_threshold < config.fast_threshold {
            // Retry the empty cells at the minimum threshold, a run of adjacent empty
            // cells of a cell row at a time (one wider rectangle vectorises better).
            for cy in 0..rows {
                let mut cx = 0;
                while cx < cols {
                    if self.cell_counts[cy * cols + cx] != 0 {
                        cx += 1;
                        continue;
                    }
                    let first = cx;
                    while cx < cols && self.cell_counts[cy * cols + cx] == 0 {
                        cx += 1;
                    }
                    let cells = Rect {
                        x0: area.x0 + first * cell_w,
                        x1: (area.x0 + cx * cell_w).min(area.x1),
                        y0: area.y0 + cy * cell_h,
                        y1: (area.y0 + (cy + 1) * cell_h).min(area.y1),
                    };
                    let margin = Rect {
                        x0: cells.x0 - 1,
                        x1: cells.x1 + 1,
                        y0: cells.y0 - 1,
                        y1: cells.y1 + 1,
                    };
                    self.hits.clear();
                    fast::score_rect(
                        image,
                        config.fast_min_threshold,
                        margin,
                        self.scores.as_mut_slice(),
                        w,
                        &mut self.hits,
                    );
                    fast::local_maxima(
                        self.scores.as_slice(),
                        w,
                        cells,
                        &self.hits,
                        &mut self.corners,
                    );
                }
            }
        }
        self.picked.clear();
        self.distributor
            .distribute(&self.corners, area, budget, &mut self.picked);
        selected.extend(self.picked.iter().map(|&i| Selected {
            level: level as u32,
            corner: self.corners[i as usize],
        }));
    }
}
