//! Pinhole camera with radial-tangential (Brown-Conrady, OpenCV order k1 k2 p1 p2 k3)
//! distortion, point undistortion, and a precomputed lookup table that undistorts
//! whole images.
//!
//! After the `source` stage has applied the [`UndistortMap`], every later stage sees an
//! ideal pinhole image with the same intrinsics ([`Camera::pinhole`]).

use crate::image::{Image, ImageView};
use nalgebra::{Matrix2, Point2, Point3, Vector2};
use serde::{Deserialize, Serialize};
use thiserror::Error;

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

/// Radial-tangential distortion coefficients, OpenCV order and meaning.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Distortion {
    /// Radial r^2 coefficient.
    pub k1: f64,
    /// Radial r^4 coefficient.
    pub k2: f64,
    /// Tangential coefficient 1.
    pub p1: f64,
    /// Tangential coefficient 2.
    pub p2: f64,
    /// Radial r^6 coefficient.
    pub k3: f64,
}

/// Newton iterations of [`Distortion::undistort`]; converges to 1e-12 well before this on
/// Kinect-like lenses.
const UNDISTORT_MAX_ITERATIONS: usize = 20;

impl Distortion {
    /// True when all coefficients are zero (no image remapping needed).
    pub fn is_zero(&self) -> bool {
        self.k1 == 0.0 && self.k2 == 0.0 && self.p1 == 0.0 && self.p2 == 0.0 && self.k3 == 0.0
    }

    /// Distorts a normalised point (z = 1 plane).
    #[inline]
    pub fn distort(&self, p: Vector2<f64>) -> Vector2<f64> {
        let (x, y) = (p.x, p.y);
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        Vector2::new(
            x * radial + 2.0 * self.p1 * x * y + self.p2 * (r2 + 2.0 * x * x),
            y * radial + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * x * y,
        )
    }

    /// Jacobian of [`Self::distort`] with respect to the normalised point.
    fn distort_jacobian(&self, p: Vector2<f64>) -> Matrix2<f64> {
        let (x, y) = (p.x, p.y);
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        // d(radial)/d(r2)
        let dradial = self.k1 + r2 * (2.0 * self.k2 + 3.0 * r2 * self.k3);
        let dxx = radial + 2.0 * x * x * dradial + 2.0 * self.p1 * y + 6.0 * self.p2 * x;
        let dxy = 2.0 * x * y * dradial + 2.0 * self.p1 * x + 2.0 * self.p2 * y;
        let dyx = 2.0 * x * y * dradial + 2.0 * self.p1 * x + 2.0 * self.p2 * y;
        let dyy = radial + 2.0 * y * y * dradial + 6.0 * self.p1 * y + 2.0 * self.p2 * x;
        Matrix2::new(dxx, dxy, dyx, dyy)
    }

    /// Inverts [`Self::distort`] by Newton's method, starting at the distorted point.
    pub fn undistort(&self, distorted: Vector2<f64>) -> Vector2<f64> {
        if self.is_zero() {
            return distorted;
        }
        let mut p = distorted;
        for _ in 0..UNDISTORT_MAX_ITERATIONS {
            let residual = self.distort(p) - distorted;
            if residual.norm_squared() < 1e-24 {
                break;
            }
            let Some(inv) = self.distort_jacobian(p).try_inverse() else {
                break;
            };
            p -= inv * residual;
        }
        p
    }
}

/// Camera parameters as written in a config file (`[camera]` table).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraConfig {
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
    /// Radial r^2 coefficient (default 0).
    #[serde(default)]
    pub k1: f64,
    /// Radial r^4 coefficient (default 0).
    #[serde(default)]
    pub k2: f64,
    /// Tangential coefficient 1 (default 0).
    #[serde(default)]
    pub p1: f64,
    /// Tangential coefficient 2 (default 0).
    #[serde(default)]
    pub p2: f64,
    /// Radial r^6 coefficient (default 0).
    #[serde(default)]
    pub k3: f64,
    /// Rolling-shutter readout time, first row to last, seconds (default 0: a global
    /// shutter). The tracker re-times each observation to the middle row with the
    /// camera's angular velocity.
    #[serde(default)]
    pub readout_s: f64,
}

/// A camera config value that cannot describe a camera.
#[derive(Debug, Error, PartialEq)]
pub enum CameraConfigError {
    /// A field is out of its valid range.
    #[error("camera.{field} = {value} is invalid: {reason}")]
    InvalidField {
        /// Field name in the `[camera]` table.
        field: &'static str,
        /// The value found.
        value: f64,
        /// What a valid value is.
        reason: &'static str,
    },
}

/// A calibrated camera: pinhole intrinsics plus lens distortion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Intrinsics of the ideal (undistorted) image.
    pub pinhole: PinholeCamera,
    /// Lens distortion of the raw image.
    pub distortion: Distortion,
}

