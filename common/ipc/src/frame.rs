//! The `Frame` message: gray (u8), depth (f32, metres) and optionally RGB images of one
//! frame in a single `[u8]` payload, read in place by every stage.
//!
//! Fixed layout (native endian, all header fields `u64`):
//!
//! ```text
//! byte 0    magic  FRAME_MAGIC
//! byte 8    gray  plane header: format, width, height, stride (elements), offset (bytes)
//! byte 48   depth plane header
//! byte 88   rgb   plane header (format 0 = absent)
//! byte 128  planes, each starting at a multiple of 64 bytes (cache line)
//! ```
//!
//! A plane of `height` rows needs `stride * (height - 1) + width` elements from its offset.
//! [`FrameView::parse`] checks every field against the payload length and alignment and
//! returns a [`FrameError`] for a malformed sample; it never panics and never copies.

use gfs_core::{ImageError, ImageView};
use thiserror::Error;

/// First 8 bytes of every frame payload: "GFSFRM01".
pub const FRAME_MAGIC: u64 = u64::from_le_bytes(*b"GFSFRM01");

/// Bytes of the fixed header before the first plane.
pub const FRAME_HEADER_BYTES: usize = 128;

/// Alignment of every plane offset in bytes.
const PLANE_ALIGN: usize = 64;

/// Words of one plane header.
const PLANE_WORDS: usize = 5;

/// Pixel format of a plane.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PixelFormat {
    /// 8-bit gray.
    Gray8,
    /// `f32` depth in metres, 0.0 = missing.
    DepthF32,
    /// 8-bit RGB, 3 bytes per pixel.
    Rgb8,
}

impl PixelFormat {
    /// Code stored in the plane header (0 is "absent").
    pub fn code(self) -> u64 {
        match self {
            PixelFormat::Gray8 => 1,
            PixelFormat::DepthF32 => 2,
            PixelFormat::Rgb8 => 3,
        }
    }

    /// Bytes per pixel.
    pub fn bytes_per_pixel(self) -> usize {
        match self {
            PixelFormat::Gray8 => 1,
            PixelFormat::DepthF32 => 4,
            PixelFormat::Rgb8 => 3,
        }
    }
}

/// Where one image lies in the payload.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PlaneHeader {
    /// Pixel format.
    pub format: PixelFormat,
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Elements (pixels) between row starts, >= width.
    pub stride: usize,
    /// Byte offset of the first pixel from the start of the payload.
    pub offset: usize,
}

impl PlaneHeader {
    /// Bytes the plane spans from its offset.
    fn span_bytes(&self) -> Option<usize> {
        let elems = match self.height {
            0 => 0,
            h => self.stride.checked_mul(h - 1)?.checked_add(self.width)?,
        };
        elems.checked_mul(self.format.bytes_per_pixel())
    }
}

/// A frame payload is malformed or cannot be laid out.
#[derive(Debug, Error, PartialEq, Eq)]
pub enum FrameError {
    /// The payload is shorter than the header or than a plane needs.
    #[error("frame payload of {got} bytes is truncated: {what} needs {need}")]
    Truncated {
        /// Payload length.
        got: usize,
        /// Bytes needed.
        need: usize,
        /// What needed them ("header", "gray plane", ...).
        what: &'static str,
    },
    /// The first 8 bytes are not [`FRAME_MAGIC`].
    #[error("frame payload has magic {found:#018x}, not a frame (or another layout version)")]
    BadMagic {
        /// The value found.
        found: u64,
    },
    /// A plane header holds the wrong format code or an impossible value.
    #[error("frame {plane} plane header is invalid: {reason}")]
    BadPlane {
        /// Which plane.
        plane: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// A plane's bytes are not aligned for its pixel type.
    #[error("frame {plane} plane at byte offset {offset} is misaligned for its pixel type")]
    Misaligned {
        /// Which plane.
        plane: &'static str,
        /// Byte offset in the payload.
        offset: usize,
    },
    /// The images to publish do not share one size.
    #[error("frame images differ in size: gray {gray:?}, depth {depth:?}, rgb {rgb:?}")]
    SizeMismatch {
        /// Gray (width, height).
        gray: (usize, usize),
        /// Depth (width, height).
        depth: (usize, usize),
        /// RGB (width, height), if any.
        rgb: Option<(usize, usize)>,
    },
    /// A view over a plane could not be made.
    #[error("frame {plane} plane: {source}")]
    Image {
        /// Which plane.
        plane: &'static str,
        /// The view error.
        #[source]
        source: ImageError,
    },
}

/// Byte layout of a frame of `width x height` pixels with unpadded planes (only made by
/// [`FrameLayout::new`], so its offsets are always consistent).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameLayout {
    gray: PlaneHeader,
    depth: PlaneHeader,
    rgb: Option<PlaneHeader>,
    byte_len: usize,
}

