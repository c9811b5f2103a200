//! Parameters of the homogenisation (`[lines.homogenise]`).

use serde::{Deserialize, Serialize};

/// Which homogenisation scheme runs (section III-B).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum HomogeniseScheme {
    /// Keep every detected line.
    None,
    /// Quadtree over the grid; record of a cell = number of lines traversing it.
    Quadtree,
    /// Quadtree over the grid; record of a cell = number of line midpoints in it.
    Midpoint,
    /// The paper's score ranking, formulas (1)-(3); the scheme the paper finds best in
    /// dense regions, hence the default.
    #[default]
    Score,
}

/// The penalty of the score scheme for the lines that do not win a cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum ScorePenalty {
    /// Formula (2): `na^4 / 2`.
    Half,
    /// Formula (3): `na^4 / exp(np - 3)`, smaller for lines through many cells.
    Exponential,
    /// Formula (3) when the line lengths differ a lot (90th / 10th percentile length
    /// above [`HomogeniseConfig::length_spread`]), else formula (2): the paper's advice.
    #[default]
    Auto,
}

/// Parameters of the homogenisation.
///
/// How many lines are kept (the target): with `adaptive` (default), the target is the
/// *effective number of lines* of the grid, `sum over lines of (mean over the cells it
/// traverses of 1 / lines in that cell)`, times `occupancy_scale`, clamped to
/// `[min_lines, max_lines]`. Lines that do not share cells count 1 each; a cluster of k
/// lines piled in the same cells counts 1. So the target follows the scene instead of a
/// per-dataset constant (the paper's fixed T fails when a sequence swings from 20 to 323
/// lines), and when at most `min_lines` lines exist all are kept. Without `adaptive` the
/// target is `fixed_target` (the paper's T).
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct HomogeniseConfig {
    /// The scheme. Default `score`.
    pub scheme: HomogeniseScheme,
    /// Derive the target from the grid occupancy. Default true.
    pub adaptive: bool,
    /// Lines kept when `adaptive` is false (the paper's fixed threshold T). Default 80.
    pub fixed_target: usize,
    /// Factor on the effective number of lines. Default 1.0 (keep one line per
    /// "independent" line of the scene).
    pub occupancy_scale: f32,
    /// Lower bound of the adaptive target; frames with fewer lines keep all. Default 30,
    /// about the number of lines a pose needs with margin against outliers.
    pub min_lines: usize,
    /// Upper bound of the adaptive target. Default 150, beyond which matching cost grows
    /// without helping the pose.
    pub max_lines: usize,
    /// Penalty formula of the score scheme. Default `auto`.
    pub score_penalty: ScorePenalty,
    /// 90th / 10th percentile length ratio beyond which `auto` uses formula (3).
    /// Default 4.0.
    pub length_spread: f32,
}

impl Default for HomogeniseConfig {
    fn default() -> Self {
        Self {
            scheme: HomogeniseScheme::default(),
            adaptive: true,
            fixed_target: 80,
            occupancy_scale: 1.0,
            min_lines: 30,
            max_lines: 150,
            score_penalty: ScorePenalty::default(),
            length_spread: 4.0,
        }
    }
}