impl Camera {
    /// Builds and validates a camera from its config.
    ///
    /// # Errors
    /// [`CameraConfigError::InvalidField`] naming the first field that is not finite or
    /// out of range (non-positive focal length or size, principal point outside the image).
    pub fn from_config(c: &CameraConfig) -> Result<Self, CameraConfigError> {
        let check = |field, value: f64, ok: bool, reason| {
            if value.is_finite() && ok {
                Ok(())
            } else {
                Err(CameraConfigError::InvalidField {
                    field,
                    value,
                    reason,
                })
            }
        };
        check("width", c.width as f64, c.width > 0, "must be > 0")?;
        check("height", c.height as f64, c.height > 0, "must be > 0")?;
        check("fx", c.fx, c.fx > 0.0, "must be > 0")?;
        check("fy", c.fy, c.fy > 0.0, "must be > 0")?;
        check(
            "cx",
            c.cx,
            c.cx >= 0.0 && c.cx < c.width as f64,
            "must lie inside the image",
        )?;
        check(
            "cy",
            c.cy,
            c.cy >= 0.0 && c.cy < c.height as f64,
            "must lie inside the image",
        )?;
        check(
            "readout_s",
            c.readout_s,
            (0.0..=1.0).contains(&c.readout_s),
            "must be a time in seconds between 0 and 1",
        )?;
        for (field, v) in [
            ("k1", c.k1),
            ("k2", c.k2),
            ("p1", c.p1),
            ("p2", c.p2),
            ("k3", c.k3),
        ] {
            check(field, v, true, "must be finite")?;
        }
        Ok(Self {
            pinhole: PinholeCamera::new(c.fx, c.fy, c.cx, c.cy, c.width, c.height),
            distortion: Distortion {
                k1: c.k1,
                k2: c.k2,
                p1: c.p1,
                p2: c.p2,
                k3: c.k3,
            },
        })
    }

    /// Maps a raw (distorted) pixel to its position in the ideal pinhole image.
    pub fn undistort_pixel(&self, raw: Point2<f64>) -> Point2<f64> {
        let k = &self.pinhole;
        let p = self.distortion.undistort(k.normalized(raw.x, raw.y));
        Point2::new(k.fx * p.x + k.cx, k.fy * p.y + k.cy)
    }

    /// Maps an ideal pinhole pixel to where the lens puts it in the raw image.
    pub fn distort_pixel(&self, ideal: Point2<f64>) -> Point2<f64> {
        let k = &self.pinhole;
        let p = self.distortion.distort(k.normalized(ideal.x, ideal.y));
        Point2::new(k.fx * p.x + k.cx, k.fy * p.y + k.cy)
    }
}

/// Fixed-point precision of the bilinear weights (1/256 of a pixel).
const WEIGHT_BITS: u32 = 8;
const WEIGHT_ONE: u32 = 1 << WEIGHT_BITS;
/// Marks an output pixel whose source falls outside the raw image.
const OUTSIDE: u32 = u32::MAX;

/// One output pixel of the bilinear table: top-left source pixel and sub-pixel weights.
/// Coordinates rather than a flat index so that any source stride works.
#[derive(Clone, Copy, Debug)]
struct BilinearTap {
    x: u32,
    y: u32,
    wx: u16,
    wy: u16,
}

/// Precomputed undistortion: for every pixel of the ideal image, where to read the raw one.
///
/// Built once per camera; applying it costs one table read and four pixel reads per
/// output pixel (bilinear, for gray and colour) or one (nearest, for depth, so that
/// depth edges are never blended into ghost surfaces).
#[derive(Clone, Debug)]
pub struct UndistortMap {
    width: usize,
    height: usize,
    bilinear: Vec<BilinearTap>,
    nearest: Vec<(u32, u32)>,
}

impl UndistortMap {
    /// The table for `camera`; the output image has the raw image's size and intrinsics.
    pub fn new(camera: &Camera) -> Self {
        let (w, h) = (camera.pinhole.width, camera.pinhole.height);
        let mut bilinear = Vec::with_capacity(w * h);
        let mut nearest = Vec::with_capacity(w * h);
        for v in 0..h {
            for u in 0..w {
                let src = camera.distort_pixel(Point2::new(u as f64, v as f64));
                bilinear.push(bilinear_tap(src, w, h));
                let (nx, ny) = (src.x.round(), src.y.round());
                let inside = nx >= 0.0 && ny >= 0.0 && nx <= (w - 1) as f64 && ny <= (h - 1) as f64;
                nearest.push(if inside {
                    (nx as u32, ny as u32)
                } else {
                    (OUTSIDE, OUTSIDE)
                });
            }
        }
        Self {
            width: w,
            height: h,
            bilinear,
            nearest,
        }
    }