impl FrameLayout {
    /// The layout of a `width x height` frame, with an RGB plane when `with_rgb`.
    ///
    /// # Errors
    /// [`FrameError::BadPlane`] when the byte size overflows `usize`.
    pub fn new(width: usize, height: usize, with_rgb: bool) -> Result<Self, FrameError> {
        let mut end = FRAME_HEADER_BYTES;
        let mut place = |format: PixelFormat, plane: &'static str| {
            let offset = end.div_ceil(PLANE_ALIGN).checked_mul(PLANE_ALIGN);
            let header = offset.map(|offset| PlaneHeader {
                format,
                width,
                height,
                stride: width,
                offset,
            });
            let next = header
                .and_then(|h| Some((h, h.offset.checked_add(h.span_bytes()?)?)))
                .ok_or_else(|| FrameError::BadPlane {
                    plane,
                    reason: format!("{width}x{height} overflows the address space"),
                })?;
            end = next.1;
            Ok(next.0)
        };
        let gray = place(PixelFormat::Gray8, "gray")?;
        let depth = place(PixelFormat::DepthF32, "depth")?;
        let rgb = if with_rgb {
            Some(place(PixelFormat::Rgb8, "rgb")?)
        } else {
            None
        };
        Ok(Self {
            gray,
            depth,
            rgb,
            byte_len: end,
        })
    }

    /// Gray plane.
    pub fn gray(&self) -> PlaneHeader {
        self.gray
    }

    /// Depth plane.
    pub fn depth(&self) -> PlaneHeader {
        self.depth
    }

    /// RGB plane, if the frame carries colour.
    pub fn rgb(&self) -> Option<PlaneHeader> {
        self.rgb
    }

    /// Total payload bytes.
    pub fn byte_len(&self) -> usize {
        self.byte_len
    }

    /// Writes the fixed header into the first [`FRAME_HEADER_BYTES`] of `bytes`.
    fn write_header(&self, bytes: &mut [u8]) {
        let mut words = [0u64; FRAME_HEADER_BYTES / 8];
        words[0] = FRAME_MAGIC;
        let planes = [Some(self.gray), Some(self.depth), self.rgb];
        for (slot, plane) in planes.iter().enumerate() {
            if let Some(p) = plane {
                let base = 1 + slot * PLANE_WORDS;
                words[base..base + PLANE_WORDS].copy_from_slice(&[
                    p.format.code(),
                    p.width as u64,
                    p.height as u64,
                    p.stride as u64,
                    p.offset as u64,
                ]);
            }
        }
        for (chunk, word) in bytes.chunks_exact_mut(8).zip(words) {
            chunk.copy_from_slice(&word.to_ne_bytes());
        }
    }
}

/// The images of one frame to publish (borrowed; registered RGB-D: one size).
#[derive(Clone, Copy, Debug)]
pub struct FrameImages<'a> {
    /// Gray image.
    pub gray: ImageView<'a, u8>,
    /// Depth in metres, 0.0 = missing.
    pub depth: ImageView<'a, f32>,
    /// Colour, if published.
    pub rgb: Option<ImageView<'a, [u8; 3]>>,
}

impl FrameImages<'_> {
    /// The layout these images need.
    ///
    /// # Errors
    /// [`FrameError::SizeMismatch`] when the images differ in size.
    pub fn layout(&self) -> Result<FrameLayout, FrameError> {
        let size = |w: usize, h: usize| (w, h);
        let gray = size(self.gray.width(), self.gray.height());
        let depth = size(self.depth.width(), self.depth.height());
        let rgb = self.rgb.map(|v| size(v.width(), v.height()));
        if depth != gray || rgb.is_some_and(|r| r != gray) {
            return Err(FrameError::SizeMismatch { gray, depth, rgb });
        }
        FrameLayout::new(gray.0, gray.1, rgb.is_some())
    }
}

/// Writable planes of a frame payload (a loaned sample's bytes): the source decodes or
/// converts straight into them.
#[derive(Debug)]
pub struct FrameViewMut<'a> {
    /// Gray pixels, row-major, stride = width.
    pub gray: &'a mut [u8],
    /// Depth pixels in metres, row-major, stride = width.
    pub depth: &'a mut [f32],
    /// RGB pixels, row-major, stride = width, if the layout has colour.
    pub rgb: Option<&'a mut [[u8; 3]]>,
}

