//! The colour camera's vignetting, estimated online from the frames it tracks, and taken
//! out of each frame's intensities before the photometric term reads them.
//!
//! A lens darkens the image towards its corners, fixed to the camera: on a bare wall
//! that falloff is most of the image's shading, and the photometric term, which compares
//! a surface's intensities from two views, reads it as a pattern that does not move, so
//! it pulls a turning camera into a slide that keeps the image still (a Kinect-like
//! camera with 30 % falloff turning in a bare room slid 80-90 mm a frame). As in online
//! photometric calibration (Bergmann, Wang and Cremers, RA-L 2017), a surface point seen
//! by two tracked frames at image radii `r1`, `r2` gives `log I2 - log I1 = log g +
//! log V(r2) - log V(r1)`, `g` the change of exposure between them; with `log V(r) =
//! c2 r^2 + c4 r^4` (`r` over the half-diagonal) the coefficients are a linear least-
//! squares fit over every pair seen, each frame pair's gain eliminated by centring.

use crate::depth::grid::{DepthGrid, IntensityLevel, PosedGrid};
use gfs_core::camera::PinholeCamera;
use nalgebra::{Matrix2, Point3, Vector2};

/// Ridge on the normal equations, in squared radius-differences: a first frame pair that
/// hardly moved determines nothing and leaves the coefficients near none.
const RIDGE: f64 = 2.0;
/// Gray levels outside which a sample is too dark (its rounding dominates) or saturated.
const DARK: f64 = 8.0;
const BRIGHT: f64 = 247.0;
/// Log-intensity differences beyond this from the pair's fit are another surface or a
/// highlight, not the falloff.
const MAX_LOG_RESIDUAL: f64 = 0.15;
/// The falloff's coefficients are kept within these (a corner at most 4.5 times darker
/// or 1.6 brighter than the centre).
const MIN_COEFFICIENT: f64 = -1.5;
const MAX_COEFFICIENT: f64 = 0.5;

/// The estimate of the falloff and its normal equations.
#[derive(Debug, Default)]
pub struct Vignetting {
    /// `(c2, c4)` of `log V(r) = c2 r^2 + c4 r^4`.
    coefficients: Vector2<f64>,
    normal: Matrix2<f64>,
    rhs: Vector2<f64>,
    /// The coefficients the last frame's and the current frame's intensities were
    /// divided by.
    applied_last: Vector2<f64>,
    applied_current: Vector2<f64>,
    /// `(log-intensity difference, radius terms)` of the pair being observed (reused).
    samples: Vec<(f64, Vector2<f64>)>,
}

/// `(r^2, r^4)` at pixel `(u, v)`, `r` over the image's half-diagonal from the
/// principal point.
fn radius_terms(camera: &PinholeCamera, u: f64, v: f64) -> Vector2<f64> {
    let half_diagonal2 = 0.25 * ((camera.width.pow(2) + camera.height.pow(2)) as f64);
    let r2 = ((u - camera.cx).powi(2) + (v - camera.cy).powi(2)) / half_diagonal2.max(1.0);
    Vector2::new(r2, r2 * r2)
}

impl Vignetting {
    /// Divides `grid`'s intensities, the cells and the coarse level, by the falloff
    /// estimated so far; the frame being tracked.
    pub fn correct(&mut self, camera: &PinholeCamera, grid: &mut DepthGrid) {
        self.applied_current = self.coefficients;
        for level in [IntensityLevel::Cells, IntensityLevel::Coarse] {
            let Some(image) = grid.intensity_grid(level) else {
                continue;
            };
            let (cell, width) = (f64::from(image.stride_px), image.width);
            let values = match level {
                IntensityLevel::Cells => &mut grid.intensity,
                IntensityLevel::Coarse => &mut grid.coarse_intensity,
            };
            for (k, value) in values.iter_mut().enumerate() {
                let (i, j) = ((k % width) as f64, (k / width) as f64);
                let x = radius_terms(camera, (i + 0.5) * cell, (j + 0.5) * cell);
                *value *= (-self.coefficients.dot(&x)).exp() as f32;
            }
        }
    }

    /// Adds the samples of `current`, tracked, against `reference`, the last frame
    /// (both as [`Self::correct`] left them), and updates the estimate; a sample whose
    /// point `current`'s depth shows more than `occlusion_m` nearer is hidden there.
    pub fn observe(
        &mut self,
        camera: &PinholeCamera,
        current: PosedGrid,
        reference: PosedGrid,
        occlusion_m: f64,
    ) {
        let (Some(image), Some(reference_image)) = (
            current.grid.intensity_grid(IntensityLevel::Cells),
            reference.grid.intensity_grid(IntensityLevel::Cells),
        ) else {
            return;
        };
        let current_from_reference =
            current.camera_from_world * reference.camera_from_world.inverse();
        self.samples.clear();
        for k in 0..reference.grid.points.len() {
            let Some((node, _)) = reference.grid.node(k) else {
                continue;
            };
            let in_reference = Point3::from(node);
            let in_current = current_from_reference * in_reference;
            let (Some(uv_r), Some(uv_c)) =
                (camera.project(&in_reference), camera.project(&in_current))
            else {
                continue;
            };
            let (Some(i_r), Some(i_c)) = (
                reference_image.intensity(uv_r.x, uv_r.y),
                image.intensity(uv_c.x, uv_c.y),
            ) else {
                continue;
            };
            let hidden = current
                .grid
                .at_pixel(uv_c.x, uv_c.y)
                .is_some_and(|(q, _)| (q.z - in_current.z).abs() > occlusion_m);
            if hidden {
                continue;
            }
            let (x_r, x_c) = (
                radius_terms(camera, uv_r.x, uv_r.y),
                radius_terms(camera, uv_c.x, uv_c.y),
            );
            // The intensities as the camera recorded them.
            let raw_r = i_r * self.applied_last.dot(&x_r).exp();
            let raw_c = i_c * self.applied_current.dot(&x_c).exp();
            if [raw_r, raw_c].iter().any(|v| !(DARK..=BRIGHT).contains(v)) {
                continue;
            }
            self.samples.push((raw_c.ln() - raw_r.ln(), x_c - x_r));
        }
        self.accumulate();
    }

