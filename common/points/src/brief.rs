//! Steered BRIEF (ORB, Rublee et al. 2011, Sec. 4): 256 intensity comparisons between
//! point pairs of a learned pattern, rotated by the keypoint orientation, read on the
//! Gaussian-smoothed level image.

use crate::keypoint::Descriptor;
use crate::pattern::BIT_PATTERN_31;
use crate::simd::avx2_dispatch;
use gfs_core::ImageView;

/// Pixels from the keypoint that a steered test may read: the pattern spans -13..=12,
/// so a rotated point stays within `round(13 * sqrt(2)) = 18`.
pub(crate) const REACH: usize = 18;

/// Largest row stride (pixels) the steered offsets handle in `i32` (`REACH` rows of it).
pub(crate) const MAX_STRIDE: usize = 1 << 26;

/// The pattern as two coordinate arrays (structure of arrays, so that steering all 512
/// points is one vectorised loop), and the per-keypoint offset scratch.
#[derive(Debug)]
pub(crate) struct SteeredBrief {
    px: [f32; 512],
    py: [f32; 512],
    offsets: [i32; 512],
}

impl Default for SteeredBrief {
    fn default() -> Self {
        let mut px = [0.0; 512];
        let mut py = [0.0; 512];
        for (i, t) in BIT_PATTERN_31.iter().enumerate() {
            px[2 * i] = f32::from(t[0]);
            py[2 * i] = f32::from(t[1]);
            px[2 * i + 1] = f32::from(t[2]);
            py[2 * i + 1] = f32::from(t[3]);
        }
        Self {
            px,
            py,
            offsets: [0; 512],
        }
    }
}

/// `1.5 * 2^23`: adding it to an `f32` of magnitude below `2^22` leaves the integer
/// nearest to it (ties to even, as OpenCV's `cvRound`) in the low mantissa bits.
const ROUND_MAGIC: f32 = 12_582_912.0;

/// Round to nearest, ties to even, for |v| < 2^22; vectorises (an add and an integer
/// subtract), unlike `f32::round` or a saturating `as` cast.
#[inline]
fn round_small(v: f32) -> i32 {
    (v + ROUND_MAGIC).to_bits() as i32 - ROUND_MAGIC.to_bits() as i32
}

impl SteeredBrief {
    /// Descriptor of the keypoint at integer `(x, y)` with orientation `angle` (radians),
    /// read on `smoothed`; `(x, y)` must be at least `REACH` pixels from the border
    /// (caller invariant).
    pub(crate) fn describe(
        &mut self,
        smoothed: ImageView<'_, u8>,
        x: usize,
        y: usize,
        angle: f32,
    ) -> Descriptor {
        debug_assert!(
            x >= REACH
                && y >= REACH
                && x + REACH < smoothed.width()
                && y + REACH < smoothed.height()
        );
        let (s, c) = angle.sin_cos();
        // The extractor only passes images with strides below `MAX_STRIDE`.
        let stride = smoothed.stride() as i32;
        steer(&self.px, &self.py, s, c, stride, &mut self.offsets);
        let data = smoothed.as_slice();
        let centre = (y * smoothed.stride() + x) as isize;
        let at = |k: usize| data[(centre + self.offsets[k] as isize) as usize];
        let mut desc = [0u64; 4];
        for (w, word) in desc.iter_mut().enumerate() {
            let mut bits = 0u64;
            for b in 0..64 {
                let t = w * 64 + b;
                bits |= u64::from(at(2 * t) < at(2 * t + 1)) << b;
            }
            *word = bits;
        }
        desc
    }
}

avx2_dispatch! {
    /// Flat offsets of the pattern points rotated by the angle of sine `s`, cosine `c`:
    /// column `x c - y s`, row `x s + y c`, each rounded to the nearest pixel.
    /// `i32` offsets: 8 per AVX2 multiply, where `isize` would need emulated 64-bit ones.
    fn steer(px: &[f32; 512], py: &[f32; 512], s: f32, c: f32, stride: i32, out: &mut [i32; 512]) {
        for i in 0..512 {
            let dx = round_small(px[i] * c - py[i] * s);
            let dy = round_small(px[i] * s + py[i] * c);
            out[i] = dy * stride + dx;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gfs_core::GrayImage;

    #[test]
    fn rounding_and_reach() {
        assert_eq!(
            [-2.5, -2.4, 2.5, 3.5, 0.49, -0.51, 18.4].map(round_small),
            [-2, -2, 2, 4, 0, -1, 18]
        );
        let max = BIT_PATTERN_31
            .iter()
            .flat_map(|t| [(t[0], t[1]), (t[2], t[3])])
            .map(|(x, y)| f32::from(x).hypot(f32::from(y)))
            .fold(0.0f32, f32::max);
        assert!(max.round() as usize <= REACH, "{max}");
    }

    #[test]
    fn rotating_the_image_by_90_degrees_with_the_angle_keeps_the_descriptor() {
        // A 90-degree rotation maps pixels exactly, and the steered pattern with angle
        // +90 degrees reads the rotated image at the rotated points: same bits, except
        // for ties at rounding (none here: integer rotation).
        let n = 41;
        let mut s = 12345u64;
        let data: Vec<u8> = (0..n * n)
            .map(|_| {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1);
                (s >> 56) as u8
            })
            .collect();
        let img = GrayImage::from_vec(n, n, data).unwrap();
        // Rotated image: R(x, y) = I(y, n - 1 - x), i.e. content turned by +90 degrees in
        // image coordinates (x right, y down).
        let rot_data: Vec<u8> = (0..n * n)
            .map(|i| img.get(i / n, n - 1 - i % n).unwrap())
            .collect();
        let rot = GrayImage::from_vec(n, n, rot_data).unwrap();
        let mut b = SteeredBrief::default();
        let d0 = b.describe(img.view(), 20, 20, 0.0);
        let d1 = b.describe(rot.view(), 20, 20, std::f32::consts::FRAC_PI_2);
        assert_eq!(d0, d1);
        assert_ne!(d0, b.describe(rot.view(), 20, 20, 0.0));
    }
}