impl<'a> FrameViewMut<'a> {
    /// Writes `layout`'s header into `bytes` and splits the rest into its planes.
    ///
    /// # Errors
    /// [`FrameError::Truncated`] when `bytes` is shorter than `layout.byte_len()`,
    /// [`FrameError::Misaligned`] when `bytes` does not start 8-byte aligned (a topic
    /// payload always does, see [`crate::PAYLOAD_ALIGNMENT`]).
    pub fn new(layout: &FrameLayout, bytes: &'a mut [u8]) -> Result<Self, FrameError> {
        if bytes.len() < layout.byte_len {
            return Err(FrameError::Truncated {
                got: bytes.len(),
                need: layout.byte_len,
                what: "frame layout",
            });
        }
        layout.write_header(bytes);
        let (_, rest) = bytes.split_at_mut(layout.gray.offset);
        let gray_len = layout.depth.offset - layout.gray.offset;
        let (gray, rest) = rest.split_at_mut(gray_len);
        let depth_end = layout.rgb.map_or(layout.byte_len, |r| r.offset);
        let (depth, rgb) = rest.split_at_mut(depth_end - layout.depth.offset);
        let pixels = layout.gray.width * layout.gray.height;
        let cast_err = |plane, offset| FrameError::Misaligned { plane, offset };
        let depth: &mut [f32] = bytemuck::try_cast_slice_mut(&mut depth[..pixels * 4])
            .map_err(|_| cast_err("depth", layout.depth.offset))?;
        let rgb = match layout.rgb {
            Some(r) => Some(
                bytemuck::try_cast_slice_mut(&mut rgb[..pixels * 3])
                    .map_err(|_| cast_err("rgb", r.offset))?,
            ),
            None => None,
        };
        Ok(Self {
            gray: &mut gray[..pixels],
            depth,
            rgb,
        })
    }

    /// Copies `images` into the planes, row by row (source strides may differ).
    ///
    /// # Errors
    /// [`FrameError::SizeMismatch`] when the images do not fit the planes.
    pub fn copy_from(&mut self, images: &FrameImages<'_>) -> Result<(), FrameError> {
        let (w, h) = (images.gray.width(), images.gray.height());
        let fits = self.gray.len() == w * h
            && self.depth.len() == w * h
            && images.depth.width() == w
            && images.depth.height() == h
            && match (&self.rgb, images.rgb) {
                (Some(dst), Some(src)) => {
                    dst.len() == w * h && src.width() == w && src.height() == h
                }
                (None, None) => true,
                _ => false,
            };
        if !fits {
            return Err(FrameError::SizeMismatch {
                gray: (w, h),
                depth: (images.depth.width(), images.depth.height()),
                rgb: images.rgb.map(|v| (v.width(), v.height())),
            });
        }
        copy_rows(self.gray, &images.gray);
        copy_rows(self.depth, &images.depth);
        if let (Some(dst), Some(src)) = (self.rgb.as_deref_mut(), images.rgb.as_ref()) {
            copy_rows(dst, src);
        }
        Ok(())
    }
}

fn copy_rows<T: Copy>(dst: &mut [T], src: &ImageView<'_, T>) {
    if src.width() == 0 {
        return;
    }
    for (y, row) in dst.chunks_exact_mut(src.width()).enumerate() {
        row.copy_from_slice(src.row(y));
    }
}

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

#[cfg(test)]
mod tests {
    use super::*;

    /// An 8-byte aligned byte buffer, as a topic payload is.
    fn aligned(len: usize) -> Vec<u64> {
        vec![0u64; len.div_ceil(8)]
    }

    fn small_frame(w: usize, h: usize, with_rgb: bool) -> (FrameLayout, Vec<u64>) {
        let layout = FrameLayout::new(w, h, with_rgb).unwrap();
        let mut buf = aligned(layout.byte_len());
        let bytes: &mut [u8] = bytemuck::cast_slice_mut(&mut buf);
        let planes = FrameViewMut::new(&layout, &mut bytes[..layout.byte_len()]).unwrap();
        for (i, p) in planes.gray.iter_mut().enumerate() {
            *p = i as u8;
        }
        for (i, p) in planes.depth.iter_mut().enumerate() {
            *p = i as f32 * 0.5;
        }
        if let Some(rgb) = planes.rgb {
            for (i, p) in rgb.iter_mut().enumerate() {
                *p = [i as u8, 2, 3];
            }
        }
        (layout, buf)
    }

    #[test]
    fn vga_layout_offsets() {
        let l = FrameLayout::new(640, 480, true).unwrap();
        assert_eq!(l.gray().offset, 128);
        assert_eq!(l.depth().offset, 128 + 307_200);
        assert_eq!(l.rgb().unwrap().offset, 128 + 307_200 + 1_228_800);
        assert_eq!(l.byte_len(), 2_457_728);
        assert_eq!(
            FrameLayout::new(640, 480, false).unwrap().byte_len(),
            1_536_128
        );
        assert!(FrameLayout::new(usize::MAX / 2, 3, true).is_err());
    }