    /// Output width (= raw width).
    pub fn width(&self) -> usize {
        self.width
    }

    /// Output height (= raw height).
    pub fn height(&self) -> usize {
        self.height
    }

    /// Undistorts a gray image (bilinear). Pixels whose source is outside become 0.
    ///
    /// # Errors
    /// [`RemapError`] when `src` is not the size the table was built for.
    pub fn remap_gray(
        &self,
        src: &ImageView<'_, u8>,
        dst: &mut Image<u8>,
    ) -> Result<(), RemapError> {
        self.check(src.width(), src.height())?;
        dst.resize(self.width, self.height);
        let stride = src.stride();
        let data = src.as_slice();
        for (out, tap) in dst.as_mut_slice().iter_mut().zip(&self.bilinear) {
            *out = if tap.x == OUTSIDE {
                0
            } else {
                let i = tap.y as usize * stride + tap.x as usize;
                blend(
                    data[i],
                    data[i + 1],
                    data[i + stride],
                    data[i + stride + 1],
                    tap,
                ) as u8
            };
        }
        Ok(())
    }

    /// Undistorts an RGB image (bilinear per channel). Outside pixels become black.
    ///
    /// # Errors
    /// [`RemapError`] when `src` is not the size the table was built for.
    pub fn remap_rgb(
        &self,
        src: &ImageView<'_, [u8; 3]>,
        dst: &mut Image<[u8; 3]>,
    ) -> Result<(), RemapError> {
        self.check(src.width(), src.height())?;
        dst.resize(self.width, self.height);
        let stride = src.stride();
        let data = src.as_slice();
        for (out, tap) in dst.as_mut_slice().iter_mut().zip(&self.bilinear) {
            *out = if tap.x == OUTSIDE {
                [0; 3]
            } else {
                let i = tap.y as usize * stride + tap.x as usize;
                let (a, b, c, d) = (data[i], data[i + 1], data[i + stride], data[i + stride + 1]);
                std::array::from_fn(|k| blend(a[k], b[k], c[k], d[k], tap) as u8)
            };
        }
        Ok(())
    }

    /// Undistorts a depth image (nearest neighbour). Outside pixels become 0 (missing).
    ///
    /// # Errors
    /// [`RemapError`] when `src` is not the size the table was built for.
    pub fn remap_depth(
        &self,
        src: &ImageView<'_, f32>,
        dst: &mut Image<f32>,
    ) -> Result<(), RemapError> {
        self.check(src.width(), src.height())?;
        dst.resize(self.width, self.height);
        let stride = src.stride();
        let data = src.as_slice();
        for (out, &(x, y)) in dst.as_mut_slice().iter_mut().zip(&self.nearest) {
            *out = if x == OUTSIDE {
                0.0
            } else {
                data[y as usize * stride + x as usize]
            };
        }
        Ok(())
    }

    fn check(&self, width: usize, height: usize) -> Result<(), RemapError> {
        if width == self.width && height == self.height {
            Ok(())
        } else {
            Err(RemapError {
                expected: (self.width, self.height),
                got: (width, height),
            })
        }
    }
}

/// An image handed to [`UndistortMap`] does not have the calibrated size.
#[derive(Debug, Error, PartialEq, Eq)]
#[error("image is {}x{} but the camera is calibrated for {}x{}", got.0, got.1, expected.0, expected.1)]
pub struct RemapError {
    /// Calibrated (width, height).
    pub expected: (usize, usize),
    /// Size of the image given.
    pub got: (usize, usize),
}

fn bilinear_tap(src: Point2<f64>, w: usize, h: usize) -> BilinearTap {
    let outside = BilinearTap {
        x: OUTSIDE,
        y: OUTSIDE,
        wx: 0,
        wy: 0,
    };
    if w < 2 || h < 2 || !(src.x >= 0.0 && src.y >= 0.0) {
        return outside;
    }
    if src.x > (w - 1) as f64 || src.y > (h - 1) as f64 {
        return outside;
    }
    // Clamp the top-left tap so that the 2x2 neighbourhood stays inside on the last row/column.
    let x0 = (src.x.floor() as usize).min(w - 2);
    let y0 = (src.y.floor() as usize).min(h - 2);
    let wx = ((src.x - x0 as f64) * WEIGHT_ONE as f64).round() as u16;
    let wy = ((src.y - y0 as f64) * WEIGHT_ONE as f64).round() as u16;
    BilinearTap {
        x: x0 as u32,
        y: y0 as u32,
        wx,
        wy,
    }
}

