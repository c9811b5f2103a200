//! The Gaussian smoothing the descriptor is computed on: 7x7, sigma 2 (ORB-SLAM2,
//! `GaussianBlur(.., Size(7, 7), 2, 2, BORDER_REFLECT_101)`), separable, in 8-bit fixed
//! point so that both passes run on `u16` lanes (8 pixels per SSE2 register).

use crate::simd::avx2_dispatch;
use gfs_core::{GrayImage, ImageView};

/// `exp(-x^2 / (2 * 2^2))` for x = 0..3, normalised and scaled to sum 256 (errors
/// below 0.7 / 256 per tap).
const KERNEL: [u16; 4] = [56, 49, 33, 18];
const RADIUS: usize = 3;

/// Reusable buffers of the blur.
#[derive(Debug)]
pub(crate) struct GaussianBlur {
    /// Horizontal pass result.
    tmp: GrayImage,
    /// One source row with `RADIUS` reflected pixels on each side.
    padded: Vec<u8>,
}

impl Default for GaussianBlur {
    fn default() -> Self {
        Self {
            tmp: GrayImage::new(0, 0),
            padded: Vec::new(),
        }
    }
}

/// Index `i` (which may be up to `RADIUS` outside `0..n`) reflected without repeating
/// the edge pixel (OpenCV `BORDER_REFLECT_101`); needs `n > RADIUS`.
fn reflect(i: isize, n: usize) -> usize {
    let n = n as isize;
    let r = if i < 0 {
        -i
    } else if i >= n {
        2 * n - 2 - i
    } else {
        i
    };
    r as usize
}

impl GaussianBlur {
    /// Smooths `src` into `dst` (resized to the same size). Images narrower or shorter
    /// than 4 pixels are copied unchanged.
    pub(crate) fn apply(&mut self, src: ImageView<'_, u8>, dst: &mut GrayImage) {
        let (w, h) = (src.width(), src.height());
        dst.resize(w, h);
        if w <= RADIUS || h <= RADIUS {
            for y in 0..h {
                dst.row_mut(y).copy_from_slice(src.row(y));
            }
            return;
        }
        self.tmp.resize(w, h);
        self.padded.resize(w + 2 * RADIUS, 0);
        for y in 0..h {
            let row = src.row(y);
            self.padded[RADIUS..RADIUS + w].copy_from_slice(row);
            for k in 1..=RADIUS {
                self.padded[RADIUS - k] = row[reflect(-(k as isize), w)];
                self.padded[RADIUS + w - 1 + k] = row[reflect((w - 1 + k) as isize, w)];
            }
            horizontal(&self.padded, self.tmp.row_mut(y));
        }
        for y in 0..h {
            let r = |d: isize| self.tmp.row(reflect(y as isize + d, h));
            vertical(
                [r(-3), r(-2), r(-1), r(0), r(1), r(2), r(3)],
                dst.row_mut(y),
            );
        }
    }
}

avx2_dispatch! {
fn horizontal(p: &[u8], out: &mut [u8]) {
    let n = out.len();
    let (a, b, c, d) = (&p[0..n], &p[1..n + 1], &p[2..n + 2], &p[3..n + 3]);
    let (e, f, g) = (&p[4..n + 4], &p[5..n + 5], &p[6..n + 6]);
    for i in 0..n {
        let s = KERNEL[3] * (u16::from(a[i]) + u16::from(g[i]))
            + KERNEL[2] * (u16::from(b[i]) + u16::from(f[i]))
            + KERNEL[1] * (u16::from(c[i]) + u16::from(e[i]))
            + KERNEL[0] * u16::from(d[i]);
        out[i] = ((s + 128) >> 8) as u8;
    }
}
}

avx2_dispatch! {
fn vertical(rows: [&[u8]; 7], out: &mut [u8]) {
    let n = out.len();
    let [a, b, c, d, e, f, g] = rows.map(|r| &r[..n]);
    for i in 0..n {
        let s = KERNEL[3] * (u16::from(a[i]) + u16::from(g[i]))
            + KERNEL[2] * (u16::from(b[i]) + u16::from(f[i]))
            + KERNEL[1] * (u16::from(c[i]) + u16::from(e[i]))
            + KERNEL[0] * u16::from(d[i]);
        out[i] = ((s + 128) >> 8) as u8;
    }
}
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kernel_sums_to_one_and_matches_sigma_2() {
        let sum: u16 = KERNEL[0] + 2 * (KERNEL[1] + KERNEL[2] + KERNEL[3]);
        assert_eq!(sum, 256);
        let g: Vec<f64> = (0..4).map(|x| (-(x * x) as f64 / 8.0).exp()).collect();
        let total = g[0] + 2.0 * (g[1] + g[2] + g[3]);
        for x in 0..4 {
            assert!(
                (f64::from(KERNEL[x]) - 256.0 * g[x] / total).abs() < 0.7,
                "tap {x}"
            );
        }
    }

    #[test]
    fn constant_stays_constant_and_an_impulse_spreads_as_the_kernel() {
        let mut b = GaussianBlur::default();
        let mut out = GrayImage::new(0, 0);
        let flat = GrayImage::from_vec(9, 8, vec![77; 72]).unwrap();
        b.apply(flat.view(), &mut out);
        assert!(out.as_slice().iter().all(|&v| v == 77));
        let mut imp = GrayImage::new(15, 15);
        imp.set(7, 7, 255);
        b.apply(imp.view(), &mut out);
        // 255 * 56/256 = 55.8 -> 56 after the horizontal pass, then 56 * 56/256 = 12.25.
        assert_eq!(out.get(7, 7), Some(12));
        assert_eq!(out.get(7 + 4, 7), Some(0));
        let total: u32 = out.as_slice().iter().map(|&v| u32::from(v)).sum();
        assert!((total as i32 - 255).abs() <= 20, "{total}");
    }
}
