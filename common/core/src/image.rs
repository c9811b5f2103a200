//! Image buffers and borrowed views.
//!
//! Memory model: an [`Image`] owns a contiguous row-major buffer with no padding
//! (stride = width). An [`ImageView`] borrows any row-major buffer with a stride of at
//! least its width, so that a shared-memory sample or a sub-window is read in place.

use thiserror::Error;

/// A view or image could not be made from the given buffer.
#[derive(Debug, Error, PartialEq, Eq)]
pub enum ImageError {
    /// The buffer is shorter than `stride * (height - 1) + width` elements.
    #[error(
        "buffer of {got} elements is too small for {width}x{height} with stride {stride} (needs {need})"
    )]
    BufferTooSmall {
        /// Elements in the buffer.
        got: usize,
        /// Elements needed.
        need: usize,
        /// Requested width in pixels.
        width: usize,
        /// Requested height in pixels.
        height: usize,
        /// Requested stride in elements.
        stride: usize,
    },
    /// The stride is smaller than the width.
    #[error("stride {stride} is smaller than the width {width}")]
    StrideTooSmall {
        /// Requested width in pixels.
        width: usize,
        /// Requested stride in elements.
        stride: usize,
    },
}

/// An owned image: `width * height` pixels of `T`, row-major, no padding.
#[derive(Clone, Debug, PartialEq)]
pub struct Image<T> {
    width: usize,
    height: usize,
    data: Vec<T>,
}

/// 8-bit gray image.
pub type GrayImage = Image<u8>;
/// Depth image in metres, 0.0 = missing.
pub type DepthImage = Image<f32>;
/// 8-bit RGB colour image.
pub type RgbImage = Image<[u8; 3]>;

impl<T: Copy + Default> Image<T> {
    /// A `width x height` image filled with `T::default()`.
    pub fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            data: vec![T::default(); width * height],
        }
    }

    /// Resizes to `width x height`, reusing the allocation. Pixel values are unspecified
    /// afterwards (callers overwrite them); this is the per-frame scratch pattern.
    pub fn resize(&mut self, width: usize, height: usize) {
        self.width = width;
        self.height = height;
        self.data.resize(width * height, T::default());
    }

    /// Sets every pixel to `value`.
    pub fn fill(&mut self, value: T) {
        self.data.fill(value);
    }
}

impl<T: Copy> Image<T> {
    /// Wraps `data` (row-major, `width * height` elements).
    ///
    /// # Errors
    /// [`ImageError::BufferTooSmall`] when the length is not `width * height`.
    pub fn from_vec(width: usize, height: usize, data: Vec<T>) -> Result<Self, ImageError> {
        if data.len() != width * height {
            return Err(ImageError::BufferTooSmall {
                got: data.len(),
                need: width * height,
                width,
                height,
                stride: width,
            });
        }
        Ok(Self {
            width,
            height,
            data,
        })
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// True when the image has no pixel.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// All pixels, row-major.
    pub fn as_slice(&self) -> &[T] {
        &self.data
    }

    /// All pixels, row-major, mutable.
    pub fn as_mut_slice(&mut self) -> &mut [T] {
        &mut self.data
    }

    /// Consumes the image and returns its buffer.
    pub fn into_vec(self) -> Vec<T> {
        self.data
    }

    /// Row `y`. Panics when `y >= height` (a bug, not an input error).
    pub fn row(&self, y: usize) -> &[T] {
        &self.data[y * self.width..(y + 1) * self.width]
    }

    /// Row `y`, mutable. Panics when `y >= height`.
    pub fn row_mut(&mut self, y: usize) -> &mut [T] {
        &mut self.data[y * self.width..(y + 1) * self.width]
    }

    /// Pixel at column `x`, row `y`, or `None` outside the image.
    pub fn get(&self, x: usize, y: usize) -> Option<T> {
        self.view().get(x, y)
    }

    /// Writes pixel (`x`, `y`). Panics outside the image.
    pub fn set(&mut self, x: usize, y: usize, value: T) {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside image"
        );
        self.data[y * self.width + x] = value;
    }

