//! The quadtree schemes of section III-B, ORB-SLAM's node division run over grid
//! records instead of keypoints.
//!
//! Each cell holds a record: the number of lines traversing it (quadtree scheme) or the
//! number of line midpoints in it (midpoint scheme). Starting from one node covering the
//! grid, the node with the largest record that still holds two or more distinct lines is
//! split into four (at half its cells; empty children are dropped) until there are as
//! many nodes as the target or nothing can be split. Every node then keeps its best line
//! (highest mean gradient, then longest) not already kept by another node.

use super::score::better;
use crate::DetectedLine;
use crate::grid::LineGrid;

/// A rectangle of cells `[c0, c1) x [r0, r1)` with its record sum.
#[derive(Clone, Copy, Debug)]
struct Node {
    c0: usize,
    r0: usize,
    c1: usize,
    r1: usize,
    record: u32,
    /// Holds two or more distinct lines (worth splitting).
    several: bool,
}

/// Reusable storage of the quadtree schemes.
#[derive(Clone, Debug, Default)]
pub(super) struct Quadtree {
    /// Per-cell member lists (CSR): lines traversing the cell, or whose midpoint it holds.
    offsets: Vec<u32>,
    members: Vec<u32>,
    /// Summed-area table of per-cell record counts, `(cols + 1) x (rows + 1)`.
    sat: Vec<u32>,
    nodes: Vec<Node>,
    next: Vec<Node>,
    stamp: Vec<u32>,
    kept: Vec<bool>,
}

impl Quadtree {
    /// Appends to `keep` the lines the quadtree keeps for `target` nodes.
    pub(super) fn select(
        &mut self,
        lines: &[DetectedLine],
        grid: &LineGrid,
        midpoints: bool,
        target: usize,
        keep: &mut Vec<u32>,
    ) {
        let (cols, rows) = (grid.cols(), grid.rows());
        if cols == 0 || rows == 0 || lines.is_empty() {
            return;
        }
        self.fill_members(lines, grid, midpoints);
        self.fill_sat(cols, rows);
        self.stamp.clear();
        self.stamp.resize(lines.len(), u32::MAX);
        self.nodes.clear();
        let mut serial = 0u32;
        let root = self.node(0, 0, cols, rows, cols, &mut serial);
        if root.record > 0 {
            self.nodes.push(root);
        }
        while self.nodes.len() < target {
            // The splittable node with the most records (ORB-SLAM splits the densest first).
            let Some(pick) = (0..self.nodes.len())
                .filter(|&i| {
                    let n = &self.nodes[i];
                    n.several && (n.c1 - n.c0 > 1 || n.r1 - n.r0 > 1)
                })
                .max_by_key(|&i| (self.nodes[i].record, usize::MAX - i))
            else {
                break;
            };
            let n = self.nodes.swap_remove(pick);
            let cm = n.c0 + (n.c1 - n.c0).div_ceil(2);
            let rm = n.r0 + (n.r1 - n.r0).div_ceil(2);
            self.next.clear();
            for (c0, c1) in [(n.c0, cm), (cm, n.c1)] {
                for (r0, r1) in [(n.r0, rm), (rm, n.r1)] {
                    if c0 < c1 && r0 < r1 {
                        let child = self.node(c0, r0, c1, r1, cols, &mut serial);
                        if child.record > 0 {
                            self.next.push(child);
                        }
                    }
                }
            }
            self.nodes.append(&mut self.next);
        }
        // Densest nodes choose first, so a line shared by several nodes goes to the
        // node where it competes with the most lines.
        self.nodes
            .sort_unstable_by_key(|n| (u32::MAX - n.record, n.r0, n.c0));
        self.kept.clear();
        self.kept.resize(lines.len(), false);
        for k in 0..self.nodes.len() {
            let n = self.nodes[k];
            let mut best: Option<u32> = None;
            for r in n.r0..n.r1 {
                for c in n.c0..n.c1 {
                    let cell = r * cols + c;
                    let (a, b) = (self.offsets[cell] as usize, self.offsets[cell + 1] as usize);
                    for &line in &self.members[a..b] {
                        if self.kept[line as usize] {
                            continue;
                        }
                        if best.is_none_or(|b| better(&lines[line as usize], &lines[b as usize])) {
                            best = Some(line);
                        }
                    }
                }
            }
            if let Some(b) = best {
                self.kept[b as usize] = true;
                keep.push(b);
            }
        }
    }

    /// Per-cell member lists for the chosen record.
    fn fill_members(&mut self, lines: &[DetectedLine], grid: &LineGrid, midpoints: bool) {
        let n_cells = grid.cell_count();
        self.offsets.clear();
        self.offsets.resize(n_cells + 1, 0);
        self.members.clear();
        if midpoints {
            // Counting sort of the lines by the cell of their midpoint.
            let cell_of = |l: &DetectedLine| {
                let [u, v] = l.segment.midpoint();
                grid.cell_at(u, v)
            };
            for l in lines {
                if let Some(c) = cell_of(l) {
                    self.offsets[c.0 as usize + 1] += 1;
                }
            }
            for c in 0..n_cells {
                self.offsets[c + 1] += self.offsets[c];
            }
            self.members.resize(self.offsets[n_cells] as usize, 0);
            self.sat.clear();
            self.sat.extend_from_slice(&self.offsets[..n_cells]);
            for (i, l) in lines.iter().enumerate() {
                if let Some(c) = cell_of(l) {
                    let slot = &mut self.sat[c.0 as usize];
                    self.members[*slot as usize] = i as u32;
                    *slot += 1;
                }
            }
        } else {
            for c in 0..n_cells {
                let here = grid.lines_in(crate::grid::CellId(c as u32));
                self.members.extend_from_slice(here);
                self.offsets[c + 1] = self.members.len() as u32;
            }
        }
    }

    /// Summed-area table of the per-cell records (member counts).
    fn fill_sat(&mut self, cols: usize, rows: usize) {
        let w = cols + 1;
        self.sat.clear();
        self.sat.resize(w * (rows + 1), 0);
        for r in 0..rows {
            let mut row_sum = 0;
            for c in 0..cols {
                let cell = r * cols + c;
                row_sum += self.offsets[cell + 1] - self.offsets[cell];
                self.sat[(r + 1) * w + c + 1] = self.sat[r * w + c + 1] + row_sum;
            }
        }
    }

    /// A node with its record (from the summed-area table) and whether it holds two or
    /// more distinct lines (counted with a per-node stamp).
    fn node(
        &mut self,
        c0: usize,
        r0: usize,
        c1: usize,
        r1: usize,
        cols: usize,
        serial: &mut u32,
    ) -> Node {
        let w = cols + 1;
        let record = self.sat[r1 * w + c1] + self.sat[r0 * w + c0]
            - self.sat[r0 * w + c1]
            - self.sat[r1 * w + c0];
        *serial += 1;
        let mut distinct = 0;
        'cells: for r in r0..r1 {
            for c in c0..c1 {
                let cell = r * cols + c;
                let (a, b) = (self.offsets[cell] as usize, self.offsets[cell + 1] as usize);
                for &line in &self.members[a..b] {
                    let s = &mut self.stamp[line as usize];
                    if *s != *serial {
                        *s = *serial;
                        distinct += 1;
                        if distinct > 1 {
                            break 'cells;
                        }
                    }
                }
            }
        }
        Node {
            c0,
            r0,
            c1,
            r1,
            record,
            several: distinct > 1,
        }
    }
}
