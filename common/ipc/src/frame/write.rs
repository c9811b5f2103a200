//! Writing a frame: images to publish and the writable planes of a loaned sample.

use gfs_core::ImageView;

use super::error::FrameError;
use super::layout::FrameLayout;

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
        if bytes.len() < layout.byte_len() {
            return Err(FrameError::Truncated {
                got: bytes.len(),
                need: layout.byte_len(),
                what: "frame layout",
            });
        }
        layout.write_header(bytes);
        let (_, rest) = bytes.split_at_mut(layout.gray().offset);
        let gray_len = layout.depth().offset - layout.gray().offset;
        let (gray, rest) = rest.split_at_mut(gray_len);
        let depth_end = layout.rgb().map_or(layout.byte_len(), |r| r.offset);
        let (depth, rgb) = rest.split_at_mut(depth_end - layout.depth().offset);
        let pixels = layout.gray().width * layout.gray().height;
        let cast_err = |plane, offset| FrameError::Misaligned { plane, offset };
        let depth: &mut [f32] = bytemuck::try_cast_slice_mut(&mut depth[..pixels * 4])
            .map_err(|_| cast_err("depth", layout.depth().offset))?;
        let rgb = match layout.rgb() {
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