    /// A borrowed view of the whole image.
    pub fn view(&self) -> ImageView<'_, T> {
        ImageView {
            width: self.width,
            height: self.height,
            stride: self.width,
            data: &self.data,
        }
    }
}

/// A borrowed row-major image with a stride (elements between row starts) >= width.
#[derive(Clone, Copy, Debug)]
pub struct ImageView<'a, T> {
    width: usize,
    height: usize,
    stride: usize,
    data: &'a [T],
}

impl<'a, T: Copy> ImageView<'a, T> {
    /// A view of `data` as `width x height` pixels, rows `stride` elements apart.
    ///
    /// # Errors
    /// [`ImageError::StrideTooSmall`] or [`ImageError::BufferTooSmall`] when the buffer
    /// cannot hold the image.
    pub fn new(
        width: usize,
        height: usize,
        stride: usize,
        data: &'a [T],
    ) -> Result<Self, ImageError> {
        if stride < width {
            return Err(ImageError::StrideTooSmall { width, stride });
        }
        let need = if height == 0 {
            0
        } else {
            stride * (height - 1) + width
        };
        if data.len() < need {
            return Err(ImageError::BufferTooSmall {
                got: data.len(),
                need,
                width,
                height,
                stride,
            });
        }
        Ok(Self {
            width,
            height,
            stride,
            data,
        })
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Elements between the starts of two rows.
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// True when the view has no pixel.
    pub fn is_empty(&self) -> bool {
        self.width == 0 || self.height == 0
    }

    /// The underlying buffer (rows `stride` apart).
    pub fn as_slice(&self) -> &'a [T] {
        self.data
    }

    /// Row `y` (`width` elements). Panics when `y >= height`.
    pub fn row(&self, y: usize) -> &'a [T] {
        let start = y * self.stride;
        &self.data[start..start + self.width]
    }

    /// Pixel at column `x`, row `y`, or `None` outside the view.
    pub fn get(&self, x: usize, y: usize) -> Option<T> {
        if x < self.width && y < self.height {
            Some(self.data[y * self.stride + x])
        } else {
            None
        }
    }

    /// Pixel at (`x`, `y`) without the `Option`; panics outside (bounds are the caller's
    /// invariant in hot loops that already clipped their range).
    #[inline]
    pub fn at(&self, x: usize, y: usize) -> T {
        debug_assert!(x < self.width && y < self.height);
        self.data[y * self.stride + x]
    }

    /// Copies the view into an owned, unpadded image.
    pub fn to_image(&self) -> Image<T> {
        let mut data = Vec::with_capacity(self.width * self.height);
        for y in 0..self.height {
            data.extend_from_slice(self.row(y));
        }
        Image {
            width: self.width,
            height: self.height,
            data,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn view_with_stride_reads_the_right_pixels() {
        let data: Vec<u8> = (0..20).collect();
        let v = ImageView::new(3, 4, 5, &data).unwrap();
        assert_eq!(v.row(2), &[10, 11, 12]);
        assert_eq!(v.get(2, 3), Some(17));
        assert_eq!(v.get(3, 0), None);
        assert_eq!(
            v.to_image().as_slice(),
            &[0, 1, 2, 5, 6, 7, 10, 11, 12, 15, 16, 17]
        );
    }

    #[test]
    fn too_small_buffers_are_errors_not_panics() {
        let data = [0u8; 10];
        assert_eq!(
            ImageView::new(3, 4, 3, &data).unwrap_err(),
            ImageError::BufferTooSmall {
                got: 10,
                need: 12,
                width: 3,
                height: 4,
                stride: 3
            }
        );
        assert!(matches!(
            ImageView::new(4, 1, 3, &data),
            Err(ImageError::StrideTooSmall { .. })
        ));
        assert!(Image::from_vec(2, 2, vec![0u8; 3]).is_err());
        assert!(ImageView::<u8>::new(0, 0, 0, &[]).unwrap().is_empty());
    }
}
