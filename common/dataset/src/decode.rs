//! Turning the files of one frame into a [`Frame`]: decode, check, undistort, gray, metres.
//!
//! [`FrameDecoder`] owns the per-frame scratch (file bytes, raw pixels, the distorted
//! images) and reuses it for every frame; the output images come from a recycled
//! [`Frame`] when the caller hands one back.

use crate::DepthConfig;
use crate::error::DatasetError;
use crate::lists::{Entry, ImageRef};
use gfs_core::camera::UndistortMap;
use gfs_core::ids::FrameId;
use gfs_core::stamp::Stamp;
use gfs_core::{DepthImage, GrayImage, Image, RgbImage};
use image::codecs::jpeg::JpegDecoder;
use image::codecs::png::PngDecoder;
use image::{ColorType, ImageDecoder};
use std::io::{Cursor, Read};
use std::path::Path;
use std::sync::Arc;

/// One RGB-D frame, ready for the algorithms.
#[derive(Clone, Debug)]
pub struct Frame {
    /// Index in the sequence (0-based, in input order).
    pub id: FrameId,
    /// Colour capture stamp, exactly as listed.
    pub timestamp: Stamp,
    /// Colour, undistorted (bilinear) when the camera has distortion.
    pub rgb: RgbImage,
    /// Gray from `rgb`, ITU-R BT.601 weights, rounded.
    pub gray: GrayImage,
    /// Depth in metres, 0.0 = missing; undistorted (nearest) when the camera has distortion.
    pub depth: DepthImage,
}

impl Frame {
    /// An empty frame whose buffers the decoder grows on first use.
    fn empty() -> Self {
        Self {
            id: FrameId(0),
            timestamp: Stamp::default(),
            rgb: Image::new(0, 0),
            gray: Image::new(0, 0),
            depth: Image::new(0, 0),
        }
    }
}

/// Decodes the frames of one sequence, reusing its scratch buffers.
pub(crate) struct FrameDecoder {
    size: (usize, usize),
    depth_config: DepthConfig,
    undistort: Option<Arc<UndistortMap>>,
    file_bytes: Vec<u8>,
    pixel_bytes: Vec<u8>,
    raw_rgb: RgbImage,
    raw_depth: DepthImage,
}

