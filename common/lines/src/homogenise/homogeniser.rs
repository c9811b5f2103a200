//! The homogenisation step: scheme dispatch, target, ranking, reusable scratch.

use super::adaptive::adaptive_target;
use super::quadtree::Quadtree;
use super::score::score_lines;
use super::{HomogeniseConfig, HomogeniseScheme, ScorePenalty};
use crate::DetectedLine;
use crate::grid::LineGrid;

/// Selects the lines to keep; owns its scratch so that a warm instance does not allocate.
///
/// ```
/// use gfs_lines::grid::{GridConfig, LineGrid};
/// use gfs_lines::homogenise::{HomogeniseConfig, Homogeniser};
/// use gfs_lines::{DetectedLine, Segment};
/// let lines: Vec<DetectedLine> = (0..40)
///     .map(|i| DetectedLine { segment: Segment::new(5.0, 5.0 + i as f32 * 0.5, 30.0, 5.0 + i as f32 * 0.5), mean_gradient: 50.0 })
///     .collect();
/// let mut grid = LineGrid::new(&GridConfig::default());
/// grid.build(640, 480, lines.iter().map(|l| &l.segment));
/// let mut homogeniser = Homogeniser::new(HomogeniseConfig::default());
/// let mut keep = Vec::new();
/// homogeniser.select(&lines, &grid, &mut keep);
/// assert_eq!(keep.len(), 30); // one cluster, clamped up to the 30-line minimum
/// ```
#[derive(Clone, Debug)]
pub struct Homogeniser {
    config: HomogeniseConfig,
    scores: Vec<f64>,
    stamp: Vec<u32>,
    order: Vec<u32>,
    lengths: Vec<f32>,
    quadtree: Quadtree,
    target: usize,
}

