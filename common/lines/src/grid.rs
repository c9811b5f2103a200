//! The grid index of section III-B ("Grid Structure"): the image divided into square
//! cells, with the bipartite index both ways (line -> cells it traverses, cell -> lines
//! that traverse it). It is the basis of the homogenisation schemes and of the tracker's
//! grid-based matching (section III-C), including the "extension search" of Fig. 6.
//!
//! Traversal is exact: a segment is clipped to the image and walked cell by cell with the
//! Amanatides-Woo algorithm, so a line is listed in every cell its pixels cross and in
//! no other. Cell `(col, row)` covers the pixels `u` in `[col*s, (col+1)*s)` and `v` in
//! `[row*s, (row+1)*s)`; with pixel centres at integer coordinates, that is the
//! continuous interval `[col*s - 0.5, (col+1)*s - 0.5)`.
//!
//! Storage is two compressed-row tables that keep their capacity between frames, so a
//! warm [`LineGrid`] does not allocate.

use crate::Segment;
use serde::{Deserialize, Serialize};

/// Parameters of the grid.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct GridConfig {
    /// Side of a square cell in pixels. Default 40 (a 16 x 12 grid on 640 x 480 images,
    /// the granularity the paper's Fig. 4 and Fig. 6 suggest).
    pub cell_size: usize,
}

impl Default for GridConfig {
    fn default() -> Self {
        Self { cell_size: 40 }
    }
}

/// A cell of the grid: `row * cols + col`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct CellId(pub u32);

/// The bipartite line <-> cell index of one frame. Line indices are positions in the
/// slice of segments given to [`LineGrid::build`].
#[derive(Clone, Debug, Default)]
pub struct LineGrid {
    cell_size: f32,
    cols: usize,
    rows: usize,
    width: usize,
    height: usize,
    /// `line_cells[line_offsets[i]..line_offsets[i + 1]]` are the cells of line `i`.
    line_offsets: Vec<u32>,
    line_cells: Vec<CellId>,
    /// `cell_lines[cell_offsets[c]..cell_offsets[c + 1]]` are the lines of cell `c`.
    cell_offsets: Vec<u32>,
    cell_lines: Vec<u32>,
    /// Per-cell write cursor while filling `cell_lines`.
    cursor: Vec<u32>,
}

impl LineGrid {
    /// An empty grid with the cell size of `config` (a cell size of 0 counts as 1).
    pub fn new(config: &GridConfig) -> Self {
        Self {
            cell_size: config.cell_size.max(1) as f32,
            ..Self::default()
        }
    }

    /// Indexes `segments` on a `width x height` image: every line is listed in the cells
    /// it traverses (in traversal order from `start` to `end`) and every cell lists its
    /// lines (in increasing index). Segments entirely outside the image get no cell.
    pub fn build<'a, I>(&mut self, width: usize, height: usize, segments: I)
    where
        I: IntoIterator<Item = &'a Segment>,
    {
        let s = self.cell_size as usize;
        self.width = width;
        self.height = height;
        self.cols = width.div_ceil(s);
        self.rows = height.div_ceil(s);
        let n_cells = self.cols * self.rows;
        self.line_offsets.clear();
        self.line_offsets.push(0);
        self.line_cells.clear();
        let mut cells = std::mem::take(&mut self.line_cells);
        for segment in segments {
            self.traverse(segment, false, &mut cells);
            self.line_offsets.push(cells.len() as u32);
        }
        self.line_cells = cells;

        // Cell -> lines: counting sort of the (line, cell) pairs by cell.
        self.cell_offsets.clear();
        self.cell_offsets.resize(n_cells + 1, 0);
        for cell in &self.line_cells {
            self.cell_offsets[cell.0 as usize + 1] += 1;
        }
        for c in 0..n_cells {
            self.cell_offsets[c + 1] += self.cell_offsets[c];
        }
        self.cursor.clear();
        self.cursor.extend_from_slice(&self.cell_offsets[..n_cells]);
        self.cell_lines.clear();
        self.cell_lines.resize(self.line_cells.len(), 0);
        for line in 0..self.line_offsets.len() - 1 {
            let (a, b) = (self.line_offsets[line], self.line_offsets[line + 1]);
            for k in a..b {
                let cell = self.line_cells[k as usize].0 as usize;
                self.cell_lines[self.cursor[cell] as usize] = line as u32;
                self.cursor[cell] += 1;
            }
        }
    }

    /// Number of cell columns.
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// Number of cell rows.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Number of cells.
    pub fn cell_count(&self) -> usize {
        self.cols * self.rows
    }

