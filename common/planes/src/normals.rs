//! Pixel normals from back-projected depth on a strided grid (paper Sec. III-A,
//! Algorithm 1, `PixelNormalExtraction`).
//!
//! The depth image is cut into `stride x stride` blocks; each block becomes one grid
//! node holding a 3D point (the mean of the block's back-projected pixels, or its centre
//! pixel). A node's normal is `(right - left) x (up - down)` over its four grid
//! neighbours, computed only when all four have a point and none of them is across a
//! depth discontinuity, and oriented towards the camera.

use crate::error::PlaneError;
use gfs_core::ImageView;
use gfs_core::camera::PinholeCamera;

/// Accumulated depth of one block while its rows are being read.
#[derive(Clone, Copy, Debug, Default)]
struct BlockSum {
    /// Sum of valid depths (m).
    z: f32,
    /// Sum of `(u - u0) * z` over valid pixels, `u0` the block's first column.
    uz: f32,
    /// Sum of `(v - v0) * z` over valid pixels, `v0` the block's first row.
    vz: f32,
    /// Number of valid pixels.
    count: u32,
    /// Smallest valid depth (m).
    min: f32,
    /// Largest valid depth (m).
    max: f32,
}

impl BlockSum {
    const EMPTY: Self = Self {
        z: 0.0,
        uz: 0.0,
        vz: 0.0,
        count: 0,
        min: f32::INFINITY,
        max: 0.0,
    };
}

/// True for a usable depth: positive and finite (0.0 = missing; NaN fails both tests).
#[inline]
fn valid_depth(z: f32) -> bool {
    z > 0.0 && z < f32::INFINITY
}

/// Per-node 3D points and normals of a depth image on a strided grid, with reusable
/// buffers (one allocation for the first frame of a given size, none afterwards).
#[derive(Clone, Debug)]
pub struct NormalEstimator {
    stride: usize,
    average_blocks: bool,
    max_depth_jump_per_px: f32,
    grid_width: usize,
    grid_height: usize,
    /// Node points in the camera frame (m); z = 0 means no point.
    points: Vec<[f32; 3]>,
    /// Unit node normals in the camera frame, towards the camera; zero = no normal.
    normals: Vec<[f32; 3]>,
    /// Block sums of the grid row being read.
    row_sums: Vec<BlockSum>,
}

impl NormalEstimator {
    /// An estimator on a `stride` grid (`stride >= 1`; 0 is treated as 1), averaging each
    /// block or sampling its centre, with the relative depth-jump threshold per pixel of
    /// distance (see [`crate::PlaneConfig`]).
    pub fn new(stride: usize, average_blocks: bool, max_depth_jump_per_px: f32) -> Self {
        Self {
            stride: stride.max(1),
            average_blocks,
            max_depth_jump_per_px,
            grid_width: 0,
            grid_height: 0,
            points: Vec::new(),
            normals: Vec::new(),
            row_sums: Vec::new(),
        }
    }

    /// Computes the grid points and normals of `depth` (metres, 0.0 = missing) and
    /// returns the number of nodes with a normal. Images smaller than three blocks in
    /// either direction give an empty grid, not an error.
    ///
    /// # Errors
    /// [`PlaneError::SizeMismatch`] when `depth` is not the camera's size.
    pub fn compute(
        &mut self,
        depth: &ImageView<'_, f32>,
        camera: &PinholeCamera,
    ) -> Result<usize, PlaneError> {
        if depth.width() != camera.width || depth.height() != camera.height {
            return Err(PlaneError::SizeMismatch {
                depth_width: depth.width(),
                depth_height: depth.height(),
                camera_width: camera.width,
                camera_height: camera.height,
            });
        }
        self.grid_width = depth.width() / self.stride;
        self.grid_height = depth.height() / self.stride;
        let nodes = self.grid_width * self.grid_height;
        self.points.clear();
        self.points.resize(nodes, [0.0; 3]);
        self.normals.clear();
        self.normals.resize(nodes, [0.0; 3]);
        if self.average_blocks {
            self.block_points(depth, camera);
        } else {
            self.centre_points(depth, camera);
        }
        Ok(self.cross_normals())
    }

