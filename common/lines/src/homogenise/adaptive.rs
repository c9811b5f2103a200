//! The adaptive target: how many lines the homogenisation keeps.

use super::HomogeniseConfig;
use crate::grid::{CellId, LineGrid};

/// The number of lines to keep for the lines indexed by `grid` (see
/// [`HomogeniseConfig`] for the rule). Never more than the number of lines, and all of
/// them when there are at most `min_lines`.
pub fn adaptive_target(grid: &LineGrid, config: &HomogeniseConfig) -> usize {
    let n = grid.line_count();
    if !config.adaptive {
        return config.fixed_target.min(n);
    }
    if n <= config.min_lines {
        return n;
    }
    let target = effective_lines(grid) * f64::from(config.occupancy_scale.max(0.0));
    (target.round() as usize)
        .clamp(config.min_lines, config.max_lines.max(config.min_lines))
        .min(n)
}

/// Sum over lines of the mean, over the cells a line traverses, of 1 / (lines in the
/// cell): each occupied cell is one unit shared by its lines.
fn effective_lines(grid: &LineGrid) -> f64 {
    (0..grid.line_count())
        .map(|line| {
            let cells = grid.cells_of(line);
            if cells.is_empty() {
                return 0.0;
            }
            let share: f64 = cells
                .iter()
                .map(|&c: &CellId| 1.0 / grid.lines_in(c).len() as f64)
                .sum();
            share / cells.len() as f64
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Segment;
    use crate::grid::GridConfig;

    #[test]
    fn a_pile_of_lines_counts_once_and_separate_lines_count_each() {
        let mut grid = LineGrid::new(&GridConfig::default());
        // 20 parallel short lines in cell (0, 0), plus 3 separate long horizontal lines.
        let mut lines: Vec<Segment> = (0..20)
            .map(|i| Segment::new(5.0, 5.0 + i as f32, 30.0, 5.0 + i as f32))
            .collect();
        for row in [3.0, 6.0, 9.0] {
            lines.push(Segment::new(50.0, row * 40.0, 600.0, row * 40.0));
        }
        grid.build(640, 480, &lines);
        assert!((effective_lines(&grid) - 4.0).abs() < 1e-9);
        let config = HomogeniseConfig {
            min_lines: 2,
            ..HomogeniseConfig::default()
        };
        assert_eq!(adaptive_target(&grid, &config), 4);
        // With the default minimum of 30, 23 lines are all kept.
        assert_eq!(adaptive_target(&grid, &HomogeniseConfig::default()), 23);
        let fixed = HomogeniseConfig {
            adaptive: false,
            fixed_target: 10,
            ..HomogeniseConfig::default()
        };
        assert_eq!(adaptive_target(&grid, &fixed), 10);
    }
}