    /// Number of indexed lines.
    pub fn line_count(&self) -> usize {
        self.line_offsets.len().saturating_sub(1)
    }

    /// Side of a cell in pixels.
    pub fn cell_size(&self) -> f32 {
        self.cell_size
    }

    /// The cells line `line` traverses, in order from its start; empty for an unknown line.
    pub fn cells_of(&self, line: usize) -> &[CellId] {
        match (self.line_offsets.get(line), self.line_offsets.get(line + 1)) {
            (Some(&a), Some(&b)) => &self.line_cells[a as usize..b as usize],
            _ => &[],
        }
    }

    /// The lines that traverse `cell`, in increasing index; empty for an unknown cell.
    pub fn lines_in(&self, cell: CellId) -> &[u32] {
        let c = cell.0 as usize;
        match (self.cell_offsets.get(c), self.cell_offsets.get(c + 1)) {
            (Some(&a), Some(&b)) => &self.cell_lines[a as usize..b as usize],
            _ => &[],
        }
    }

    /// `(col, row)` of a cell.
    pub fn col_row(&self, cell: CellId) -> (usize, usize) {
        let c = cell.0 as usize;
        (c % self.cols.max(1), c / self.cols.max(1))
    }

    /// The cell at `(col, row)`, or `None` outside the grid.
    pub fn cell(&self, col: usize, row: usize) -> Option<CellId> {
        (col < self.cols && row < self.rows).then(|| CellId((row * self.cols + col) as u32))
    }

    /// The cell holding pixel position (u, v), or `None` outside the image.
    pub fn cell_at(&self, u: f32, v: f32) -> Option<CellId> {
        let (x, y) = ((u + 0.5) / self.cell_size, (v + 0.5) / self.cell_size);
        if !(x >= 0.0 && y >= 0.0) || u + 0.5 >= self.width as f32 || v + 0.5 >= self.height as f32
        {
            return None;
        }
        self.cell(x as usize, y as usize)
    }

    /// Appends to `out` the cells within `radius` cells of `cell` (Chebyshev distance,
    /// the cell itself included; radius 1 is the 3 x 3 "adjacent area").
    pub fn neighbourhood(&self, cell: CellId, radius: usize, out: &mut Vec<CellId>) {
        if cell.0 as usize >= self.cell_count() {
            return;
        }
        let (col, row) = self.col_row(cell);
        for r in row.saturating_sub(radius)..(row + radius + 1).min(self.rows) {
            for c in col.saturating_sub(radius)..(col + radius + 1).min(self.cols) {
                out.push(CellId((r * self.cols + c) as u32));
            }
        }
    }

    /// Appends to `out` the cells `segment` traverses within the image, in order from
    /// its start (the same cells [`LineGrid::build`] records for it).
    pub fn segment_cells(&self, segment: &Segment, out: &mut Vec<CellId>) {
        self.traverse(segment, false, out);
    }

    /// Appends to `out` the cells the infinite extension of `segment` traverses within
    /// the image: the "extension search" range of the paper's Fig. 6 (a broken line keeps
    /// its slope, so its other pieces lie along the extension).
    pub fn extension_cells(&self, segment: &Segment, out: &mut Vec<CellId>) {
        self.traverse(segment, true, out);
    }

    /// Candidate lines of this grid for a segment (usually of another frame): the
    /// lines in the cells the segment traverses and in their neighbours within `radius`
    /// cells, plus, when `extension` is set, the cells of the segment's extension.
    /// `out` is cleared and receives sorted, distinct line indices; `cells` is scratch.
    pub fn candidates(
        &self,
        segment: &Segment,
        radius: usize,
        extension: bool,
        cells: &mut Vec<CellId>,
        out: &mut Vec<u32>,
    ) {
        out.clear();
        cells.clear();
        self.traverse(segment, extension, cells);
        for &cell in cells.iter() {
            if radius == 0 {
                out.extend_from_slice(self.lines_in(cell));
                continue;
            }
            let (col, row) = self.col_row(cell);
            for r in row.saturating_sub(radius)..(row + radius + 1).min(self.rows) {
                for c in col.saturating_sub(radius)..(col + radius + 1).min(self.cols) {
                    out.extend_from_slice(self.lines_in(CellId((r * self.cols + c) as u32)));
                }
            }
        }
        out.sort_unstable();
        out.dedup();
    }

