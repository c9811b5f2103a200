//! The score-based scheme, section III-B formulas (1)-(3).
//!
//! For every cell that lines traverse: `na` = number of distinct lines in the cell's
//! adjacent area (its 3 x 3 neighbourhood). The line of the cell with the highest mean
//! gradient gains `na^4` (formula (1)); every other line of the cell loses `na^4 / 2`
//! (formula (2)) or `na^4 / exp(np - 3)` (formula (3)), `np` being the number of cells
//! that line traverses. Lines are then ranked by score.

use crate::DetectedLine;
use crate::grid::LineGrid;

/// Adds the scores of formulas (1)-(3) into `scores` (one per line, zeroed here).
/// `stamp` is per-line scratch used to count distinct lines of a neighbourhood.
pub(super) fn score_lines(
    lines: &[DetectedLine],
    grid: &LineGrid,
    exponential: bool,
    scores: &mut Vec<f64>,
    stamp: &mut Vec<u32>,
) {
    scores.clear();
    scores.resize(lines.len(), 0.0);
    stamp.clear();
    stamp.resize(lines.len(), u32::MAX);
    let (cols, rows) = (grid.cols(), grid.rows());
    for row in 0..rows {
        for col in 0..cols {
            let Some(cell) = grid.cell(col, row) else {
                continue;
            };
            let here = grid.lines_in(cell);
            if here.is_empty() {
                continue;
            }
            // na: distinct lines of the 3 x 3 adjacent area, counted with a stamp so that
            // a line crossing several of those cells counts once.
            let mark = cell.0;
            let mut na = 0u32;
            for r in row.saturating_sub(1)..(row + 2).min(rows) {
                for c in col.saturating_sub(1)..(col + 2).min(cols) {
                    let Some(adjacent) = grid.cell(c, r) else {
                        continue;
                    };
                    for &line in grid.lines_in(adjacent) {
                        let s = &mut stamp[line as usize];
                        if *s != mark {
                            *s = mark;
                            na += 1;
                        }
                    }
                }
            }
            let weight = f64::from(na).powi(4);
            let best = representative(lines, here);
            for &line in here {
                let l = line as usize;
                if line == best {
                    scores[l] += weight; // formula (1)
                } else if exponential {
                    let np = grid.cells_of(l).len() as f64;
                    scores[l] -= weight / (np - 3.0).exp(); // formula (3)
                } else {
                    scores[l] -= weight / 2.0; // formula (2)
                }
            }
        }
    }
}

/// The line of `candidates` with the highest mean gradient (ties: longer, then lower
/// index), the cell's "most representative line".
pub(super) fn representative(lines: &[DetectedLine], candidates: &[u32]) -> u32 {
    let mut best = candidates[0];
    for &c in &candidates[1..] {
        if better(&lines[c as usize], &lines[best as usize]) {
            best = c;
        }
    }
    best
}

/// True when `a` is a better representative than `b`: higher mean gradient, then longer.
pub(super) fn better(a: &DetectedLine, b: &DetectedLine) -> bool {
    a.mean_gradient > b.mean_gradient
        || (a.mean_gradient == b.mean_gradient && a.segment.length() > b.segment.length())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Segment;
    use crate::grid::GridConfig;

    fn line(u0: f32, v0: f32, u1: f32, v1: f32, g: f32) -> DetectedLine {
        DetectedLine {
            segment: Segment::new(u0, v0, u1, v1),
            mean_gradient: g,
        }
    }

    /// Hand-worked example on a 120 x 40 image, 40 px cells (3 x 1 grid):
    ///
    /// | line | cells | mean gradient | np |
    /// |------|-------|---------------|----|
    /// | A    | 0     | 50            | 1  |
    /// | B    | 0     | 40            | 1  |
    /// | C    | 1, 2  | 30            | 2  |
    /// | D    | 2     | 60            | 1  |
    ///
    /// - cell 0: lines {A, B}; adjacent area = cells 0, 1 -> {A, B, C}, na = 3, na^4 = 81.
    ///   A wins: +81. B loses 81 / 2 = 40.5 (formula 2) or 81 / e^(1-3) = 81 e^2 =
    ///   598.52 (formula 3).
    /// - cell 1: lines {C}; adjacent area = cells 0, 1, 2 -> {A, B, C, D}, na = 4, 256.
    ///   C wins: +256.
    /// - cell 2: lines {C, D}; adjacent area = cells 1, 2 -> {C, D}, na = 2, 16.
    ///   D wins: +16. C loses 16 / 2 = 8 (formula 2) or 16 / e^(2-3) = 16 e = 43.49.
    ///
    /// Formula (2): A = 81, B = -40.5, C = 248, D = 16.
    /// Formula (3): A = 81, B = -598.52, C = 212.51, D = 16.
    #[test]
    fn formulas_give_the_hand_worked_scores() {
        let lines = [
            line(5.0, 10.0, 30.0, 10.0, 50.0),
            line(5.0, 20.0, 30.0, 20.0, 40.0),
            line(45.0, 10.0, 110.0, 10.0, 30.0),
            line(85.0, 30.0, 110.0, 30.0, 60.0),
        ];
        let mut grid = LineGrid::new(&GridConfig { cell_size: 40 });
        grid.build(120, 40, lines.iter().map(|l| &l.segment));
        let (mut scores, mut stamp) = (Vec::new(), Vec::new());
        score_lines(&lines, &grid, false, &mut scores, &mut stamp);
        assert_eq!(scores, vec![81.0, -40.5, 248.0, 16.0]);
        score_lines(&lines, &grid, true, &mut scores, &mut stamp);
        let e = std::f64::consts::E;
        let expected = [81.0, -81.0 * e * e, 256.0 - 16.0 * e, 16.0];
        for (s, x) in scores.iter().zip(expected) {
            assert!((s - x).abs() < 1e-9, "{scores:?}");
        }
        assert!((scores[1] + 598.52).abs() < 0.01 && (scores[2] - 212.51).abs() < 0.01);
    }
}
