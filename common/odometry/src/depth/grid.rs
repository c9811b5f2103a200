//! A frame's depth as the tracker keeps it: the planes stage's block-averaged 3D points
//! and normals, sub-sampled to a coarse grid of the image, and the mean gray levels of
//! finer pixel cells and of blocks of them (memory: 80 x 60 nodes, 160 x 120 cells and
//! 80 x 60 blocks of a VGA frame, 211 kB), for the depth and photometric alignment of
//! the next frames.

use gfs_core::ImageView;
use gfs_optim::residuals::IntensityGrid;
use gfs_planes::NormalEstimator;
use nalgebra::{Isometry3, Vector3};

/// 3D points and unit normals of a frame on a regular pixel grid, camera frame.
#[derive(Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
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
    /// Mean gray level of each `intensity_cell_px` square of pixels over the grid's
    /// extent, row-major, blurred; empty when the intensities were not sampled.
    #[serde(default)]
    pub intensity: Vec<f32>,
    /// Pixels per intensity cell side (a divisor of `stride_px`); 0 = `stride_px`.
    #[serde(default)]
    pub intensity_cell_px: u32,
    /// The means of 2 x 2 blurred `intensity` cells, row-major
    /// ([`IntensityLevel::Coarse`]); empty when the intensities were not sampled.
    #[serde(default)]
    pub coarse_intensity: Vec<f32>,
    /// The gray image's pixel noise where the cells were sampled, gray levels (its
    /// Laplacian's mean magnitude, Immerkaer 1996); `None` when not measured.
    #[serde(default)]
    pub pixel_noise: Option<f32>,
}

/// Pixel noise, gray levels, below which an 8-bit image's rounding is not dithered: a
/// smooth surface then shows rounding contours, which a change of exposure moves
/// across it. `gfsvo synth`'s low-texture frames measure 0.03 / 0.12 / 0.27 / 0.47 gray
/// levels rendered with 0 / 0.1 / 0.25 / 0.5 gray levels of noise per channel (slow
/// seed 29 tracked 413 / 333 / 20 / 1.5 mm off with all terms, every frame `tracked`
/// before this was measured), 1.4 with the default 2; TUM fr1's 0.6-1.1.
pub const MIN_DITHERING_NOISE: f32 = 0.35;

/// Rows of the image between those the pixel noise is measured on.
const NOISE_ROW_STEP: usize = 8;

/// The pixel noise of the `width` x `height` top-left part of `gray`, gray levels: the
/// mean magnitude of the Laplacian difference `[1 -2 1; -2 4 -2; 1 -2 1]` (zero on a
/// plane, so smooth shading adds nothing) times `sqrt(pi / 2) / 6` (Immerkaer 1996), on
/// every [`NOISE_ROW_STEP`]-th row; `None` on an image under 3 x 3 pixels.
fn pixel_noise(gray: &ImageView<'_, u8>, width: usize, height: usize) -> Option<f32> {
    if width < 3 || height < 3 {
        return None;
    }
    let (mut sum, mut count) = (0u64, 0u64);
    for y in (1..height - 1).step_by(NOISE_ROW_STEP) {
        let rows = [gray.row(y - 1), gray.row(y), gray.row(y + 1)];
        for x in 1..width - 1 {
            let at = |r: usize, dx: usize| i32::from(rows[r][x + dx - 1]);
            let laplacian = at(0, 0) - 2 * at(0, 1) + at(0, 2) - 2 * at(1, 0) + 4 * at(1, 1)
                - 2 * at(1, 2)
                + at(2, 0)
                - 2 * at(2, 1)
                + at(2, 2);
            sum += u64::from(laplacian.unsigned_abs());
            count += 1;
        }
    }
    let scale = (std::f64::consts::FRAC_PI_2).sqrt() / 6.0;
    Some((scale * sum as f64 / count as f64) as f32)
}

/// Which of a depth grid's intensities the photometric term reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IntensityLevel {
    /// The blurred cells.
    Cells,
    /// Means of 2 x 2 blurred cells. Their values are about as noisy as the cells' (on
    /// `gfsvo synth`'s frames a sample differs from its reference at the true pose by
    /// 0.11 gray levels here, 0.12 on the cells, its neighbour's error correlated 0.5
    /// either way), their gradients, taken over twice the distance, half as noisy: a
    /// paint coarser than the cells fixes a pose here that the cells' gradient noise
    /// hides (the record's "Coarser intensity cells for a frame the cells leave weak").
    Coarse,
}

