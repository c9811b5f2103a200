//! A minimal RGB raster canvas: rectangles, thick lines, dots and bitmap text, clipped
//! to the image so that any coordinate is safe.

use super::font::{ADVANCE, GLYPH_H, GLYPH_W, glyph};
use gfs_core::{Image, RgbImage};

/// An RGB colour.
pub type Rgb = [u8; 3];

/// A drawing surface over an owned RGB image.
pub struct Canvas {
    image: RgbImage,
}

impl Canvas {
    /// A `width x height` canvas filled with `background`.
    pub fn new(width: usize, height: usize, background: Rgb) -> Self {
        let mut image = Image::new(width, height);
        image.fill(background);
        Self { image }
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.image.width()
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.image.height()
    }

    /// The drawing.
    pub fn into_image(self) -> RgbImage {
        self.image
    }

    /// Sets one pixel; coordinates outside the canvas are ignored.
    pub fn put(&mut self, x: i64, y: i64, color: Rgb) {
        if x >= 0 && y >= 0 && (x as usize) < self.width() && (y as usize) < self.height() {
            self.image.set(x as usize, y as usize, color);
        }
    }

    /// Fills the rectangle `[x0, x1) x [y0, y1)` (clipped).
    pub fn fill_rect(&mut self, x0: i64, y0: i64, x1: i64, y1: i64, color: Rgb) {
        let clamp_x = |v: i64| v.clamp(0, self.width() as i64) as usize;
        let clamp_y = |v: i64| v.clamp(0, self.height() as i64) as usize;
        let (xa, xb, ya, yb) = (clamp_x(x0), clamp_x(x1), clamp_y(y0), clamp_y(y1));
        for y in ya..yb {
            if xa < xb {
                self.image.row_mut(y)[xa..xb].fill(color);
            }
        }
    }

    /// A one-pixel rectangle outline.
    pub fn rect_outline(&mut self, x0: i64, y0: i64, x1: i64, y1: i64, color: Rgb) {
        self.fill_rect(x0, y0, x1, y0 + 1, color);
        self.fill_rect(x0, y1 - 1, x1, y1, color);
        self.fill_rect(x0, y0, x0 + 1, y1, color);
        self.fill_rect(x1 - 1, y0, x1, y1, color);
    }

    /// A square dot of side `size` centred on (`x`, `y`).
    pub fn dot(&mut self, x: f64, y: f64, size: usize, color: Rgb) {
        if !(x.is_finite() && y.is_finite()) {
            return;
        }
        let half = size as f64 / 2.0;
        // Pixel k covers [k - 0.5, k + 0.5): the square starts at the pixel holding x - half + 0.5.
        let (x0, y0) = (
            (x - half + 0.5).floor() as i64,
            (y - half + 0.5).floor() as i64,
        );
        self.fill_rect(x0, y0, x0 + size as i64, y0 + size as i64, color);
    }

    /// A line of `width` pixels from (`x0`, `y0`) to (`x1`, `y1`), stepped one pixel at a
    /// time along its longer axis. Far-off or non-finite ends are ignored.
    pub fn line(&mut self, x0: f64, y0: f64, x1: f64, y1: f64, width: usize, color: Rgb) {
        const LIMIT: f64 = 1e6;
        if ![x0, y0, x1, y1]
            .iter()
            .all(|v| v.is_finite() && v.abs() < LIMIT)
        {
            return;
        }
        let steps = (x1 - x0).abs().max((y1 - y0).abs()).ceil().max(1.0) as usize;
        for k in 0..=steps {
            let f = k as f64 / steps as f64;
            self.dot(x0 + f * (x1 - x0), y0 + f * (y1 - y0), width, color);
        }
    }

    /// A dashed horizontal line from `x0` to `x1` at row `y`.
    pub fn dashed_hline(&mut self, x0: i64, x1: i64, y: i64, dash: i64, color: Rgb) {
        let mut x = x0;
        while x < x1 {
            self.fill_rect(x, y, (x + dash).min(x1), y + 1, color);
            x += 2 * dash;
        }
    }

    /// Pixel width of `text` at `scale`.
    pub fn text_width(text: &str, scale: usize) -> i64 {
        (text.chars().count() * ADVANCE * scale) as i64
    }

    /// Pixel height of a line of text at `scale`.
    pub fn text_height(scale: usize) -> i64 {
        (GLYPH_H * scale) as i64
    }

    /// Writes `text` with its top-left corner at (`x`, `y`), each font pixel a
    /// `scale x scale` square.
    pub fn text(&mut self, x: i64, y: i64, text: &str, scale: usize, color: Rgb) {
        let s = scale as i64;
        for (i, c) in text.chars().enumerate() {
            let left = x + (i * ADVANCE * scale) as i64;
            for (row, bits) in glyph(c).iter().enumerate() {
                for col in 0..GLYPH_W {
                    if bits & (1 << (GLYPH_W - 1 - col)) != 0 {
                        let (px, py) = (left + col as i64 * s, y + row as i64 * s);
                        self.fill_rect(px, py, px + s, py + s, color);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const BLACK: Rgb = [0, 0, 0];
    const WHITE: Rgb = [255, 255, 255];

    fn count(c: &Canvas, color: Rgb) -> usize {
        c.image.as_slice().iter().filter(|&&p| p == color).count()
    }

    #[test]
    fn lines_and_rects_are_clipped_and_sized() {
        let mut c = Canvas::new(20, 10, WHITE);
        c.line(0.0, 5.0, 19.0, 5.0, 1, BLACK);
        assert_eq!(count(&c, BLACK), 20);
        c.fill_rect(-5, -5, 100, 100, BLACK);
        assert_eq!(count(&c, BLACK), 200);
        // Off-canvas and non-finite coordinates draw nothing and do not panic.
        let mut c = Canvas::new(0, 0, WHITE);
        c.line(f64::NAN, 0.0, 1e300, 3.0, 3, BLACK);
        c.text(-3, -3, "ATE 0.1 m", 2, BLACK);
        assert!(c.into_image().is_empty());
    }

    #[test]
    fn text_lights_the_glyph_pixels_at_scale() {
        let mut c = Canvas::new(40, 20, WHITE);
        c.text(1, 1, "1", 2, BLACK);
        // 10 font pixels, 4 image pixels each.
        assert_eq!(count(&c, BLACK), 40);
        assert_eq!(Canvas::text_width("ab", 2), 24);
    }
}
