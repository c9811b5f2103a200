//! Photometric error of a reference surface point (direct alignment, Steinbruecker /
//! Kerl): `e = I_c(pi(T_cw P_w)) - i_ref`, the frame's intensity where the point
//! projects against the reference's intensity of it, on a coarse intensity grid (cell
//! means: the image noise averages out and the motion of a frame stays within a few
//! cells). It constrains what the geometry leaves free: a wall and the floor fix no
//! translation along their edge, their shading and faint paint texture do.
//!
//! `de/ddelta = grad I (du/dp_c) [I, -[p_c]x]`, the gradient taken as central
//! differences of the bilinear grid one cell either side.

use super::projection::{point_pose_jacobian, project, projection_jacobian};
use gfs_core::camera::PinholeCamera;
use nalgebra::{Isometry3, Matrix1x6, Matrix2x6, Point3, RowVector2, Vector3};

/// A frame's intensities as the means of square pixel cells, row-major; cell `(i, j)`
/// covers pixels `[i s, (i + 1) s) x [j s, (j + 1) s)` and sits at their centre.
#[derive(Clone, Copy, Debug)]
pub struct IntensityGrid<'a> {
    /// Pixels per cell side.
    pub stride_px: u32,
    /// Cells per row.
    pub width: usize,
    /// Cell rows.
    pub height: usize,
    /// Mean gray level of each cell.
    pub values: &'a [f32],
}

impl IntensityGrid<'_> {
    /// Fractional cell coordinates of pixel `(u, v)`.
    #[inline]
    fn cell(&self, u: f64, v: f64) -> (f64, f64) {
        let s = f64::from(self.stride_px.max(1));
        let centre = (s - 1.0) / 2.0;
        ((u - centre) / s, (v - centre) / s)
    }

    /// Bilinear value at fractional cell `(x, y)`; `None` outside the grid.
    #[inline(always)]
    fn bilinear(&self, x: f64, y: f64) -> Option<f64> {
        if !(x >= 0.0 && y >= 0.0) {
            return None;
        }
        // Truncation is the floor here (both are non-negative), without a libm call.
        let (i, j) = (x as usize, y as usize);
        if i + 1 >= self.width || j + 1 >= self.height {
            return None;
        }
        let k = j * self.width + i;
        // The cell, its right neighbour, the row below: one bounds check for the four.
        let cells = self.values.get(k..k + self.width + 2)?;
        let at = |offset: usize| f64::from(cells[offset]);
        let (fx, fy) = (x - i as f64, y - j as f64);
        let top = at(0) * (1.0 - fx) + at(1) * fx;
        let bottom = at(self.width) * (1.0 - fx) + at(self.width + 1) * fx;
        Some(top * (1.0 - fy) + bottom * fy)
    }

    /// Intensity at pixel `(u, v)`; `None` outside the grid's inner cells.
    #[inline]
    pub fn intensity(&self, u: f64, v: f64) -> Option<f64> {
        let (x, y) = self.cell(u, v);
        self.bilinear(x, y)
    }

    /// Intensity and its gradient per pixel at `(u, v)`; `None` within a cell of the
    /// border.
    #[inline]
    pub fn intensity_and_gradient(&self, u: f64, v: f64) -> Option<(f64, RowVector2<f64>)> {
        let (value, gradient) = self.intensity_and_inner_gradient(u, v)?;
        Some((value, gradient?))
    }

    /// Intensity at `(u, v)` (`None` outside the inner cells) and its gradient per pixel
    /// (`None` within a cell of the border).
    #[inline]
    fn intensity_and_inner_gradient(
        &self,
        u: f64,
        v: f64,
    ) -> Option<(f64, Option<RowVector2<f64>>)> {
        let (x, y) = self.cell(u, v);
        let value = self.bilinear(x, y)?;
        let gradient = || {
            let dx = self.bilinear(x + 1.0, y)? - self.bilinear(x - 1.0, y)?;
            let dy = self.bilinear(x, y + 1.0)? - self.bilinear(x, y - 1.0)?;
            let s = f64::from(self.stride_px.max(1));
            Some(RowVector2::new(dx, dy) / (2.0 * s))
        };
        Some((value, gradient()))
    }
}

/// A reference surface point and its intensity, seen in the frame's intensity grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Photometric {
    /// The reference intensity, in the frame's exposure (gain-corrected), gray levels.
    pub intensity: f64,
}

/// Error and Jacobian of a [`Photometric`] at one estimate.
#[derive(Clone, Copy, Debug)]
pub struct PhotometricLinearization {
    /// Frame intensity minus reference intensity, gray levels.
    pub error: f64,
    /// d(error)/d(delta) for the left pose perturbation, 1x6: `gradient * d_pixel`.
    pub d_pose: Matrix1x6<f64>,
    /// The frame's intensity gradient where the point projects, gray levels per pixel.
    pub gradient: RowVector2<f64>,
    /// d(pixel)/d(delta) of the point, 2x6.
    pub d_pixel: Matrix2x6<f64>,
}

/// Where a point projects in the frame and what the frame's intensity grid reads
/// there: one reading serves the exposure gain's fit and the error at that gain.
#[derive(Clone, Copy, Debug)]
pub struct PhotometricReading {
    /// The point in the camera frame.
    pub point_in_camera: Vector3<f64>,
    /// The frame's intensity where it projects, gray levels.
    pub value: f64,
    /// Its gradient, gray levels per pixel; `None` within a cell of the grid's border
    /// or when not asked for.
    pub gradient: Option<RowVector2<f64>>,
}