/// `clone_from` copies into the buffers already there (the derived one allocates anew):
/// the tracker keeps a keyframe's grid this way at every keyframe.
impl Clone for DepthGrid {
    fn clone(&self) -> Self {
        let mut grid = Self::default();
        grid.clone_from(self);
        grid
    }

    fn clone_from(&mut self, source: &Self) {
        self.stride_px = source.stride_px;
        self.width = source.width;
        self.height = source.height;
        self.points.clone_from(&source.points);
        self.normals.clone_from(&source.normals);
        self.intensity.clone_from(&source.intensity);
        self.intensity_cell_px = source.intensity_cell_px;
        self.coarse_intensity.clone_from(&source.coarse_intensity);
        self.pixel_noise = source.pixel_noise;
    }
}

impl DepthGrid {
    /// Pixels per intensity cell side of the grids the front end makes: finer than the
    /// nodes, the cells keep the paint's finer texture.
    pub const INTENSITY_CELL_PX: u32 = 4;

    /// Cell side, cells per row and rows of the intensities.
    fn intensity_layout(&self) -> (usize, usize, usize) {
        let cell = if self.intensity_cell_px == 0 {
            self.stride_px
        } else {
            self.intensity_cell_px
        } as usize;
        let extent = |nodes: u32| (nodes * self.stride_px) as usize / cell.max(1);
        (cell, extent(self.width), extent(self.height))
    }

    /// Cell side, cells per row and rows of the intensities at `level`.
    fn level_layout(&self, level: IntensityLevel) -> (usize, usize, usize) {
        let (cell, w, h) = self.intensity_layout();
        match level {
            IntensityLevel::Cells => (cell, w, h),
            IntensityLevel::Coarse => (2 * cell, w / 2, h / 2),
        }
    }

    /// True without any node.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// True when a node has a depth (an unreadable frame's grid has none).
    pub fn has_depth(&self) -> bool {
        self.points.iter().any(|p| p[2] > 0.0)
    }