    /// Amanatides-Woo walk of the segment (or of its infinite line when `infinite`)
    /// clipped to the image rectangle, in grid units where cell (c, r) is the unit
    /// square `[c, c+1) x [r, r+1)`.
    fn traverse(&self, segment: &Segment, infinite: bool, out: &mut Vec<CellId>) {
        if self.cols == 0 || self.rows == 0 {
            return;
        }
        let s = self.cell_size;
        let x0 = (segment.start[0] + 0.5) / s;
        let y0 = (segment.start[1] + 0.5) / s;
        let (dx, dy) = (
            (segment.end[0] - segment.start[0]) / s,
            (segment.end[1] - segment.start[1]) / s,
        );
        if !(x0.is_finite() && y0.is_finite() && dx.is_finite() && dy.is_finite()) {
            return;
        }
        let (xmax, ymax) = (self.width as f32 / s, self.height as f32 / s);
        let (mut t0, mut t1) = if infinite {
            if dx == 0.0 && dy == 0.0 {
                return;
            }
            (f32::NEG_INFINITY, f32::INFINITY)
        } else {
            (0.0, 1.0)
        };
        // Liang-Barsky clipping of p(t) = p0 + t d to [0, xmax] x [0, ymax].
        for (p, q) in [(-dx, x0), (dx, xmax - x0), (-dy, y0), (dy, ymax - y0)] {
            if p == 0.0 {
                if q < 0.0 {
                    return;
                }
            } else {
                let r = q / p;
                if p < 0.0 {
                    t0 = t0.max(r);
                } else {
                    t1 = t1.min(r);
                }
            }
        }
        if t0 > t1 {
            return;
        }
        let (ax, ay) = (x0 + t0 * dx, y0 + t0 * dy);
        let (bx, by) = (x0 + t1 * dx, y0 + t1 * dy);
        let clamp_col = |x: f32| (x.floor().max(0.0) as usize).min(self.cols - 1) as i64;
        let clamp_row = |y: f32| (y.floor().max(0.0) as usize).min(self.rows - 1) as i64;
        let (mut col, mut row) = (clamp_col(ax), clamp_row(ay));
        let (end_col, end_row) = (clamp_col(bx), clamp_row(by));
        let (ddx, ddy) = (bx - ax, by - ay);
        let step_c: i64 = if end_col > col { 1 } else { -1 };
        let step_r: i64 = if end_row > row { 1 } else { -1 };
        // Parameter (0..1 along a -> b) of the next vertical / horizontal cell boundary.
        let next_boundary = |pos: f32, cell: i64, step: i64, d: f32| {
            if d == 0.0 {
                f32::INFINITY
            } else {
                let edge = if step > 0 { cell + 1 } else { cell } as f32;
                (edge - pos) / d
            }
        };
        let mut t_col = next_boundary(ax, col, step_c, ddx);
        let mut t_row = next_boundary(ay, row, step_r, ddy);
        let (dt_col, dt_row) = (1.0 / ddx.abs(), 1.0 / ddy.abs());
        let steps = (end_col - col).abs() + (end_row - row).abs();
        out.push(CellId((row as usize * self.cols + col as usize) as u32));
        // Exactly `steps` moves, so the walk always ends in the end cell even when
        // rounding makes a boundary crossing ambiguous.
        let (mut left_c, mut left_r) = ((end_col - col).abs(), (end_row - row).abs());
        for _ in 0..steps {
            if left_r == 0 || (left_c > 0 && t_col <= t_row) {
                col += step_c;
                t_col += dt_col;
                left_c -= 1;
            } else {
                row += step_r;
                t_row += dt_row;
                left_r -= 1;
            }
            out.push(CellId((row as usize * self.cols + col as usize) as u32));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::Rng;

    fn sampled_cells(grid: &LineGrid, s: &Segment, t_range: (f32, f32)) -> Vec<CellId> {
        let n = 200_000;
        let mut cells = Vec::new();
        for i in 0..=n {
            let t = t_range.0 + (t_range.1 - t_range.0) * i as f32 / n as f32;
            let u = s.start[0] + t * (s.end[0] - s.start[0]);
            let v = s.start[1] + t * (s.end[1] - s.start[1]);
            if let Some(c) = grid.cell_at(u, v) {
                cells.push(c);
            }
        }
        cells.sort_unstable();
        cells.dedup();
        cells
    }

    #[test]
    fn traversal_equals_dense_sampling_on_random_segments() {
        let mut grid = LineGrid::new(&GridConfig { cell_size: 40 });
        let mut state = Rng(7);
        let segments: Vec<Segment> = (0..300)
            .map(|_| {
                // Some endpoints fall outside the 645 x 477 image on purpose.
                let mut p = || (state.next() * 760.0 - 60.0, state.next() * 580.0 - 50.0);
                let (a, b) = (p(), p());
                Segment::new(a.0, a.1, b.0, b.1)
            })
            .collect();
        grid.build(645, 477, &segments);
        assert_eq!((grid.cols(), grid.rows()), (17, 12));
        for (i, s) in segments.iter().enumerate() {
            let mut walked = grid.cells_of(i).to_vec();
            let n = walked.len();
            walked.sort_unstable();
            walked.dedup();
            assert_eq!(walked.len(), n, "segment {i} visits a cell twice");
            assert_eq!(
                walked,
                sampled_cells(&grid, s, (0.0, 1.0)),
                "segment {i}: {s:?}"
            );
            for c in &walked {
                assert!(grid.lines_in(*c).contains(&(i as u32)));
            }
        }
        let total: usize = (0..grid.cell_count())
            .map(|c| grid.lines_in(CellId(c as u32)).len())
            .sum();
        assert_eq!(total, grid.line_cells.len());
    }

    #[test]
    fn extension_covers_the_whole_line_through_the_image() {
        let mut grid = LineGrid::new(&GridConfig::default());
        grid.build(640, 480, &[]);
        let mut state = Rng(3);
        for _ in 0..100 {
            let (u, v) = (state.next() * 640.0, state.next() * 480.0);
            let angle = state.next() * std::f32::consts::TAU;
            // A 10 px piece; sampling it from -100 to +100 lengths spans the whole image.
            let s = Segment::new(u, v, u + 10.0 * angle.cos(), v + 10.0 * angle.sin());
            let mut cells = Vec::new();
            grid.extension_cells(&s, &mut cells);
            cells.sort_unstable();
            assert_eq!(cells, sampled_cells(&grid, &s, (-100.0, 100.0)));
        }
        // A horizontal line at v = 100 crosses the 16 cells of row 2.
        let mut cells = Vec::new();
        grid.extension_cells(&Segment::new(300.0, 100.0, 310.0, 100.0), &mut cells);
        assert_eq!(cells.len(), 16);
        assert!(cells.iter().all(|c| grid.col_row(*c).1 == 2));
    }

    #[test]
    fn neighbourhood_and_candidates() {
        let mut grid = LineGrid::new(&GridConfig::default());
        let lines = [
            Segment::new(10.0, 10.0, 30.0, 10.0),   // cell (0, 0)
            Segment::new(100.0, 10.0, 110.0, 30.0), // cell (2, 0)
            Segment::new(500.0, 400.0, 600.0, 450.0),
        ];
        grid.build(640, 480, &lines);
        let mut cells = Vec::new();
        grid.neighbourhood(CellId(0), 1, &mut cells);
        assert_eq!(cells, vec![CellId(0), CellId(1), CellId(16), CellId(17)]);
        let mut out = Vec::new();
        let query = Segment::new(45.0, 15.0, 50.0, 15.0); // cell (1, 0)
        grid.candidates(&query, 1, false, &mut cells, &mut out);
        assert_eq!(out, vec![0, 1]);
        grid.candidates(&query, 0, false, &mut cells, &mut out);
        assert!(out.is_empty());
        // The extension of a short horizontal piece reaches both lines of row 0.
        grid.candidates(&query, 0, true, &mut cells, &mut out);
        assert_eq!(out, vec![0, 1]);
    }

    #[test]
    fn degenerate_inputs_do_not_panic() {
        let mut grid = LineGrid::new(&GridConfig { cell_size: 0 });
        grid.build(0, 0, &[Segment::new(1.0, 1.0, 2.0, 2.0)]);
        assert!(grid.cells_of(0).is_empty());
        assert!(grid.lines_in(CellId(5)).is_empty());
        let mut grid = LineGrid::new(&GridConfig::default());
        let odd = [
            Segment::new(f32::NAN, 0.0, 1.0, 1.0),
            Segment::new(-100.0, -100.0, -50.0, -10.0),
            Segment::new(5.0, 5.0, 5.0, 5.0),
        ];
        grid.build(64, 48, &odd);
        assert!(grid.cells_of(0).is_empty() && grid.cells_of(1).is_empty());
        assert_eq!(grid.cells_of(2), &[CellId(0)]);
        let mut cells = Vec::new();
        grid.extension_cells(&odd[2], &mut cells);
        assert!(cells.is_empty());
    }
}