/// The two decoders the datasets need, behind one face.
enum AnyDecoder<'a> {
    Png(Box<PngDecoder<Cursor<&'a [u8]>>>),
    Jpeg(Box<JpegDecoder<Cursor<&'a [u8]>>>),
}

impl<'a> AnyDecoder<'a> {
    fn new(bytes: &'a [u8], path: &Path) -> Result<Self, DatasetError> {
        let err = |e: image::ImageError| decode_error(path, e);
        if bytes.starts_with(b"\x89PNG") {
            Ok(Self::Png(Box::new(
                PngDecoder::new(Cursor::new(bytes)).map_err(err)?,
            )))
        } else if bytes.starts_with(&[0xFF, 0xD8]) {
            Ok(Self::Jpeg(Box::new(
                JpegDecoder::new(Cursor::new(bytes)).map_err(err)?,
            )))
        } else {
            Err(DatasetError::Decode {
                path: path.to_path_buf(),
                message: "neither a PNG nor a JPEG file".to_owned(),
            })
        }
    }

    fn color_type(&self) -> ColorType {
        match self {
            Self::Png(d) => d.color_type(),
            Self::Jpeg(d) => d.color_type(),
        }
    }

    fn size(&self) -> (usize, usize) {
        let (w, h) = match self {
            Self::Png(d) => d.dimensions(),
            Self::Jpeg(d) => d.dimensions(),
        };
        (w as usize, h as usize)
    }

    /// Decodes into `buf`, which must hold exactly `width * height * bytes_per_pixel`.
    fn read_into(self, buf: &mut [u8], path: &Path) -> Result<(), DatasetError> {
        match self {
            Self::Png(d) => d.read_image(buf),
            Self::Jpeg(d) => d.read_image(buf),
        }
        .map_err(|e| decode_error(path, e))
    }
}

fn decode_error(path: &Path, e: image::ImageError) -> DatasetError {
    DatasetError::Decode {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// Gray value of an RGB pixel, ITU-R BT.601 weights (0.299, 0.587, 0.114), rounded.
#[inline]
pub fn gray_bt601(p: [u8; 3]) -> u8 {
    ((299 * u32::from(p[0]) + 587 * u32::from(p[1]) + 114 * u32::from(p[2]) + 500) / 1000) as u8
}

impl FrameDecoder {
    pub(crate) fn new(
        size: (usize, usize),
        depth_config: DepthConfig,
        undistort: Option<Arc<UndistortMap>>,
    ) -> Self {
        Self {
            size,
            depth_config,
            undistort,
            file_bytes: Vec::new(),
            pixel_bytes: Vec::new(),
            raw_rgb: Image::new(0, 0),
            raw_depth: Image::new(0, 0),
        }
    }

    /// A decoder with the same camera and depth settings and no scratch yet.
    pub(crate) fn clone_empty(&self) -> Self {
        Self::new(self.size, self.depth_config, self.undistort.clone())
    }

    /// Decodes frame `index`, writing into the buffers of `reuse` when given.
    pub(crate) fn decode(
        &mut self,
        index: usize,
        entry: &Entry,
        reuse: Option<Frame>,
    ) -> Result<Frame, DatasetError> {
        let mut frame = reuse.unwrap_or_else(Frame::empty);
        frame.id = FrameId(index as u64);
        frame.timestamp = entry.rgb.stamp;
        self.decode_rgb(&entry.rgb, &mut frame.rgb)?;
        self.decode_depth(&entry.depth, &mut frame.depth)?;
        frame.gray.resize(frame.rgb.width(), frame.rgb.height());
        for (g, &p) in frame
            .gray
            .as_mut_slice()
            .iter_mut()
            .zip(frame.rgb.as_slice())
        {
            *g = gray_bt601(p);
        }
        Ok(frame)
    }

    fn read_file(&mut self, image: &ImageRef) -> Result<(), DatasetError> {
        let mut file = std::fs::File::open(&image.path).map_err(|source| {
            if source.kind() == std::io::ErrorKind::NotFound {
                DatasetError::MissingImage {
                    path: image.path.clone(),
                    list: image.list.clone(),
                    line: image.line,
                }
            } else {
                DatasetError::Io {
                    path: image.path.clone(),
                    source,
                }
            }
        })?;
        self.file_bytes.clear();
        file.read_to_end(&mut self.file_bytes)
            .map_err(|source| DatasetError::Io {
                path: image.path.clone(),
                source,
            })?;
        Ok(())
    }

    fn check_size(&self, got: (usize, usize), path: &Path) -> Result<(), DatasetError> {
        if got == self.size {
            Ok(())
        } else {
            Err(DatasetError::SizeMismatch {
                path: path.to_path_buf(),
                got,
                expected: self.size,
            })
        }
    }

    fn decode_rgb(&mut self, image: &ImageRef, out: &mut RgbImage) -> Result<(), DatasetError> {
        self.read_file(image)?;
        let path = image.path.as_path();
        let decoder = AnyDecoder::new(&self.file_bytes, path)?;
        let (w, h) = decoder.size();
        self.check_size((w, h), path)?;
        // Without distortion the decoded pixels are the output; with it they are scratch.
        let target = if self.undistort.is_some() {
            &mut self.raw_rgb
        } else {
            &mut *out
        };
        target.resize(w, h);
        match decoder.color_type() {
            ColorType::Rgb8 => decoder.read_into(target.as_mut_slice().as_flattened_mut(), path)?,
            ColorType::Rgba8 => {
                self.pixel_bytes.resize(w * h * 4, 0);
                decoder.read_into(&mut self.pixel_bytes, path)?;
                for (dst, src) in target
                    .as_mut_slice()
                    .iter_mut()
                    .zip(self.pixel_bytes.chunks_exact(4))
                {
                    *dst = [src[0], src[1], src[2]];
                }
            }
            ColorType::L8 => {
                self.pixel_bytes.resize(w * h, 0);
                decoder.read_into(&mut self.pixel_bytes, path)?;
                for (dst, &g) in target.as_mut_slice().iter_mut().zip(&self.pixel_bytes) {
                    *dst = [g; 3];
                }
            }
            other => {
                return Err(DatasetError::ColourFormat {
                    path: path.to_path_buf(),
                    found: format!("{other:?}"),
                });
            }
        }
        if let Some(map) = &self.undistort {
            map.remap_rgb(&self.raw_rgb.view(), out)
                .map_err(|e| DatasetError::SizeMismatch {
                    path: path.to_path_buf(),
                    got: e.got,
                    expected: e.expected,
                })?;
        }
        Ok(())
    }

    fn decode_depth(&mut self, image: &ImageRef, out: &mut DepthImage) -> Result<(), DatasetError> {
        self.read_file(image)?;
        let path = image.path.as_path();
        let decoder = AnyDecoder::new(&self.file_bytes, path)?;
        let color = decoder.color_type();
        if color != ColorType::L16 {
            return Err(DatasetError::DepthNot16Bit {
                path: path.to_path_buf(),
                found: format!("{color:?}"),
            });
        }
        let (w, h) = decoder.size();
        self.check_size((w, h), path)?;
        self.pixel_bytes.resize(w * h * 2, 0);
        decoder.read_into(&mut self.pixel_bytes, path)?;
        let target = if self.undistort.is_some() {
            &mut self.raw_depth
        } else {
            &mut *out
        };
        target.resize(w, h);
        let config = self.depth_config;
        // The decoder hands 16-bit samples over in native byte order.
        for (dst, src) in target
            .as_mut_slice()
            .iter_mut()
            .zip(self.pixel_bytes.chunks_exact(2))
        {
            *dst = config.metres(u16::from_ne_bytes([src[0], src[1]]));
        }
        if let Some(map) = &self.undistort {
            map.remap_depth(&self.raw_depth.view(), out).map_err(|e| {
                DatasetError::SizeMismatch {
                    path: path.to_path_buf(),
                    got: e.got,
                    expected: e.expected,
                }
            })?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gray_uses_bt601_weights_rounded() {
        assert_eq!(gray_bt601([255, 255, 255]), 255);
        assert_eq!(gray_bt601([0, 0, 0]), 0);
        // 0.299 * 255 = 76.245 -> 76; 0.587 * 255 = 149.685 -> 150; 0.114 * 255 = 29.07 -> 29.
        assert_eq!(gray_bt601([255, 0, 0]), 76);
        assert_eq!(gray_bt601([0, 255, 0]), 150);
        assert_eq!(gray_bt601([0, 0, 255]), 29);
    }
}
