//! Gaussian smoothing, EDLines step 1: a separable 5x5 binomial kernel 1-4-6-4-1 / 16,
//! whose variance is exactly 1 (sigma = 1 px, the EDLines setting). Integer arithmetic:
//! the horizontal pass keeps the 16x sum in `u16`, the vertical pass rounds back to `u8`.
//! Borders replicate the edge pixels.

use gfs_core::{Image, ImageView};

/// Smooths `src` into `dst` (resized to the source size), using `tmp` as scratch.
pub(crate) fn gaussian_5x5(src: &ImageView<'_, u8>, tmp: &mut Image<u16>, dst: &mut Image<u8>) {
    let (w, h) = (src.width(), src.height());
    tmp.resize(w, h);
    dst.resize(w, h);
    if w == 0 || h == 0 {
        return;
    }
    for y in 0..h {
        horizontal(src.row(y), tmp.row_mut(y));
    }
    let last = h - 1;
    for y in 0..h {
        let n = w;
        let (r0, r1, r2) = (
            &tmp.row(y.saturating_sub(2))[..n],
            &tmp.row(y.saturating_sub(1))[..n],
            &tmp.row(y)[..n],
        );
        let (r3, r4) = (
            &tmp.row((y + 1).min(last))[..n],
            &tmp.row((y + 2).min(last))[..n],
        );
        let out = &mut dst.row_mut(y)[..n];
        for x in 0..n {
            // Max 16 * 4080 + 128 = 65408: fits u16.
            let s = r0[x] + r4[x] + 4 * (r1[x] + r3[x]) + 6 * r2[x] + 128;
            out[x] = (s >> 8) as u8;
        }
    }
}

/// One row of the horizontal pass: `t[x] = sum_k w_k s[clamp(x + k)]`, weights 1 4 6 4 1.
fn horizontal(s: &[u8], t: &mut [u16]) {
    let w = s.len();
    let at = |x: isize| u16::from(s[x.clamp(0, w as isize - 1) as usize]);
    let clamped = |x: usize| {
        let x = x as isize;
        at(x - 2) + at(x + 2) + 4 * (at(x - 1) + at(x + 1)) + 6 * at(x)
    };
    if w < 5 {
        for (x, o) in t.iter_mut().enumerate() {
            *o = clamped(x);
        }
        return;
    }
    // Five shifted views of the row, cut to the same length so that the loop vectorises.
    let n = w - 4;
    let (s0, s1, s2, s3, s4) = (
        &s[..n],
        &s[1..n + 1],
        &s[2..n + 2],
        &s[3..n + 3],
        &s[4..n + 4],
    );
    let out = &mut t[2..n + 2];
    for i in 0..n {
        out[i] = u16::from(s0[i])
            + u16::from(s4[i])
            + 4 * (u16::from(s1[i]) + u16::from(s3[i]))
            + 6 * u16::from(s2[i]);
    }
    for x in [0, 1, w - 2, w - 1] {
        t[x] = clamped(x);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_images_stay_constant_and_tiny_ones_do_not_panic() {
        let (mut tmp, mut dst) = (Image::new(0, 0), Image::new(0, 0));
        for (w, h) in [(0, 0), (1, 1), (3, 2), (4, 7), (17, 9)] {
            let img = Image::from_vec(w, h, vec![200u8; w * h]).unwrap();
            gaussian_5x5(&img.view(), &mut tmp, &mut dst);
            assert_eq!((dst.width(), dst.height()), (w, h));
            assert!(dst.as_slice().iter().all(|&v| v == 200));
        }
    }

    #[test]
    fn a_single_bright_pixel_spreads_as_the_binomial_kernel() {
        let mut img = Image::new(9, 9);
        img.set(4, 4, 255u8);
        let (mut tmp, mut dst) = (Image::new(0, 0), Image::new(0, 0));
        gaussian_5x5(&img.view(), &mut tmp, &mut dst);
        // 255 * 36 / 256 = 35.86 -> 36 at the centre, 255 * 6 / 256 = 5.98 -> 6 beside it.
        assert_eq!(dst.get(4, 4), Some(36));
        assert_eq!(dst.get(5, 4), Some(24));
        assert_eq!(dst.get(6, 4), Some(6));
        assert_eq!(dst.get(7, 4), Some(0));
    }
}
