//! Precomputed undistortion of whole images: for every pixel of the ideal pinhole image,
//! where the lens put it in the raw image.

use super::Camera;
use crate::image::{Image, ImageView};
use nalgebra::Point2;
use thiserror::Error;

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
    use crate::camera::CameraConfig;

    /// The published TUM freiburg1 calibration (strongest distortion of the TUM cameras).
    fn fr1() -> Camera {
        Camera::from_config(&CameraConfig {
            k1: 0.262383,
            k2: -0.953104,
            p1: -0.005358,
            p2: 0.002628,
            k3: 1.163314,
            ..CameraConfig::pinhole(517.306408, 516.469215, 318.643040, 255.313989, 640, 480)
        })
        .unwrap()
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
}