    /// Keeps every `step`-th node of `estimator`'s grid (row and column), without
    /// intensities, reusing the buffers.
    pub fn sample(&mut self, estimator: &NormalEstimator, step: usize) {
        let step = step.max(1);
        let (w, h) = (estimator.grid_width(), estimator.grid_height());
        self.stride_px = (estimator.stride() * step) as u32;
        self.width = (w / step) as u32;
        self.height = (h / step) as u32;
        self.points.clear();
        self.normals.clear();
        // New nodes: the last frame's intensities no longer belong to them.
        self.intensity.clear();
        self.coarse_intensity.clear();
        self.pixel_noise = None;
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

    /// Averages `gray` over cells of `cell_px` (`[i s, (i + 1) s) x [j s, (j + 1) s)`)
    /// over the grid's extent and makes both levels of them, reusing the buffers;
    /// nothing when the image does not cover the grid or `cell_px` does not divide the
    /// node stride.
    pub fn sample_intensity(&mut self, gray: &ImageView<'_, u8>, cell_px: u32) {
        self.intensity.clear();
        self.coarse_intensity.clear();
        self.pixel_noise = None;
        self.intensity_cell_px = cell_px;
        let (s, w, h) = self.intensity_layout();
        if s == 0
            || !(self.stride_px as usize).is_multiple_of(s)
            || gray.width() < w * s
            || gray.height() < h * s
        {
            return;
        }
        self.intensity.resize(w * h, 0.0);
        for y in 0..h * s {
            let row = &gray.row(y)[..w * s];
            let cells = &mut self.intensity[(y / s) * w..(y / s + 1) * w];
            for (cell, pixels) in cells.iter_mut().zip(row.chunks_exact(s)) {
                *cell += pixels.iter().map(|&p| f32::from(p)).sum::<f32>();
            }
        }
        let area = (s * s) as f32;
        self.intensity.iter_mut().for_each(|v| *v /= area);
        self.blur_and_coarsen_intensity();
        self.pixel_noise = pixel_noise(gray, w * s, h * s);
    }

    /// False when the image the intensities were sampled from is too clean for its
    /// 8-bit rounding to be dithered ([`MIN_DITHERING_NOISE`]); true when not measured.
    pub fn rounding_is_dithered(&self) -> bool {
        self.pixel_noise
            .is_none_or(|noise| noise >= MIN_DITHERING_NOISE)
    }

    /// Blurs the intensities with the binomial kernel `[1 4 6 4 1] / 16` along rows and
    /// columns (a Gaussian of about one cell), in place, then averages them into the
    /// coarse level. The photometric term reads them between cells: bilinear
    /// interpolation of noise that is independent from cell to cell has less variance
    /// between cells than at them, and on faint texture that variance pulls the pose
    /// towards whole-cell shifts (a wall and the floor moving 1 cm a frame were tracked
    /// 7 % short); correlated noise interpolates evenly.
    pub fn blur_and_coarsen_intensity(&mut self) {
        self.coarse_intensity.clear();
        let (_, w, h) = self.intensity_layout();
        if w == 0 || self.intensity.len() != w * h {
            return;
        }
        for _ in 0..2 {
            for j in 0..h {
                smooth_line(&mut self.intensity, j * w, 1, w);
            }
            for i in 0..w {
                smooth_line(&mut self.intensity, i, w, h);
            }
        }
        self.coarsen_intensity();
    }

    /// Makes the coarse level again from the cells (means of 2 x 2 of them).
    pub fn coarsen_intensity(&mut self) {
        self.coarse_intensity.clear();
        let (_, w, h) = self.intensity_layout();
        if w == 0 || self.intensity.len() != w * h {
            return;
        }
        let (_, cw, ch) = self.level_layout(IntensityLevel::Coarse);
        for j in 0..ch {
            let (top, bottom) = (
                &self.intensity[2 * j * w..(2 * j + 1) * w],
                &self.intensity[(2 * j + 1) * w..(2 * j + 2) * w],
            );
            self.coarse_intensity.extend(
                top.chunks_exact(2)
                    .zip(bottom.chunks_exact(2))
                    .take(cw)
                    .map(|(t, b)| 0.25 * (t[0] + t[1] + b[0] + b[1])),
            );
        }
    }

    /// The intensities at `level` as the photometric term reads them; `None` when not
    /// sampled.
    pub fn intensity_grid(&self, level: IntensityLevel) -> Option<IntensityGrid<'_>> {
        let (cell, w, h) = self.level_layout(level);
        let values = match level {
            IntensityLevel::Cells => &self.intensity,
            IntensityLevel::Coarse => &self.coarse_intensity,
        };
        (w > 0 && values.len() == w * h).then_some(IntensityGrid {
            stride_px: cell as u32,
            width: w,
            height: h,
            values,
        })
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

    /// The surface at pixel `(u, v)`: the four nodes around it blended bilinearly when
    /// they are one surface (each normal within `min_cos` of the first's, each point
    /// within `max_step_m` of the first's plane), else the node at the pixel. The node
    /// at the pixel alone would leave up to half a node between a paired point and its
    /// reference along the surface (15 mm at 2 m), and through the normals' noise that
    /// offset pulls the pose towards where the frame's nodes fall on the reference's,
    /// as cell shifts pulled the photometric term
    /// ([`Self::blur_and_coarsen_intensity`]). The third value is the surface normal's
    /// noise variance as a share of one node's: the sum of the squared weights of the
    /// nodes blended (1 at a node).
    pub fn surface_at_pixel(
        &self,
        u: f64,
        v: f64,
        min_cos: f64,
        max_step_m: f64,
    ) -> Option<(Vector3<f64>, Vector3<f64>, f64)> {
        let at_node = |(p, n)| (p, n, 1.0);
        let s = f64::from(self.stride_px.max(1));
        // Node (i, j)'s point is its block's mean: it stands at the block's centre.
        let (x, y) = (u / s - 0.5, v / s - 0.5);
        let (i, j) = (x.floor(), y.floor());
        if i < 0.0
            || j < 0.0
            || i + 1.0 >= f64::from(self.width)
            || j + 1.0 >= f64::from(self.height)
        {
            return self.at_pixel(u, v).map(at_node);
        }
        let width = self.width as usize;
        let k = j as usize * width + i as usize;
        let (Some(a), Some(b), Some(c), Some(d)) = (
            self.node(k),
            self.node(k + 1),
            self.node(k + width),
            self.node(k + width + 1),
        ) else {
            return self.at_pixel(u, v).map(at_node);
        };
        let one_surface = [&b, &c, &d]
            .iter()
            .all(|(p, n)| n.dot(&a.1) >= min_cos && a.1.dot(&(p - a.0)).abs() <= max_step_m);
        if !one_surface {
            return self.at_pixel(u, v).map(at_node);
        }
        let (fx, fy) = (x - i, y - j);
        let weights = [
            (1.0 - fx) * (1.0 - fy),
            fx * (1.0 - fy),
            (1.0 - fx) * fy,
            fx * fy,
        ];
        let (mut point, mut normal) = (Vector3::zeros(), Vector3::zeros());
        for ((p, n), w) in [a, b, c, d].iter().zip(weights) {
            point += p * w;
            normal += n * w;
        }
        let share = weights.iter().map(|w| w * w).sum();
        Some((point, normal.normalize(), share))
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

/// `[1 2 1] / 4` in place along the `n` values of `values` from `start`, `stride`
/// apart, the end values repeated past the ends.
fn smooth_line(values: &mut [f32], start: usize, stride: usize, n: usize) {
    let mut previous = values[start];
    for k in 0..n {
        let at = start + k * stride;
        let current = values[at];
        let next = if k + 1 < n {
            values[at + stride]
        } else {
            current
        };
        values[at] = 0.25 * (previous + 2.0 * current + next);
        previous = current;
    }
}

/// A depth grid with the pose of the camera that took it: the two sides of a depth or
/// photometric association.
#[derive(Clone, Copy, Debug)]
pub struct PosedGrid<'a> {
    /// The grid.
    pub grid: &'a DepthGrid,
    /// Where its camera was.
    pub camera_from_world: &'a Isometry3<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use gfs_core::GrayImage;
    use gfs_core::rng::SplitMix64;

    #[test]
    fn intensities_are_cell_means_finer_than_the_nodes() {
        // A horizontal ramp: gray = x / 4, 640 x 480.
        let pixels = (0..480)
            .flat_map(|_| (0..640).map(|x| (x / 4) as u8))
            .collect();
        let gray = GrayImage::from_vec(640, 480, pixels).expect("size");
        let mut grid = sampled(&gray);
        let image = grid.intensity_grid(IntensityLevel::Cells).expect("sampled");
        assert_eq!((image.width, image.height, image.stride_px), (160, 120, 4));
        // A cell's mean is its pixels' (x / 4 constant over a 4 px cell); the blur keeps
        // a ramp away from the border.
        let (value, gradient) = image
            .intensity_and_gradient(4.0 * 50.0 + 1.5, 200.0)
            .expect("inside");
        assert!((value - 50.0).abs() < 1e-4, "{value}");
        assert!((gradient[0] - 0.25).abs() < 1e-5 && gradient[1].abs() < 1e-5);
        // A cell that does not divide the node stride samples nothing.
        grid.sample_intensity(&gray.view(), 3);
        assert!(grid.intensity_grid(IntensityLevel::Cells).is_none());
        assert!(grid.intensity_grid(IntensityLevel::Coarse).is_none());
    }

    /// A VGA grid's two levels of `gray`.
    fn sampled(gray: &GrayImage) -> DepthGrid {
        let mut grid = DepthGrid {
            stride_px: 8,
            width: 80,
            height: 60,
            ..DepthGrid::default()
        };
        grid.sample_intensity(&gray.view(), DepthGrid::INTENSITY_CELL_PX);
        grid
    }

    #[test]
    fn the_pixel_noise_tells_a_dithered_image_from_a_clean_one() {
        // A shading ramp over 640 pixels and a bump, rounded to 8 bits: with 2 gray
        // levels of noise (as `gfsvo synth` renders), 0.5, or none before the rounding.
        let image = |noise: f64| {
            let mut rng = SplitMix64::new(5);
            let shade = |x: f64, y: f64| {
                90.0 + 0.1 * x + 20.0 * (-((x - 320.0).powi(2) + (y - 240.0).powi(2)) / 2e4).exp()
            };
            GrayImage::from_vec(
                640,
                480,
                (0..480)
                    .flat_map(|y| (0..640).map(move |x| (f64::from(x), f64::from(y))))
                    .map(|(x, y)| (shade(x, y) + noise * rng.gaussian()).round() as u8)
                    .collect(),
            )
            .expect("size")
        };
        let measured = |noise| sampled(&image(noise)).pixel_noise.expect("measured");
        let (noisy, faint, clean) = (measured(2.0), measured(0.5), measured(0.0));
        assert!((noisy - 2.0).abs() < 0.2, "{noisy}");
        assert!((faint - 0.55).abs() < 0.1, "{faint}");
        assert!(clean < 0.1, "{clean}");
        assert!(sampled(&image(0.5)).rounding_is_dithered());
        assert!(!sampled(&image(0.0)).rounding_is_dithered());
        // Not measured (a grid not sampled from an image): taken as dithered.
        assert!(DepthGrid::default().rounding_is_dithered());
    }

    #[test]
    fn the_coarse_level_reads_a_ramp_as_the_cells_do_with_half_their_gradient_noise() {
        let ramp = GrayImage::from_vec(
            640,
            480,
            (0..480)
                .flat_map(|_| (0..640).map(|x| (x / 4) as u8))
                .collect(),
        )
        .expect("size");
        let grid = sampled(&ramp);
        let (cells, coarse) = (
            grid.intensity_grid(IntensityLevel::Cells).expect("cells"),
            grid.intensity_grid(IntensityLevel::Coarse).expect("coarse"),
        );
        assert_eq!((coarse.width, coarse.height, coarse.stride_px), (80, 60, 8));
        for u in [203.5, 300.0, 417.25] {
            let (a, b) = (
                cells.intensity_and_gradient(u, 200.0).expect("inside"),
                coarse.intensity_and_gradient(u, 200.0).expect("inside"),
            );
            assert!((a.0 - b.0).abs() < 1e-4, "{u}: {} / {}", a.0, b.0);
            assert!((b.1[0] - 0.25).abs() < 1e-5 && b.1[1].abs() < 1e-5, "{u}");
        }
        // Uniform gray with 4 gray levels of noise independent from pixel to pixel: the
        // coarse gradients are about half as noisy as the cells'.
        let mut rng = SplitMix64::new(11);
        let noisy = GrayImage::from_vec(
            640,
            480,
            (0..640 * 480)
                .map(|_| (128.0 + 4.0 * rng.gaussian()).round() as u8)
                .collect(),
        )
        .expect("size");
        let grid = sampled(&noisy);
        let spread = |level| {
            let image = grid.intensity_grid(level).expect("sampled");
            let samples: Vec<f64> = (4..60)
                .flat_map(|j| (4..76).map(move |i| (8.0 * f64::from(i), 8.0 * f64::from(j))))
                .filter_map(|(u, v)| image.intensity_and_gradient(u, v))
                .map(|(_, g)| g[0])
                .collect();
            (samples.iter().map(|g| g * g).sum::<f64>() / samples.len() as f64).sqrt()
        };
        let ratio = spread(IntensityLevel::Coarse) / spread(IntensityLevel::Cells);
        assert!((0.3..0.6).contains(&ratio), "{ratio}");
    }

    #[test]
    fn the_surface_between_nodes_is_blended_and_a_step_is_not() {
        use crate::testing::{camera, planes_depth};
        use nalgebra::{Isometry3, Point3};
        let camera = camera();
        // A wall 2 m ahead, turned 20 degrees about the vertical.
        let normal = [20f64.to_radians().sin(), 0.0, 20f64.to_radians().cos()];
        let mut grid = planes_depth(&camera, &Isometry3::identity(), &[(normal, 2.0)]);
        let min_cos = 30f64.to_radians().cos();
        // A pixel at a corner of four nodes: the blend is on the wall where the pixel
        // looks, the node at the pixel is half a node (4 px) away along each axis.
        let (u, v) = (8.0 * 30.0, 8.0 * 20.0);
        let seen_at = |p: &Vector3<f64>| camera.project(&Point3::from(*p)).expect("ahead");
        let (blended, n, share) = grid.surface_at_pixel(u, v, min_cos, 0.015).expect("wall");
        // At the corner of four nodes, each weighs a quarter: a quarter of the variance.
        assert!((share - 0.25).abs() < 1e-9, "{share}");
        let uv = seen_at(&blended);
        assert!((uv.x - u).abs() < 0.05 && (uv.y - v).abs() < 0.05, "{uv}");
        assert!((Vector3::from(normal).dot(&blended) - 2.0).abs() < 1e-4);
        assert!(n.dot(&-Vector3::from(normal)) > 0.9999, "{n}");
        let (node, _) = grid.at_pixel(u, v).expect("wall");
        let uv = seen_at(&node);
        assert!(
            (uv.x - (u + 4.0)).abs() < 0.05 && (uv.y - (v + 4.0)).abs() < 0.05,
            "{uv}"
        );
        // The columns from 30 on stand 5 cm closer: a step, not one surface.
        for j in 0..grid.height as usize {
            for i in 30..grid.width as usize {
                let p = &mut grid.points[j * grid.width as usize + i];
                let scale = (p[2] - 0.05) / p[2];
                p.iter_mut().for_each(|c| *c *= scale);
            }
        }
        assert_eq!(
            grid.surface_at_pixel(u, v, min_cos, 0.015),
            grid.at_pixel(u, v).map(|(p, n)| (p, n, 1.0))
        );
    }
}
