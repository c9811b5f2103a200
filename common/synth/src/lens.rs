//! A lens on the rendered camera: frames as a camera with distortion records them, for
//! testing the undistortion of every lens model end to end.
//!
//! Each raw pixel is ray cast along the ray the lens gives it (the ideal position of
//! the pixel, [`Camera::undistort_pixel`]), through a wider ideal pinhole camera whose
//! image holds every such position (same focal lengths, a margin around the image): the
//! raw image is as sharp as an ideal render, so the only blur a test of undistortion
//! sees is the undistortion's own. Sensor noise is applied afterwards, on the raw
//! image, as a sensor adds it.

use crate::render::{Rays, RenderBuffers, render_rays_into};
use crate::scene::Scene;
use gfs_core::camera::{Camera, Distortion, DistortionModel, PinholeCamera};
use nalgebra::{Isometry3, Point2};

/// Pixels of margin beyond the farthest ray, for the antialiasing sub-samples.
const MARGIN: f64 = 2.0;

/// A lens of `model` with coefficients as cameras of that model have them: plumb_bob as
/// the TUM freiburg1 Kinect, rational_polynomial as an Azure Kinect's colour camera,
/// equidistant as a T265-like fisheye.
pub fn typical_lens(model: DistortionModel) -> Distortion {
    let d: &[f64] = match model {
        DistortionModel::PlumbBob => &[0.262383, -0.953104, -0.005358, 0.002628, 1.163314],
        DistortionModel::RationalPolynomial => &[
            0.5164, -2.6184, 0.00046, -0.00017, 1.5022, 0.3955, -2.4455, 1.4336,
        ],
        DistortionModel::Equidistant => &[-0.0074, 0.0424, -0.0395, 0.0068],
    };
    Distortion::from_coefficients(model, d)
}

/// The wide camera and, for every raw pixel, where its ray crosses the wide image.
#[derive(Clone, Debug)]
pub(crate) struct Lens {
    wide: PinholeCamera,
    width: usize,
    height: usize,
    positions: Vec<[f32; 2]>,
}

impl Lens {
    /// The rays of `camera` (the raw image's intrinsics and size) through `distortion`.
    pub fn new(camera: &PinholeCamera, distortion: Distortion) -> Self {
        let lens = Camera {
            pinhole: *camera,
            distortion,
        };
        let (w, h) = (camera.width, camera.height);
        let ideal: Vec<Point2<f64>> = (0..h)
            .flat_map(|v| (0..w).map(move |u| (u as f64, v as f64)))
            .map(|(u, v)| lens.undistort_pixel(Point2::new(u, v)))
            .collect();
        let (mut left, mut top, mut right, mut bottom) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for p in &ideal {
            left = left.max(-p.x);
            top = top.max(-p.y);
            right = right.max(p.x - (w - 1) as f64);
            bottom = bottom.max(p.y - (h - 1) as f64);
        }
        let [left, top, right, bottom] = [left, top, right, bottom].map(|m| (m + MARGIN).ceil());
        let wide = PinholeCamera::new(
            camera.fx,
            camera.fy,
            camera.cx + left,
            camera.cy + top,
            w + (left + right) as usize,
            h + (top + bottom) as usize,
        );
        let positions = ideal
            .iter()
            .map(|p| [(p.x + left) as f32, (p.y + top) as f32])
            .collect();
        Self {
            wide,
            width: w,
            height: h,
            positions,
        }
    }

    /// Ray casts the raw image of the scene seen from `world_from_camera` into `out`.
    pub fn render(
        &self,
        scene: &Scene,
        world_from_camera: &Isometry3<f64>,
        out: &mut RenderBuffers,
    ) {
        let rays = Rays {
            width: self.width,
            height: self.height,
            positions: &self.positions,
        };
        render_rays_into(scene, &self.wide, world_from_camera, Some(&rays), out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_raw_ray_reads_inside_the_wide_image() {
        let camera = PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480);
        for model in DistortionModel::ALL {
            let lens = Lens::new(&camera, typical_lens(model));
            let wide = lens.wide;
            assert!(wide.width > camera.width, "{model:?}");
            for &[u, v] in &lens.positions {
                assert!(u >= 1.0 && v >= 1.0, "{model:?} {u} {v}");
                assert!(
                    u + 1.0 < wide.width as f32 && v + 1.0 < wide.height as f32,
                    "{model:?} {u} {v}"
                );
            }
            Camera::from_config(
                &Camera {
                    pinhole: camera,
                    distortion: typical_lens(model),
                }
                .config(0.0),
            )
            .expect("a lens the pipeline accepts");
        }
    }
}
