//! The ideal pinhole camera every stage after the source sees.

use nalgebra::{Point2, Point3, Vector2};
use serde::{Deserialize, Serialize};

/// Ideal pinhole intrinsics and the image size they belong to.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PinholeCamera {
    /// Focal length along u, pixels.
    pub fx: f64,
    /// Focal length along v, pixels.
    pub fy: f64,
    /// Principal point column, pixels.
    pub cx: f64,
    /// Principal point row, pixels.
    pub cy: f64,
    /// Image width, pixels.
    pub width: usize,
    /// Image height, pixels.
    pub height: usize,
}

impl PinholeCamera {
    /// Intrinsics `fx fy cx cy` for a `width x height` image.
    pub fn new(fx: f64, fy: f64, cx: f64, cy: f64, width: usize, height: usize) -> Self {
        Self {
            fx,
            fy,
            cx,
            cy,
            width,
            height,
        }
    }

    /// Projects a point in the camera frame; `None` when it is not in front (z <= 1 mm).
    #[inline]
    pub fn project(&self, p_in_camera: &Point3<f64>) -> Option<Point2<f64>> {
        if p_in_camera.z <= MIN_PROJECT_DEPTH {
            return None;
        }
        let inv_z = 1.0 / p_in_camera.z;
        Some(Point2::new(
            self.fx * p_in_camera.x * inv_z + self.cx,
            self.fy * p_in_camera.y * inv_z + self.cy,
        ))
    }

    /// The point at `depth` metres along the ray of pixel (`u`, `v`).
    #[inline]
    pub fn back_project(&self, u: f64, v: f64, depth: f64) -> Point3<f64> {
        Point3::new(
            (u - self.cx) / self.fx * depth,
            (v - self.cy) / self.fy * depth,
            depth,
        )
    }

    /// The ray of pixel (`u`, `v`) on the plane z = 1.
    #[inline]
    pub fn normalized(&self, u: f64, v: f64) -> Vector2<f64> {
        Vector2::new((u - self.cx) / self.fx, (v - self.cy) / self.fy)
    }

    /// True when (`u`, `v`) lies at least `border` pixels inside the image.
    #[inline]
    pub fn contains(&self, u: f64, v: f64, border: f64) -> bool {
        u >= border
            && v >= border
            && u <= self.width as f64 - 1.0 - border
            && v <= self.height as f64 - 1.0 - border
    }
}

/// Points closer than this to the camera plane are not projected (metres).
const MIN_PROJECT_DEPTH: f64 = 1e-3;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projection_and_back_projection_are_inverse() {
        let k = PinholeCamera::new(517.3, 516.5, 318.6, 255.3, 640, 480);
        let p = k.back_project(12.25, 400.5, 3.5);
        let uv = k.project(&p).unwrap();
        assert!((uv.x - 12.25).abs() < 1e-9 && (uv.y - 400.5).abs() < 1e-9);
        assert!(k.project(&Point3::new(0.0, 0.0, -1.0)).is_none());
    }
}