    #[test]
    fn written_frame_parses_back() {
        let (layout, buf) = small_frame(5, 3, true);
        let bytes: &[u8] = bytemuck::cast_slice(&buf);
        let f = FrameView::parse(&bytes[..layout.byte_len()]).unwrap();
        assert_eq!(f.gray().row(2), &[10, 11, 12, 13, 14]);
        assert_eq!(f.depth().get(4, 2), Some(7.0));
        assert_eq!(f.rgb().unwrap().get(1, 1), Some([6, 2, 3]));
        let (layout, buf) = small_frame(4, 4, false);
        let bytes: &[u8] = bytemuck::cast_slice(&buf);
        assert!(
            FrameView::parse(&bytes[..layout.byte_len()])
                .unwrap()
                .rgb()
                .is_none()
        );
        // Empty images are valid frames.
        let (layout, buf) = small_frame(0, 0, true);
        let bytes: &[u8] = bytemuck::cast_slice(&buf);
        assert!(
            FrameView::parse(&bytes[..layout.byte_len()])
                .unwrap()
                .gray()
                .is_empty()
        );
    }

    #[test]
    fn every_truncation_is_an_error() {
        let (layout, buf) = small_frame(5, 3, true);
        let bytes: &[u8] = bytemuck::cast_slice(&buf);
        for cut in 0..layout.byte_len() {
            assert!(
                matches!(
                    FrameView::parse(&bytes[..cut]),
                    Err(FrameError::Truncated { .. })
                ),
                "cut {cut}"
            );
        }
    }

    #[test]
    fn corrupt_headers_are_errors_not_panics() {
        let (layout, buf) = small_frame(5, 3, true);
        let good: &[u8] = bytemuck::cast_slice(&buf);
        let good = &good[..layout.byte_len()];
        let mut magic = buf.clone();
        magic[0] ^= 1;
        let magic: &[u8] = bytemuck::cast_slice(&magic);
        assert!(matches!(
            FrameView::parse(&magic[..layout.byte_len()]),
            Err(FrameError::BadMagic { .. })
        ));
        // Every header word set to every awkward value: Ok or Err, never a panic.
        for word in 1..FRAME_HEADER_BYTES / 8 {
            for value in [0, 1, 2, 3, 7, 127, 1 << 20, 1 << 40, u64::MAX / 3, u64::MAX] {
                let mut bad = buf.clone();
                bad[word] = value;
                let bytes: &[u8] = bytemuck::cast_slice(&bad);
                let _ = FrameView::parse(&bytes[..good.len()]);
            }
        }
        // Specific corruptions and the error each one gives (words: 1 + 5 * plane + field).
        let parse_with = |word: usize, value: u64| {
            let mut bad = buf.clone();
            bad[word] = value;
            let bytes: &[u8] = bytemuck::cast_slice(&bad);
            FrameView::parse(&bytes[..good.len()]).map(|_| ())
        };
        let bad_plane = |r: Result<(), FrameError>| matches!(r, Err(FrameError::BadPlane { .. }));
        assert!(bad_plane(parse_with(1, 2)), "gray slot with depth format");
        assert!(bad_plane(parse_with(6, 0)), "depth plane missing");
        assert!(
            bad_plane(parse_with(5, 64)),
            "gray offset inside the header"
        );
        assert!(bad_plane(parse_with(2, u64::MAX)), "width overflows");
        let truncated = |r: Result<(), FrameError>| matches!(r, Err(FrameError::Truncated { .. }));
        assert!(
            truncated(parse_with(8, 1 << 20)),
            "depth height past the end"
        );
        assert!(
            truncated(parse_with(15, 1 << 40)),
            "rgb offset past the end"
        );
        assert!(
            matches!(
                parse_with(9, 2),
                Err(FrameError::Image { plane: "depth", .. })
            ),
            "stride below width"
        );
        assert_eq!(
            parse_with(11, 0),
            Ok(()),
            "rgb plane dropped is still a frame"
        );
        // A payload that starts off the 8-byte grid cannot be read as f32 in place.
        let mut shifted = aligned(good.len() + 8);
        let sbytes: &mut [u8] = bytemuck::cast_slice_mut(&mut shifted);
        sbytes[1..=good.len()].copy_from_slice(good);
        assert!(matches!(
            FrameView::parse(&sbytes[1..=good.len()]),
            Err(FrameError::Misaligned { plane: "depth", .. })
        ));
    }

    #[test]
    fn images_of_different_sizes_are_refused() {
        let gray = vec![0u8; 12];
        let depth = vec![0f32; 12];
        let images = FrameImages {
            gray: ImageView::new(4, 3, 4, &gray).unwrap(),
            depth: ImageView::new(3, 4, 3, &depth).unwrap(),
            rgb: None,
        };
        assert!(matches!(
            images.layout(),
            Err(FrameError::SizeMismatch { .. })
        ));
    }
}
