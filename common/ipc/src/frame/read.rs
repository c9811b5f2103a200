//! Reading a frame: validation of a received payload and views into it.

use gfs_core::ImageView;

use super::error::FrameError;
use super::layout::{FRAME_HEADER_BYTES, FRAME_MAGIC, PLANE_WORDS, PixelFormat, PlaneHeader};

/// The images of a received frame payload, borrowed from it (no copy).
#[derive(Clone, Copy, Debug)]
pub struct FrameView<'a> {
    gray: ImageView<'a, u8>,
    depth: ImageView<'a, f32>,
    rgb: Option<ImageView<'a, [u8; 3]>>,
}

impl<'a> FrameView<'a> {
    /// Validates the frame payload `bytes` and borrows its images.
    ///
    /// # Errors
    /// [`FrameError::Truncated`], [`FrameError::BadMagic`], [`FrameError::BadPlane`],
    /// [`FrameError::Misaligned`] or [`FrameError::Image`] for a malformed payload.
    pub fn parse(bytes: &'a [u8]) -> Result<Self, FrameError> {
        if bytes.len() < FRAME_HEADER_BYTES {
            return Err(FrameError::Truncated {
                got: bytes.len(),
                need: FRAME_HEADER_BYTES,
                what: "header",
            });
        }
        let word = |i: usize| {
            let mut w = [0u8; 8];
            w.copy_from_slice(&bytes[i * 8..i * 8 + 8]);
            u64::from_ne_bytes(w)
        };
        if word(0) != FRAME_MAGIC {
            return Err(FrameError::BadMagic { found: word(0) });
        }
        let plane = |slot: usize, name: &'static str, format: PixelFormat| {
            let base = 1 + slot * PLANE_WORDS;
            let code = word(base);
            if code == 0 {
                return Ok(None);
            }
            let bad = |reason: String| FrameError::BadPlane {
                plane: name,
                reason,
            };
            if code != format.code() {
                return Err(bad(format!(
                    "format code {code}, expected {}",
                    format.code()
                )));
            }
            let field = |i: usize, what: &str| {
                usize::try_from(word(base + i)).map_err(|_| bad(format!("{what} too large")))
            };
            let header = PlaneHeader {
                format,
                width: field(1, "width")?,
                height: field(2, "height")?,
                stride: field(3, "stride")?,
                offset: field(4, "offset")?,
            };
            if header.offset < FRAME_HEADER_BYTES {
                return Err(bad(format!("offset {} inside the header", header.offset)));
            }
            let end = header
                .span_bytes()
                .and_then(|n| n.checked_add(header.offset))
                .ok_or_else(|| bad("size overflows".to_string()))?;
            if end > bytes.len() {
                return Err(FrameError::Truncated {
                    got: bytes.len(),
                    need: end,
                    what: name,
                });
            }
            Ok(Some((header, &bytes[header.offset..end])))
        };
        let required = |p: Option<_>, name: &'static str| {
            p.ok_or_else(|| FrameError::BadPlane {
                plane: name,
                reason: "missing".to_string(),
            })
        };
        let (gh, gray) = required(plane(0, "gray", PixelFormat::Gray8)?, "gray")?;
        let (dh, depth) = required(plane(1, "depth", PixelFormat::DepthF32)?, "depth")?;
        let rgb = plane(2, "rgb", PixelFormat::Rgb8)?;

        let view_err = |plane| move |source| FrameError::Image { plane, source };
        let gray =
            ImageView::new(gh.width, gh.height, gh.stride, gray).map_err(view_err("gray"))?;
        let depth: &[f32] =
            bytemuck::try_cast_slice(depth).map_err(|_| FrameError::Misaligned {
                plane: "depth",
                offset: dh.offset,
            })?;
        let depth =
            ImageView::new(dh.width, dh.height, dh.stride, depth).map_err(view_err("depth"))?;
        let rgb = match rgb {
            Some((rh, bytes)) => {
                let px: &[[u8; 3]] =
                    bytemuck::try_cast_slice(bytes).map_err(|_| FrameError::Misaligned {
                        plane: "rgb",
                        offset: rh.offset,
                    })?;
                Some(ImageView::new(rh.width, rh.height, rh.stride, px).map_err(view_err("rgb"))?)
            }
            None => None,
        };
        Ok(Self { gray, depth, rgb })
    }

    /// Gray image.
    pub fn gray(&self) -> ImageView<'a, u8> {
        self.gray
    }

    /// Depth image in metres, 0.0 = missing.
    pub fn depth(&self) -> ImageView<'a, f32> {
        self.depth
    }

    /// Colour image, if the frame carries one.
    pub fn rgb(&self) -> Option<ImageView<'a, [u8; 3]>> {
        self.rgb
    }
}
