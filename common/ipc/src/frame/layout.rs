//! The fixed byte layout: header words, plane headers and plane offsets.

use super::error::FrameError;

/// First 8 bytes of every frame payload: "GFSFRM01".
pub const FRAME_MAGIC: u64 = u64::from_le_bytes(*b"GFSFRM01");

/// Bytes of the fixed header before the first plane.
pub const FRAME_HEADER_BYTES: usize = 128;

/// Alignment of every plane offset in bytes.
pub(super) const PLANE_ALIGN: usize = 64;

/// Words of one plane header.
pub(super) const PLANE_WORDS: usize = 5;

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
    pub(super) fn span_bytes(&self) -> Option<usize> {
        let elems = match self.height {
            0 => 0,
            h => self.stride.checked_mul(h - 1)?.checked_add(self.width)?,
        };
        elems.checked_mul(self.format.bytes_per_pixel())
    }
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
    pub(super) fn write_header(&self, bytes: &mut [u8]) {
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
