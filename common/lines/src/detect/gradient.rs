//! Gradients, EDLines step 2: Sobel `gx`, `gy` of the smoothed image, magnitude
//! `|gx| + |gy|` (0..2040 for a 0..255 image), and the edge orientation of every pixel
//! whose magnitude reaches the gradient threshold. Border pixels get a zero gradient, so
//! that edge routing never needs a bounds check (every candidate is interior).

use gfs_core::Image;

/// Orientation code of a pixel below the gradient threshold (not an edge candidate).
pub(crate) const NONE: u8 = 0;
/// Edge running horizontally (`|gy| >= |gx|`): routed left / right.
pub(crate) const HORIZONTAL: u8 = 1;
/// Edge running vertically (`|gx| > |gy|`): routed up / down.
pub(crate) const VERTICAL: u8 = 2;
/// Bits of the orientation code in the state map.
pub(crate) const ORIENTATION: u8 = 3;
/// State bit set on a pixel once it belongs to an edge chain.
pub(crate) const EDGE: u8 = 4;

/// Gradient maps of one frame; all images have the frame size.
#[derive(Debug)]
pub(crate) struct Gradients {
    /// Sobel derivative along u (columns), positive when brighter to the right.
    pub gx: Image<i16>,
    /// Sobel derivative along v (rows), positive when brighter below.
    pub gy: Image<i16>,
    /// `|gx| + |gy|`.
    pub magnitude: Image<u16>,
    /// Orientation code ([`NONE`], [`HORIZONTAL`], [`VERTICAL`]) plus the [`EDGE`] bit.
    pub state: Image<u8>,
}

impl Gradients {
    pub(crate) fn new() -> Self {
        Self {
            gx: Image::new(0, 0),
            gy: Image::new(0, 0),
            magnitude: Image::new(0, 0),
            state: Image::new(0, 0),
        }
    }

    /// Fills every map from `smooth`; pixels below `threshold` get [`NONE`].
    pub(crate) fn compute(&mut self, smooth: &Image<u8>, threshold: u16) {
        let (w, h) = (smooth.width(), smooth.height());
        self.gx.resize(w, h);
        self.gy.resize(w, h);
        self.magnitude.resize(w, h);
        self.state.resize(w, h);
        if w < 3 || h < 3 {
            self.gx.fill(0);
            self.gy.fill(0);
            self.magnitude.fill(0);
            self.state.fill(NONE);
            return;
        }
        // The interior is overwritten below: only the border needs clearing.
        for y in [0, h - 1] {
            self.gx.row_mut(y).fill(0);
            self.gy.row_mut(y).fill(0);
            self.magnitude.row_mut(y).fill(0);
            self.state.row_mut(y).fill(NONE);
        }
        for y in 1..h - 1 {
            for x in [0, w - 1] {
                self.gx.set(x, y, 0);
                self.gy.set(x, y, 0);
                self.magnitude.set(x, y, 0);
                self.state.set(x, y, NONE);
            }
        }
        let threshold = threshold.max(1);
        for y in 1..h - 1 {
            let (p, c, n) = (smooth.row(y - 1), smooth.row(y), smooth.row(y + 1));
            let range = y * w + 1..(y + 1) * w - 1;
            let gx = &mut self.gx.as_mut_slice()[range.clone()];
            let gy = &mut self.gy.as_mut_slice()[range.clone()];
            let mag = &mut self.magnitude.as_mut_slice()[range.clone()];
            let state = &mut self.state.as_mut_slice()[range];
            for i in 0..w - 2 {
                // Column x = i + 1; the three columns i, i + 1, i + 2.
                let (p0, p1, p2) = (i16::from(p[i]), i16::from(p[i + 1]), i16::from(p[i + 2]));
                let (c0, c2) = (i16::from(c[i]), i16::from(c[i + 2]));
                let (n0, n1, n2) = (i16::from(n[i]), i16::from(n[i + 1]), i16::from(n[i + 2]));
                let dx = (p2 + 2 * c2 + n2) - (p0 + 2 * c0 + n0);
                let dy = (n0 + 2 * n1 + n2) - (p0 + 2 * p1 + p2);
                let (ax, ay) = (dx.unsigned_abs(), dy.unsigned_abs());
                let m = ax + ay;
                gx[i] = dx;
                gy[i] = dy;
                mag[i] = m;
                state[i] = if m < threshold {
                    NONE
                } else if ay >= ax {
                    HORIZONTAL
                } else {
                    VERTICAL
                };
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_vertical_step_gives_a_vertical_edge_with_the_sobel_magnitude() {
        let mut img = Image::new(8, 6);
        for y in 0..6 {
            for x in 4..8 {
                img.set(x, y, 100u8);
            }
        }
        let mut g = Gradients::new();
        g.compute(&img, 36);
        // Columns 3 and 4 straddle the step: Sobel gives 4 * 100.
        assert_eq!(g.gx.get(3, 2), Some(400));
        assert_eq!(g.gx.get(4, 2), Some(400));
        assert_eq!(g.gy.get(3, 2), Some(0));
        assert_eq!(g.state.get(3, 2), Some(VERTICAL));
        assert_eq!(g.state.get(1, 2), Some(NONE));
        // Borders carry no gradient.
        assert_eq!(g.magnitude.get(3, 0), Some(0));
    }
}