#[inline]
fn blend(a: u8, b: u8, c: u8, d: u8, tap: &BilinearTap) -> u32 {
    let (wx, wy) = (tap.wx as u32, tap.wy as u32);
    let top = a as u32 * (WEIGHT_ONE - wx) + b as u32 * wx;
    let bottom = c as u32 * (WEIGHT_ONE - wx) + d as u32 * wx;
    let half = 1 << (2 * WEIGHT_BITS - 1);
    (top * (WEIGHT_ONE - wy) + bottom * wy + half) >> (2 * WEIGHT_BITS)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The published TUM freiburg1 calibration (strongest distortion of the TUM cameras).
    fn fr1() -> Camera {
        Camera::from_config(&CameraConfig {
            fx: 517.306408,
            fy: 516.469215,
            cx: 318.643040,
            cy: 255.313989,
            width: 640,
            height: 480,
            k1: 0.262383,
            k2: -0.953104,
            p1: -0.005358,
            p2: 0.002628,
            k3: 1.163314,
            readout_s: 0.0,
        })
        .unwrap()
    }

    #[test]
    fn distortion_round_trip_is_within_a_hundredth_of_a_pixel_over_the_image() {
        let cam = fr1();
        let mut worst = 0.0f64;
        for v in (0..480).step_by(4) {
            for u in (0..640).step_by(4) {
                let ideal = Point2::new(u as f64, v as f64);
                let back = cam.undistort_pixel(cam.distort_pixel(ideal));
                worst = worst.max((back - ideal).norm());
            }
        }
        assert!(worst < 0.01, "worst round-trip error {worst} px");
    }

    #[test]
    fn projection_and_back_projection_are_inverse() {
        let k = fr1().pinhole;
        let p = k.back_project(12.25, 400.5, 3.5);
        let uv = k.project(&p).unwrap();
        assert!((uv.x - 12.25).abs() < 1e-9 && (uv.y - 400.5).abs() < 1e-9);
        assert!(k.project(&Point3::new(0.0, 0.0, -1.0)).is_none());
    }

    #[test]
    fn remapping_moves_a_raw_dot_to_its_undistorted_position() {
        let cam = fr1();
        let map = UndistortMap::new(&cam);
        // A bright 3x3 dot near a corner, where distortion is large.
        let raw_centre = Point2::new(60.0, 50.0);
        let mut raw = Image::<u8>::new(640, 480);
        for dy in -1..=1 {
            for dx in -1..=1 {
                raw.set((60 + dx) as usize, (50 + dy) as usize, 255);
            }
        }
        let mut out = Image::new(0, 0);
        map.remap_gray(&raw.view(), &mut out).unwrap();
        let (mut sx, mut sy, mut sw) = (0.0, 0.0, 0.0);
        for v in 0..480 {
            for u in 0..640 {
                let w = out.get(u, v).unwrap() as f64;
                sx += w * u as f64;
                sy += w * v as f64;
                sw += w;
            }
        }
        let expected = cam.undistort_pixel(raw_centre);
        let centroid = Point2::new(sx / sw, sy / sw);
        assert!(
            (centroid - expected).norm() < 0.5,
            "dot at {centroid}, expected {expected}"
        );
        assert!(
            (expected - raw_centre).norm() > 3.0,
            "test needs a visible shift"
        );
    }

    #[test]
    fn depth_is_remapped_without_blending() {
        let cam = fr1();
        let map = UndistortMap::new(&cam);
        let mut depth = Image::<f32>::new(640, 480);
        for v in 0..480 {
            for u in 0..640 {
                depth.set(u, v, if u < 320 { 1.0 } else { 3.0 });
            }
        }
        let mut out = Image::new(0, 0);
        map.remap_depth(&depth.view(), &mut out).unwrap();
        assert!(
            out.as_slice()
                .iter()
                .all(|&d| d == 0.0 || d == 1.0 || d == 3.0)
        );
        let wrong = Image::<f32>::new(320, 240);
        assert!(map.remap_depth(&wrong.view(), &mut out).is_err());
    }

    #[test]
    fn invalid_config_names_the_field() {
        let mut c = CameraConfig {
            fx: 500.0,
            fy: 500.0,
            cx: 320.0,
            cy: 240.0,
            width: 640,
            height: 480,
            k1: 0.0,
            k2: 0.0,
            p1: 0.0,
            p2: 0.0,
            k3: 0.0,
            readout_s: 0.0,
        };
        c.fy = -1.0;
        let e = Camera::from_config(&c).unwrap_err();
        assert!(e.to_string().contains("camera.fy"), "{e}");
        c.fy = 500.0;
        c.cx = f64::NAN;
        assert!(
            Camera::from_config(&c)
                .unwrap_err()
                .to_string()
                .contains("camera.cx")
        );
        c.cx = 320.0;
        c.readout_s = -0.01;
        assert!(
            Camera::from_config(&c)
                .unwrap_err()
                .to_string()
                .contains("camera.readout_s")
        );
    }
}
