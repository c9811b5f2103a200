//! `sensor_msgs/Image` pairs into the pipeline's frame planes: gray (BT.601, as the
//! dataset reader computes it) and depth in metres (REP 118: `16UC1` millimetres or
//! `32FC1` metres; 0 and NaN are no return), undistorted with the camera's table when
//! the camera has distortion. Every check names the topic and the stamp.

use crate::msg::Image;
use gfs_core::camera::{Camera, UndistortMap};
use gfs_core::{Image as Plane, RgbImage};
use gfs_dataset::{DepthConfig, gray_bt601};

/// An image that cannot become a frame plane.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{topic} at {stamp} s: {reason}")]
pub struct ImageError {
    /// The topic the image came from.
    pub topic: String,
    /// Its header stamp.
    pub stamp: gfs_core::stamp::Stamp,
    /// What is wrong.
    pub reason: String,
}

/// An image message and the topic it came on.
#[derive(Clone, Copy, Debug)]
pub struct Received<'a> {
    /// The message.
    pub image: &'a Image,
    /// Its topic.
    pub topic: &'a str,
}

impl Received<'_> {
    fn error(&self, reason: String) -> ImageError {
        ImageError {
            topic: self.topic.to_owned(),
            stamp: self.image.header.stamp.into(),
            reason,
        }
    }

    /// Checks size, step and length for `bytes_per_pixel`; returns the step.
    fn rows(&self, size: (usize, usize), bytes_per_pixel: usize) -> Result<usize, ImageError> {
        let img = self.image;
        let (w, h) = (img.width as usize, img.height as usize);
        if (w, h) != size {
            return Err(self.error(format!(
                "{}x{} {} image, expected {}x{}",
                w, h, img.encoding, size.0, size.1
            )));
        }
        let step = img.step as usize;
        if step < w * bytes_per_pixel {
            return Err(self.error(format!(
                "step {step} is shorter than a row of {w} {} pixels",
                img.encoding
            )));
        }
        if img.data.len() < step * h {
            return Err(self.error(format!(
                "{} bytes of data, step {step} x {h} rows needs {}",
                img.data.len(),
                step * h
            )));
        }
        Ok(step)
    }
}

/// Colour encodings this converter reads, with bytes per pixel and the channel order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Colour {
    Rgb { bytes: usize },
    Bgr { bytes: usize },
    Mono,
}

impl Colour {
    fn parse(encoding: &str) -> Option<Self> {
        Some(match encoding {
            "rgb8" => Self::Rgb { bytes: 3 },
            "rgba8" => Self::Rgb { bytes: 4 },
            "bgr8" => Self::Bgr { bytes: 3 },
            "bgra8" => Self::Bgr { bytes: 4 },
            "mono8" | "8UC1" => Self::Mono,
            _ => return None,
        })
    }

    fn bytes(self) -> usize {
        match self {
            Self::Rgb { bytes } | Self::Bgr { bytes } => bytes,
            Self::Mono => 1,
        }
    }

    fn rgb(self, px: &[u8]) -> [u8; 3] {
        match self {
            Self::Rgb { .. } => [px[0], px[1], px[2]],
            Self::Bgr { .. } => [px[2], px[1], px[0]],
            Self::Mono => [px[0]; 3],
        }
    }
}

/// Converts image pairs of one camera into frame planes, reusing its scratch images.
pub struct FrameConverter {
    size: (usize, usize),
    undistort: Option<UndistortMap>,
    range: DepthConfig,
    raw_rgb: RgbImage,
    rgb: RgbImage,
    raw_depth: Plane<f32>,
    depth: Plane<f32>,
}

impl FrameConverter {
    /// A converter for `camera`, keeping depths within `depth`'s range (its scale is not
    /// used: REP 118 fixes the units).
    pub fn new(camera: &Camera, depth: &DepthConfig) -> Self {
        Self {
            size: (camera.pinhole.width, camera.pinhole.height),
            undistort: (!camera.distortion.is_zero()).then(|| UndistortMap::new(camera)),
            range: *depth,
            raw_rgb: Plane::new(0, 0),
            rgb: Plane::new(0, 0),
            raw_depth: Plane::new(0, 0),
            depth: Plane::new(0, 0),
        }
    }

    /// The frame size, (width, height).
    pub fn size(&self) -> (usize, usize) {
        self.size
    }

    /// Checks a pair without converting it (before a shared-memory sample is loaned).
    ///
    /// # Errors
    /// [`ImageError`] for an unknown encoding, another size, a short step or data.
    pub fn check(&self, colour: Received<'_>, depth: Received<'_>) -> Result<(), ImageError> {
        let kind = Colour::parse(&colour.image.encoding)
            .ok_or_else(|| colour.error(unknown_colour(&colour.image.encoding)))?;
        colour.rows(self.size, kind.bytes())?;
        depth.rows(self.size, depth_bytes(depth)?)?;
        Ok(())
    }

