//! A grid of keypoints for search by projection (ORB-SLAM2 `Frame::GetFeaturesInArea`):
//! a map point projected at `(u, v)` looks only at the keypoints of the cells its search
//! window touches.
//!
//! Layout: compressed rows (one offset per cell into one entry array, filled by a
//! counting sort), entries holding a copy of position and level so that the search
//! reads one contiguous run per cell. Rebuilt in place every frame.

use crate::keypoint::KeyPoint;

#[derive(Clone, Copy, Debug)]
struct Entry {
    u: f32,
    v: f32,
    level: u32,
    index: u32,
}

/// Keypoints of one frame bucketed by square cells.
#[derive(Clone, Debug)]
pub struct KeyPointGrid {
    cell: f32,
    cols: usize,
    rows: usize,
    /// `starts[c]..starts[c + 1]` are the entries of cell `c` (row-major cells).
    starts: Vec<u32>,
    entries: Vec<Entry>,
    cell_of: Vec<u32>,
}

/// Cell side of ORB-SLAM2's 64x48 grid on a 640x480 image.
pub const DEFAULT_CELL_PX: f32 = 10.0;

impl KeyPointGrid {
    /// An empty grid over a `width x height` image with square cells of `cell_px` pixels
    /// (a non-finite or sub-pixel size becomes [`DEFAULT_CELL_PX`]).
    pub fn new(width: usize, height: usize, cell_px: f32) -> Self {
        let cell = if cell_px.is_finite() && cell_px >= 1.0 {
            cell_px
        } else {
            DEFAULT_CELL_PX
        };
        let cols = ((width as f32 / cell).ceil() as usize).max(1);
        let rows = ((height as f32 / cell).ceil() as usize).max(1);
        Self {
            cell,
            cols,
            rows,
            starts: vec![0; cols * rows + 1],
            entries: Vec::new(),
            cell_of: Vec::new(),
        }
    }

    /// Replaces the content with `keypoints`; a keypoint outside the image (or with a
    /// non-finite position) is left out.
    pub fn build(&mut self, keypoints: &[KeyPoint]) {
        let cells = self.cols * self.rows;
        self.starts.clear();
        self.starts.resize(cells + 1, 0);
        self.cell_of.clear();
        for kp in keypoints {
            let c = self
                .cell_at(kp.u, kp.v)
                .map_or(u32::MAX, |(cx, cy)| (cy * self.cols + cx) as u32);
            self.cell_of.push(c);
            if c != u32::MAX {
                self.starts[c as usize + 1] += 1;
            }
        }
        for c in 0..cells {
            self.starts[c + 1] += self.starts[c];
        }
        let total = self.starts[cells] as usize;
        self.entries.clear();
        self.entries.resize(
            total,
            Entry {
                u: 0.0,
                v: 0.0,
                level: 0,
                index: 0,
            },
        );
        // Fill from each cell's start, using `starts[c]` as a cursor, then shift back.
        for (i, (kp, &c)) in keypoints.iter().zip(&self.cell_of).enumerate() {
            if c == u32::MAX {
                continue;
            }
            let slot = &mut self.starts[c as usize];
            self.entries[*slot as usize] = Entry {
                u: kp.u,
                v: kp.v,
                level: kp.level,
                index: i as u32,
            };
            *slot += 1;
        }
        for c in (1..=cells).rev() {
            self.starts[c] = self.starts[c - 1];
        }
        self.starts[0] = 0;
    }

    /// Number of keypoints in the grid.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// True when the grid holds no keypoint.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Cell `(column, row)` of a point, `None` outside the grid.
    fn cell_at(&self, u: f32, v: f32) -> Option<(usize, usize)> {
        if !(u >= 0.0 && v >= 0.0) {
            return None;
        }
        let (cx, cy) = ((u / self.cell) as usize, (v / self.cell) as usize);
        (cx < self.cols && cy < self.rows).then_some((cx, cy))
    }