    /// Node points as the mean of each block's back-projected valid pixels. A block needs
    /// half of its pixels valid and a depth range within the jump threshold, so that a
    /// block straddling an occlusion edge gives no (ghost) point.
    fn block_points(&mut self, depth: &ImageView<'_, f32>, camera: &PinholeCamera) {
        let s = self.stride;
        let min_count = (s * s).div_ceil(2) as u32;
        let max_spread = self.max_depth_jump_per_px * s as f32;
        self.row_sums.clear();
        self.row_sums.resize(self.grid_width, BlockSum::EMPTY);
        for gy in 0..self.grid_height {
            self.row_sums.fill(BlockSum::EMPTY);
            for dy in 0..s {
                let row = depth.row(gy * s + dy);
                // Fixed block widths let the compiler unroll the block loop.
                match s {
                    2 => accumulate_row::<2>(row, s, dy, &mut self.row_sums),
                    4 => accumulate_row::<4>(row, s, dy, &mut self.row_sums),
                    8 => accumulate_row::<8>(row, s, dy, &mut self.row_sums),
                    _ => accumulate_row::<0>(row, s, dy, &mut self.row_sums),
                }
            }
            let out = &mut self.points[gy * self.grid_width..(gy + 1) * self.grid_width];
            for (gx, (sum, point)) in self.row_sums.iter().zip(out).enumerate() {
                if sum.count < min_count {
                    continue;
                }
                let mean_z = sum.z / sum.count as f32;
                if sum.max - sum.min > max_spread * mean_z {
                    continue;
                }
                // The mean of the back-projected points is the back-projection of the
                // depth-weighted mean pixel at the mean depth (x is linear in u*z).
                let u = (gx * s) as f64 + f64::from(sum.uz / sum.z);
                let v = (gy * s) as f64 + f64::from(sum.vz / sum.z);
                let p = camera.back_project(u, v, f64::from(mean_z));
                *point = [p.x as f32, p.y as f32, p.z as f32];
            }
        }
    }

    /// Node points as the back-projected centre pixel of each block.
    fn centre_points(&mut self, depth: &ImageView<'_, f32>, camera: &PinholeCamera) {
        let s = self.stride;
        let half = s / 2;
        for gy in 0..self.grid_height {
            let v = gy * s + half;
            let row = depth.row(v);
            let out = &mut self.points[gy * self.grid_width..(gy + 1) * self.grid_width];
            for (gx, point) in out.iter_mut().enumerate() {
                let u = gx * s + half;
                let z = row[u];
                if valid_depth(z) {
                    let p = camera.back_project(u as f64, v as f64, f64::from(z));
                    *point = [p.x as f32, p.y as f32, p.z as f32];
                }
            }
        }
    }

    /// Algorithm 1: `(right - left) x (up - down)` at every interior node whose four
    /// neighbours have points within the depth-jump threshold; returns the count.
    fn cross_normals(&mut self) -> usize {
        let (w, h) = (self.grid_width, self.grid_height);
        if w < 3 || h < 3 {
            return 0;
        }
        let max_jump = self.max_depth_jump_per_px * self.stride as f32;
        let mut count = 0;
        for gy in 1..h - 1 {
            for gx in 1..w - 1 {
                let i = gy * w + gx;
                let c = self.points[i];
                if c[2] <= 0.0 {
                    continue;
                }
                let [l, r, u, d] = [
                    self.points[i - 1],
                    self.points[i + 1],
                    self.points[i - w],
                    self.points[i + w],
                ];
                let limit = max_jump * c[2];
                // A missing neighbour has z = 0 and fails this test as well.
                if [l, r, u, d].iter().any(|p| (p[2] - c[2]).abs() > limit) {
                    continue;
                }
                let a = sub(r, l);
                let b = sub(u, d);
                let mut n = [
                    a[1] * b[2] - a[2] * b[1],
                    a[2] * b[0] - a[0] * b[2],
                    a[0] * b[1] - a[1] * b[0],
                ];
                let norm = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                if norm <= f32::MIN_POSITIVE || !norm.is_finite() {
                    continue;
                }
                // Towards the camera: the surface faces the viewer, so n . p < 0.
                let sign = if n[0] * c[0] + n[1] * c[1] + n[2] * c[2] > 0.0 {
                    -1.0 / norm
                } else {
                    1.0 / norm
                };
                n.iter_mut().for_each(|x| *x *= sign);
                self.normals[i] = n;
                count += 1;
            }
        }
        count
    }