    /// Writes gray into `gray` and metres into `depth_out` (row-major, width stride).
    ///
    /// # Errors
    /// [`ImageError`] as [`FrameConverter::check`], or output slices of another size.
    pub fn convert(
        &mut self,
        colour: Received<'_>,
        depth: Received<'_>,
        gray: &mut [u8],
        depth_out: &mut [f32],
    ) -> Result<(), ImageError> {
        self.check(colour, depth)?;
        let (w, h) = self.size;
        if gray.len() != w * h || depth_out.len() != w * h {
            return Err(colour.error(format!(
                "frame planes of {} / {} pixels for a {w}x{h} camera",
                gray.len(),
                depth_out.len()
            )));
        }
        self.colour(colour, gray);
        self.depth_planes(depth, depth_out);
        Ok(())
    }

    /// The colour image as the dataset reader gives it, rgb undistorted (bilinear) when
    /// the camera has distortion, into `out`: what the tracking image is drawn on.
    ///
    /// # Errors
    /// [`ImageError`] for an unknown encoding, another size, a short step or data.
    pub fn undistorted_colour(
        &mut self,
        colour: Received<'_>,
        out: &mut RgbImage,
    ) -> Result<(), ImageError> {
        let kind = Colour::parse(&colour.image.encoding)
            .ok_or_else(|| colour.error(unknown_colour(&colour.image.encoding)))?;
        let step = colour.rows(self.size, kind.bytes())?;
        let (w, h) = self.size;
        let target = if self.undistort.is_some() {
            &mut self.raw_rgb
        } else {
            &mut *out
        };
        target.resize(w, h);
        for (y, src) in colour.image.data.chunks(step).take(h).enumerate() {
            for (px, p) in src.chunks_exact(kind.bytes()).zip(target.row_mut(y)) {
                *p = kind.rgb(px);
            }
        }
        if let Some(map) = &self.undistort {
            map.remap_rgb(&self.raw_rgb.view(), out)
                .map_err(|e| colour.error(e.to_string()))?;
        }
        Ok(())
    }

    fn colour(&mut self, colour: Received<'_>, gray: &mut [u8]) {
        let (w, h) = self.size;
        let img = colour.image;
        let kind = Colour::parse(&img.encoding).unwrap_or(Colour::Mono);
        let step = img.step as usize;
        let bytes = kind.bytes();
        let rows = img.data.chunks(step).take(h);
        match &self.undistort {
            None => {
                for (src, dst) in rows.zip(gray.chunks_exact_mut(w)) {
                    for (px, g) in src.chunks_exact(bytes).zip(dst.iter_mut()) {
                        *g = gray_bt601(kind.rgb(px));
                    }
                }
            }
            Some(map) => {
                // As the dataset reader: undistort colour (bilinear), then gray.
                self.raw_rgb.resize(w, h);
                for (y, src) in rows.enumerate() {
                    for (px, out) in src.chunks_exact(bytes).zip(self.raw_rgb.row_mut(y)) {
                        *out = kind.rgb(px);
                    }
                }
                if map.remap_rgb(&self.raw_rgb.view(), &mut self.rgb).is_ok() {
                    for (g, &p) in gray.iter_mut().zip(self.rgb.as_slice()) {
                        *g = gray_bt601(p);
                    }
                }
            }
        }
    }

    fn depth_planes(&mut self, depth: Received<'_>, out: &mut [f32]) {
        let (w, h) = self.size;
        let img = depth.image;
        let step = img.step as usize;
        let big = img.is_bigendian != 0;
        let millimetres = DepthConfig {
            scale: 1000.0,
            ..self.range
        };
        let range = self.range;
        let target: &mut [f32] = match &self.undistort {
            None => out,
            Some(_) => {
                self.raw_depth.resize(w, h);
                self.raw_depth.as_mut_slice()
            }
        };
        let rows = img
            .data
            .chunks(step)
            .take(h)
            .zip(target.chunks_exact_mut(w));
        if img.encoding == "32FC1" {
            for (src, dst) in rows {
                for (b, d) in src.chunks_exact(4).zip(dst.iter_mut()) {
                    let b = [b[0], b[1], b[2], b[3]];
                    let m = if big {
                        f32::from_be_bytes(b)
                    } else {
                        f32::from_le_bytes(b)
                    };
                    // NaN fails both comparisons: missing.
                    *d = if m >= range.min_m && m <= range.max_m {
                        m
                    } else {
                        0.0
                    };
                }
            }
        } else {
            for (src, dst) in rows {
                for (b, d) in src.chunks_exact(2).zip(dst.iter_mut()) {
                    let raw = if big {
                        u16::from_be_bytes([b[0], b[1]])
                    } else {
                        u16::from_le_bytes([b[0], b[1]])
                    };
                    *d = millimetres.metres(raw);
                }
            }
        }
        if let Some(map) = &self.undistort
            && map
                .remap_depth(&self.raw_depth.view(), &mut self.depth)
                .is_ok()
        {
            out.copy_from_slice(self.depth.as_slice());
        }
    }
}

fn unknown_colour(encoding: &str) -> String {
    format!("colour encoding {encoding:?} is not one of rgb8, bgr8, rgba8, bgra8, mono8")
}

fn depth_bytes(depth: Received<'_>) -> Result<usize, ImageError> {
    match depth.image.encoding.as_str() {
        "16UC1" | "mono16" => Ok(2),
        "32FC1" => Ok(4),
        other => Err(depth.error(format!(
            "depth encoding {other:?} is not 16UC1 (millimetres) or 32FC1 (metres) (REP 118)"
        ))),
    }
}

#[cfg(test)]
#[path = "image_tests.rs"]
mod tests;
