//! A frame's depth as the tracker keeps it: the planes stage's block-averaged 3D points
//! and normals, sub-sampled to a coarse grid of the image (memory: 80 x 60 nodes of a
//! VGA frame, 115 kB), for the depth alignment of the next frame.

use gfs_planes::NormalEstimator;
use nalgebra::Vector3;

/// 3D points and unit normals of a frame on a regular pixel grid, camera frame.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DepthGrid {
    /// Pixels between nodes; node `(i, j)` covers pixels `[i s, (i + 1) s) x [j s, ...)`.
    pub stride_px: u32,
    /// Nodes per row.
    pub width: u32,
    /// Node rows.
    pub height: u32,
    /// Node points, metres, row-major; z = 0 means no depth.
    pub points: Vec<[f32; 3]>,
    /// Unit normals towards the camera, row-major; all zeros means none.
    pub normals: Vec<[f32; 3]>,
}

impl DepthGrid {
    /// True without any node.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Keeps every `step`-th node of `estimator`'s grid (row and column), reusing the
    /// buffers.
    pub fn sample(&mut self, estimator: &NormalEstimator, step: usize) {
        let step = step.max(1);
        let (w, h) = (estimator.grid_width(), estimator.grid_height());
        self.stride_px = (estimator.stride() * step) as u32;
        self.width = (w / step) as u32;
        self.height = (h / step) as u32;
        self.points.clear();
        self.normals.clear();
        let (points, normals) = (estimator.points(), estimator.normals());
        for j in 0..self.height as usize {
            for i in 0..self.width as usize {
                // The node nearest the centre of the coarse cell.
                let k = (j * step + step / 2) * w + i * step + step / 2;
                self.points.push(points[k]);
                self.normals.push(normals[k]);
            }
        }
    }

    /// The node at pixel `(u, v)` with a point and a normal.
    pub fn at_pixel(&self, u: f64, v: f64) -> Option<(Vector3<f64>, Vector3<f64>)> {
        let s = f64::from(self.stride_px.max(1));
        let (i, j) = ((u / s).floor(), (v / s).floor());
        if i < 0.0 || j < 0.0 || i >= f64::from(self.width) || j >= f64::from(self.height) {
            return None;
        }
        self.node(j as usize * self.width as usize + i as usize)
    }

    /// Node `k` when it has a point and a normal.
    pub fn node(&self, k: usize) -> Option<(Vector3<f64>, Vector3<f64>)> {
        let (p, n) = (self.points.get(k)?, self.normals.get(k)?);
        (p[2] > 0.0 && n != &[0.0; 3]).then(|| {
            (
                Vector3::new(p[0].into(), p[1].into(), p[2].into()),
                Vector3::new(n[0].into(), n[1].into(), n[2].into()),
            )
        })
    }
}