    /// Grid columns of the last frame (`width / stride`).
    pub fn grid_width(&self) -> usize {
        self.grid_width
    }

    /// Grid rows of the last frame (`height / stride`).
    pub fn grid_height(&self) -> usize {
        self.grid_height
    }

    /// Pixel stride of the grid.
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// Node points (camera frame, m), row-major over the grid; z = 0 means no point.
    pub fn points(&self) -> &[[f32; 3]] {
        &self.points
    }

    /// Unit node normals (camera frame, towards the camera), row-major over the grid;
    /// all zeros means no normal.
    pub fn normals(&self) -> &[[f32; 3]] {
        &self.normals
    }
}

/// Adds one image row to the sums of the blocks it crosses: `N` is the block width when
/// known at compile time, 0 for the run-time `stride`.
#[inline]
fn accumulate_row<const N: usize>(row: &[f32], stride: usize, dy: usize, sums: &mut [BlockSum]) {
    let width = if N == 0 { stride } else { N };
    for (sum, block) in sums.iter_mut().zip(row.chunks_exact(width)) {
        let (mut row_z, mut uz, mut count) = (0.0, 0.0, 0);
        let (mut min, mut max) = (sum.min, sum.max);
        // Branch-free (selects): holes are frequent and unpredictable.
        for (dx, &z) in block.iter().enumerate() {
            let ok = valid_depth(z);
            let z_or_zero = if ok { z } else { 0.0 };
            row_z += z_or_zero;
            uz += dx as f32 * z_or_zero;
            count += u32::from(ok);
            min = min.min(if ok { z } else { f32::INFINITY });
            max = max.max(z_or_zero);
        }
        sum.z += row_z;
        sum.uz += uz;
        sum.vz += dy as f32 * row_z;
        sum.count += count;
        sum.min = min;
        sum.max = max;
    }
}

#[inline]
fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[cfg(test)]
mod tests {
    use super::*;
    use gfs_core::Image;

    /// A plane z = 2 + 0.5 x seen by a 64 x 48 camera: every interior node's normal is
    /// the plane's, within 1e-3 rad, in both sampling modes.
    #[test]
    fn tilted_plane_normals_are_exact() {
        let cam = PinholeCamera::new(60.0, 60.0, 31.5, 23.5, 64, 48);
        let mut depth = Image::<f32>::new(64, 48);
        for v in 0..48 {
            for u in 0..64 {
                // Ray (x, y, 1) * t hits z = 2 + 0.5 x at t = 2 / (1 - 0.5 x).
                let x = (u as f64 - cam.cx) / cam.fx;
                depth.set(u, v, (2.0 / (1.0 - 0.5 * x)) as f32);
            }
        }
        // n ~ (0.5, 0, -1) normalised, towards the camera.
        let truth = [0.5 / 1.25f32.sqrt(), 0.0, -1.0 / 1.25f32.sqrt()];
        for average in [true, false] {
            let mut est = NormalEstimator::new(4, average, 0.015);
            let count = est.compute(&depth.view(), &cam).unwrap();
            assert_eq!(count, (16 - 2) * (12 - 2), "average {average}");
            for n in est.normals().iter().filter(|n| **n != [0.0; 3]) {
                let dot = n[0] * truth[0] + n[1] * truth[1] + n[2] * truth[2];
                assert!(dot > (1e-3f32).cos(), "average {average}: {n:?}");
            }
        }
    }

    #[test]
    fn wrong_size_is_an_error_and_tiny_images_give_no_normals() {
        let cam = PinholeCamera::new(60.0, 60.0, 31.5, 23.5, 64, 48);
        let depth = Image::<f32>::new(10, 10);
        let mut est = NormalEstimator::new(4, true, 0.015);
        assert!(matches!(
            est.compute(&depth.view(), &cam),
            Err(PlaneError::SizeMismatch {
                depth_width: 10,
                ..
            })
        ));
        for (w, h) in [(0, 0), (1, 1), (5, 3), (11, 30)] {
            let cam = PinholeCamera::new(60.0, 60.0, 0.0, 0.0, w, h);
            let mut depth = Image::<f32>::new(w, h);
            depth.fill(1.0);
            assert_eq!(est.compute(&depth.view(), &cam).unwrap(), 0, "{w}x{h}");
        }
    }
}