impl Homogeniser {
    /// A homogeniser with `config`.
    pub fn new(config: HomogeniseConfig) -> Self {
        Self {
            config,
            scores: Vec::new(),
            stamp: Vec::new(),
            order: Vec::new(),
            lengths: Vec::new(),
            quadtree: Quadtree::default(),
            target: 0,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &HomogeniseConfig {
        &self.config
    }

    /// The target of the last [`Homogeniser::select`] call.
    pub fn last_target(&self) -> usize {
        self.target
    }

    /// Writes into `keep` (cleared) the indices of the lines to keep, in increasing
    /// order. `grid` must index exactly `lines` (built from their segments). With the
    /// `none` scheme, or when no more lines exist than the target, every line is kept.
    pub fn select(&mut self, lines: &[DetectedLine], grid: &LineGrid, keep: &mut Vec<u32>) {
        keep.clear();
        let n = lines.len();
        self.target = if self.config.scheme == HomogeniseScheme::None {
            n
        } else {
            adaptive_target(grid, &self.config)
        };
        if self.target >= n || grid.line_count() != n {
            self.target = n;
            keep.extend(0..n as u32);
            return;
        }
        if self.target == 0 {
            return;
        }
        match self.config.scheme {
            HomogeniseScheme::None => keep.extend(0..n as u32),
            HomogeniseScheme::Quadtree | HomogeniseScheme::Midpoint => {
                let midpoints = self.config.scheme == HomogeniseScheme::Midpoint;
                self.quadtree
                    .select(lines, grid, midpoints, self.target, keep);
            }
            HomogeniseScheme::Score => {
                let exponential = self.use_formula_3(lines);
                score_lines(lines, grid, exponential, &mut self.scores, &mut self.stamp);
                self.order.clear();
                self.order.extend(0..n as u32);
                let (scores, order) = (&self.scores, &mut self.order);
                // Highest score first; ties by mean gradient, then index (deterministic).
                let key = |i: &u32| {
                    let i = *i as usize;
                    (scores[i], lines[i].mean_gradient)
                };
                order.select_nth_unstable_by(self.target - 1, |a, b| {
                    let (ka, kb) = (key(a), key(b));
                    kb.0.total_cmp(&ka.0)
                        .then(kb.1.total_cmp(&ka.1))
                        .then(a.cmp(b))
                });
                keep.extend_from_slice(&order[..self.target]);
            }
        }
        keep.sort_unstable();
    }

    /// Formula (3) instead of (2): by configuration, or (`auto`) when the 90th / 10th
    /// percentile length ratio exceeds `length_spread`.
    fn use_formula_3(&mut self, lines: &[DetectedLine]) -> bool {
        match self.config.score_penalty {
            ScorePenalty::Half => false,
            ScorePenalty::Exponential => true,
            ScorePenalty::Auto => {
                self.lengths.clear();
                self.lengths
                    .extend(lines.iter().map(|l| l.segment.length()));
                let n = self.lengths.len();
                if n < 2 {
                    return false;
                }
                let lo = (n / 10).min(n - 1);
                let hi = (n * 9 / 10).min(n - 1);
                let (_, &mut p10, _) = self.lengths.select_nth_unstable_by(lo, f32::total_cmp);
                let (_, &mut p90, _) = self.lengths.select_nth_unstable_by(hi, f32::total_cmp);
                p90 > self.config.length_spread * p10.max(f32::EPSILON)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Segment;
    use crate::grid::GridConfig;

    /// 30 short parallel lines (25 px, 1 px apart) piled in cells (2..3, 2), mean
    /// gradients 40..69; one isolated long line (400 px) at v = 400 with the weakest
    /// gradient of all (30); 8 medium lines spread over separate cells.
    fn scene() -> Vec<DetectedLine> {
        let mut lines: Vec<DetectedLine> = (0..30)
            .map(|i| DetectedLine {
                segment: Segment::new(85.0, 85.0 + i as f32, 110.0, 85.0 + i as f32),
                mean_gradient: 40.0 + i as f32,
            })
            .collect();
        lines.push(DetectedLine {
            segment: Segment::new(100.0, 400.0, 500.0, 400.0),
            mean_gradient: 30.0,
        });
        for k in 0..8 {
            let u = 250.0 + 45.0 * k as f32;
            lines.push(DetectedLine {
                segment: Segment::new(u, 130.0, u + 10.0, 250.0),
                mean_gradient: 35.0,
            });
        }
        lines
    }

    fn run(scheme: HomogeniseScheme) -> Vec<u32> {
        let lines = scene();
        let mut grid = LineGrid::new(&GridConfig::default());
        grid.build(640, 480, lines.iter().map(|l| &l.segment));
        let config = HomogeniseConfig {
            scheme,
            min_lines: 5,
            ..HomogeniseConfig::default()
        };
        let mut h = Homogeniser::new(config);
        let mut keep = Vec::new();
        h.select(&lines, &grid, &mut keep);
        // Effective lines: cluster 1 + long line 1 + 8 separate lines = 10.
        let target = if scheme == HomogeniseScheme::None {
            39
        } else {
            10
        };
        assert_eq!(h.last_target(), target, "{scheme:?}");
        keep
    }

    fn check(scheme: HomogeniseScheme, max_from_cluster: usize) {
        let keep = run(scheme);
        let from_cluster = keep.iter().filter(|&&i| i < 30).count();
        assert!(
            (1..=max_from_cluster).contains(&from_cluster),
            "{scheme:?}: {from_cluster} cluster lines kept: {keep:?}"
        );
        assert!(
            keep.contains(&30),
            "{scheme:?} dropped the long line: {keep:?}"
        );
        assert!(
            keep.contains(&29),
            "{scheme:?}: the strongest cluster line goes"
        );
        let spread = keep.iter().filter(|&&i| i > 30).count();
        assert!(
            spread >= 7,
            "{scheme:?}: {spread} of the 8 spread lines kept"
        );
    }

    #[test]
    fn quadtree_thins_the_cluster_and_keeps_the_long_line() {
        check(HomogeniseScheme::Quadtree, 2);
    }

    #[test]
    fn midpoint_thins_the_cluster_and_keeps_the_long_line() {
        check(HomogeniseScheme::Midpoint, 2);
    }

    #[test]
    fn score_thins_the_cluster_and_keeps_the_long_line() {
        check(HomogeniseScheme::Score, 1);
        assert_eq!(run(HomogeniseScheme::Score).len(), 10);
    }

    #[test]
    fn none_keeps_everything_and_empty_input_is_fine() {
        assert_eq!(run(HomogeniseScheme::None).len(), 39);
        let grid = LineGrid::new(&GridConfig::default());
        let mut h = Homogeniser::new(HomogeniseConfig::default());
        let mut keep = vec![3];
        h.select(&[], &grid, &mut keep);
        assert!(keep.is_empty());
        // A zero target (fixed_target = 0) keeps nothing, for every scheme.
        let lines = scene();
        let mut grid = LineGrid::new(&GridConfig::default());
        grid.build(640, 480, lines.iter().map(|l| &l.segment));
        for scheme in [
            HomogeniseScheme::Quadtree,
            HomogeniseScheme::Midpoint,
            HomogeniseScheme::Score,
        ] {
            let config = HomogeniseConfig {
                scheme,
                adaptive: false,
                fixed_target: 0,
                ..HomogeniseConfig::default()
            };
            Homogeniser::new(config).select(&lines, &grid, &mut keep);
            assert!(keep.is_empty(), "{scheme:?}");
        }
    }
}