    /// Replaces `out` with the indices (into the slice given to [`KeyPointGrid::build`])
    /// of the keypoints with `|u' - u| < radius`, `|v' - v| < radius` and level in
    /// `min_level..=max_level`, as ORB-SLAM2's square window. Order: by cell, row-major.
    pub fn features_in_area(
        &self,
        u: f32,
        v: f32,
        radius: f32,
        min_level: u32,
        max_level: u32,
        out: &mut Vec<usize>,
    ) {
        out.clear();
        if !(u.is_finite() && v.is_finite() && radius > 0.0) {
            return;
        }
        let lo_x = ((u - radius) / self.cell).floor().max(0.0);
        let lo_y = ((v - radius) / self.cell).floor().max(0.0);
        let hi_x = ((u + radius) / self.cell).floor();
        let hi_y = ((v + radius) / self.cell).floor();
        if hi_x < 0.0 || hi_y < 0.0 {
            return;
        }
        let (x0, y0) = (lo_x as usize, lo_y as usize);
        let x1 = (hi_x as usize).min(self.cols - 1);
        let y1 = (hi_y as usize).min(self.rows - 1);
        if x0 > x1 || y0 > y1 {
            return;
        }
        for cy in y0..=y1 {
            for cx in x0..=x1 {
                let c = cy * self.cols + cx;
                let run = &self.entries[self.starts[c] as usize..self.starts[c + 1] as usize];
                for e in run {
                    if (e.u - u).abs() < radius
                        && (e.v - v).abs() < radius
                        && e.level >= min_level
                        && e.level <= max_level
                    {
                        out.push(e.index as usize);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kp(u: f32, v: f32, level: u32) -> KeyPoint {
        KeyPoint {
            u,
            v,
            level,
            ..KeyPoint::default()
        }
    }

    #[test]
    fn area_search_equals_brute_force() {
        // A 23x17 lattice of keypoints with levels 0..3, searched at many centres/radii.
        let mut kps = Vec::new();
        for j in 0..17 {
            for i in 0..23 {
                kps.push(kp(
                    i as f32 * 27.7 + 3.1,
                    j as f32 * 28.1 + 1.3,
                    ((i + j) % 4) as u32,
                ));
            }
        }
        kps.push(kp(-5.0, 10.0, 0)); // outside: never returned
        kps.push(kp(f32::NAN, 10.0, 0));
        let mut grid = KeyPointGrid::new(640, 480, 16.0);
        grid.build(&kps);
        assert_eq!(grid.len(), 23 * 17);
        let mut out = Vec::new();
        let mut counts = Vec::new();
        for (u, v, r, lo, hi) in [
            (100.0, 100.0, 15.0, 0, u32::MAX),
            (320.5, 240.2, 60.0, 1, 2),
            (0.0, 0.0, 40.0, 0, 0),
            (639.0, 479.0, 100.0, 2, 3),
            (-50.0, -50.0, 30.0, 0, 9),
        ] {
            grid.features_in_area(u, v, r, lo, hi, &mut out);
            let mut expect: Vec<usize> = kps
                .iter()
                .enumerate()
                .filter(|(_, k)| k.u >= 0.0 && k.v >= 0.0)
                .filter(|(_, k)| {
                    (k.u - u).abs() < r && (k.v - v).abs() < r && k.level >= lo && k.level <= hi
                })
                .map(|(i, _)| i)
                .collect();
            out.sort_unstable();
            expect.sort_unstable();
            assert_eq!(out, expect, "({u}, {v}) r={r}");
            counts.push(out.len());
        }
        // 2x2 lattice points; 4x4 of which half on levels 1-2; the corner one; 2x2 of
        // levels 2-3 at the far corner; none.
        assert_eq!(counts, vec![4, 8, 1, 4, 0]);
        grid.build(&[]);
        grid.features_in_area(100.0, 100.0, 50.0, 0, 9, &mut out);
        assert!(grid.is_empty() && out.is_empty());
    }
}