impl PhotometricReading {
    /// Reads the frame's grid where `point_in_world` projects, with the gradient when
    /// `with_gradient`; `None` behind the camera or off the grid.
    #[inline]
    pub fn new(
        camera: &PinholeCamera,
        image: &IntensityGrid<'_>,
        camera_from_world: &Isometry3<f64>,
        point_in_world: &Vector3<f64>,
        with_gradient: bool,
    ) -> Option<Self> {
        let p_c = (camera_from_world * Point3::from(*point_in_world)).coords;
        let uv = project(camera, &p_c)?;
        let (value, gradient) = if with_gradient {
            image.intensity_and_inner_gradient(uv.x, uv.y)?
        } else {
            (image.intensity(uv.x, uv.y)?, None)
        };
        Some(Self {
            point_in_camera: p_c,
            value,
            gradient,
        })
    }
}

impl Photometric {
    /// The error; `None` behind the camera or off the grid.
    #[inline]
    pub fn error(
        &self,
        camera: &PinholeCamera,
        image: &IntensityGrid<'_>,
        camera_from_world: &Isometry3<f64>,
        point_in_world: &Vector3<f64>,
    ) -> Option<f64> {
        let reading =
            PhotometricReading::new(camera, image, camera_from_world, point_in_world, false)?;
        Some(self.error_of(&reading))
    }

    /// The error of a reading.
    #[inline]
    pub fn error_of(&self, reading: &PhotometricReading) -> f64 {
        reading.value - self.intensity
    }

    /// The error and its Jacobian; `None` behind the camera or within a cell of the
    /// grid's border.
    #[inline]
    pub fn linearize(
        &self,
        camera: &PinholeCamera,
        image: &IntensityGrid<'_>,
        camera_from_world: &Isometry3<f64>,
        point_in_world: &Vector3<f64>,
    ) -> Option<PhotometricLinearization> {
        let reading =
            PhotometricReading::new(camera, image, camera_from_world, point_in_world, true)?;
        self.linearize_reading(camera, &reading)
    }

    /// The error and its Jacobian at a reading taken with its gradient; `None` without
    /// one.
    #[inline]
    pub fn linearize_reading(
        &self,
        camera: &PinholeCamera,
        reading: &PhotometricReading,
    ) -> Option<PhotometricLinearization> {
        let gradient = reading.gradient?;
        let p_c = &reading.point_in_camera;
        let d_pixel = projection_jacobian(camera, p_c) * point_pose_jacobian(p_c);
        Some(PhotometricLinearization {
            error: self.error_of(reading),
            d_pose: gradient * d_pixel,
            gradient,
            d_pixel,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::residuals::testing::{
        SplitMix64, assert_jacobian, random_camera_and_pose, random_point_in_view,
    };
    use gfs_core::se3::retract;
    use nalgebra::{SVector, Vector6};

    /// An 80 x 60 grid of 8 px cells whose intensity is linear in the pixel (bilinear
    /// interpolation and central differences are then exact).
    fn ramp() -> Vec<f32> {
        let mut values = Vec::new();
        for j in 0..60 {
            for i in 0..80 {
                let (u, v) = (8.0 * i as f32 + 3.5, 8.0 * j as f32 + 3.5);
                // Binary fractions: exact in f32.
                values.push(100.0 + 0.25 * u - 0.125 * v);
            }
        }
        values
    }

    #[test]
    fn jacobian_matches_central_differences() {
        let values = ramp();
        let image = IntensityGrid {
            stride_px: 8,
            width: 80,
            height: 60,
            values: &values,
        };
        let mut rng = SplitMix64::new(7);
        let mut checked = 0;
        for _ in 0..50 {
            let (camera, t_cw) = random_camera_and_pose(&mut rng);
            let p_w = random_point_in_view(&mut rng, &t_cw);
            let r = Photometric { intensity: 120.0 };
            let Some(l) = r.linearize(&camera, &image, &t_cw, &p_w) else {
                continue;
            };
            let f = |d: &Vector6<f64>| {
                SVector::<f64, 1>::new(
                    r.error(&camera, &image, &retract(&t_cw, d), &p_w)
                        .unwrap_or(f64::NAN),
                )
            };
            assert_jacobian(f, &l.d_pose, "photometric d_pose");
            checked += 1;
        }
        assert!(checked > 30, "{checked}");
    }

    #[test]
    fn a_cell_centre_reads_its_own_value_and_the_border_reads_nothing() {
        let values = ramp();
        let image = IntensityGrid {
            stride_px: 8,
            width: 80,
            height: 60,
            values: &values,
        };
        let (value, gradient) = image
            .intensity_and_gradient(8.0 * 10.0 + 3.5, 8.0 * 20.0 + 3.5)
            .expect("inside");
        assert!((value - f64::from(values[20 * 80 + 10])).abs() < 1e-4);
        assert!((gradient - RowVector2::new(0.25, -0.125)).norm() < 1e-5);
        assert!(image.intensity_and_gradient(2.0, 100.0).is_none());
        assert!(image.intensity(636.0, 100.0).is_none());
    }
}