    /// The frame just tracked becomes the last frame: called after every frame,
    /// observed or not.
    pub fn next_frame(&mut self) {
        self.applied_last = self.applied_current;
    }

    /// Adds the pair's samples, centred (the pair's gain eliminated), without those far
    /// from the current estimate, and solves again.
    fn accumulate(&mut self) {
        let n = self.samples.len();
        if n < 2 {
            return;
        }
        let (sum_y, sum_x) = self
            .samples
            .iter()
            .fold((0.0, Vector2::zeros()), |(y, x), s| (y + s.0, x + s.1));
        let (mean_y, mean_x) = (sum_y / n as f64, sum_x / n as f64);
        for (y, x) in &self.samples {
            let (y, x) = (y - mean_y, x - mean_x);
            if (y - self.coefficients.dot(&x)).abs() > MAX_LOG_RESIDUAL {
                continue;
            }
            self.normal += x * x.transpose();
            self.rhs += x * y;
        }
        let ridged = self.normal + Matrix2::identity() * RIDGE;
        if let Some(inverse) = ridged.try_inverse() {
            self.coefficients =
                (inverse * self.rhs).map(|c| c.clamp(MIN_COEFFICIENT, MAX_COEFFICIENT));
        }
        tracing::debug!(
            c2 = self.coefficients.x,
            c4 = self.coefficients.y,
            samples = n,
            "vignetting"
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{CORNER, camera, textured_planes_depth};
    use nalgebra::{Isometry3, Vector3};

    /// A faint paint and a lamp's shading, gray levels.
    fn paint(p: &Vector3<f64>) -> f64 {
        150.0 + 4.0 * (2.3 * p.x + 0.9 * p.z).sin() + 3.0 * (1.7 * p.x - 2.1 * p.y).cos()
    }

    /// The bare corner from `pose`, its cells darkened by `1 - 0.3 r^2` and the
    /// exposure by `gain`.
    fn vignetted(pose: &Isometry3<f64>, gain: f64, seed: u64) -> DepthGrid {
        let camera = camera();
        let mut grid = textured_planes_depth(&camera, pose, &CORNER, paint, seed);
        let image = grid.intensity_grid(IntensityLevel::Cells).expect("cells");
        let (cell, width) = (f64::from(image.stride_px), image.width);
        for (k, value) in grid.intensity.iter_mut().enumerate() {
            let (i, j) = ((k % width) as f64, (k / width) as f64);
            let r2 = radius_terms(&camera, (i + 0.5) * cell, (j + 0.5) * cell).x;
            *value *= (gain * (1.0 - 0.3 * r2)) as f32;
        }
        grid.coarsen_intensity();
        grid
    }

    #[test]
    fn the_falloff_of_a_turning_camera_is_found_and_divided_out() {
        let camera = camera();
        let mut vignetting = Vignetting::default();
        let mut last: Option<(DepthGrid, Isometry3<f64>)> = None;
        // Eight frames turning 2 degrees a frame, the exposure changing 5 % a frame.
        for k in 0..8u64 {
            let pose = Isometry3::rotation(Vector3::y() * (2.0 * k as f64).to_radians());
            let mut grid = vignetted(&pose, 1.0 + 0.05 * k as f64, k);
            vignetting.correct(&camera, &mut grid);
            if let Some((reference, reference_pose)) = &last {
                let current = PosedGrid {
                    grid: &grid,
                    camera_from_world: &pose,
                };
                let reference = PosedGrid {
                    grid: reference,
                    camera_from_world: reference_pose,
                };
                vignetting.observe(&camera, current, reference, 0.08);
            }
            vignetting.next_frame();
            last = Some((grid, pose));
        }
        let log_falloff = |r2: f64| vignetting.coefficients.dot(&Vector2::new(r2, r2 * r2));
        // In the corner 0.7 of the centre, halfway out 0.925.
        assert!(
            (log_falloff(1.0) - 0.7f64.ln()).abs() < 0.03,
            "{}",
            log_falloff(1.0)
        );
        assert!((log_falloff(0.25) - 0.925f64.ln()).abs() < 0.01);
        // The next frame's cells, divided by it, are the paint's within 1.5 %.
        let pose = Isometry3::rotation(Vector3::y() * 16f64.to_radians());
        let mut grid = vignetted(&pose, 1.0, 9);
        let plain = textured_planes_depth(&camera, &pose, &CORNER, paint, 9);
        vignetting.correct(&camera, &mut grid);
        let worst = (grid.intensity.iter().zip(&plain.intensity))
            .filter(|(_, p)| **p > 0.0)
            .map(|(v, p)| (v / p - 1.0).abs())
            .fold(0.0f32, f32::max);
        assert!(worst < 0.015, "{worst}");
    }
}
