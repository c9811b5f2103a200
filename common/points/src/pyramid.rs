//! The scale pyramid: level `k` is level `k - 1` resized by `1 / scale_factor` with
//! bilinear interpolation (ORB-SLAM2 `ComputePyramid`, OpenCV `INTER_LINEAR` pixel-centre
//! mapping). Level 0 is the caller's image, read in place; levels 1.. are owned and reused.

use crate::simd::avx2_dispatch;
use gfs_core::{GrayImage, ImageView};

/// Fixed-point bits of the interpolation weights (weights sum to `1 << WEIGHT_BITS`).
const WEIGHT_BITS: u32 = 8;
const ONE: u32 = 1 << WEIGHT_BITS;

/// Levels 1.. of the pyramid and the scratch of the resize.
#[derive(Debug, Default)]
pub(crate) struct Pyramid {
    /// `levels[k - 1]` is level `k`; only the first `built` are valid for this frame.
    levels: Vec<GrayImage>,
    built: usize,
    resizer: Resizer,
}

/// Scratch of the bilinear resize.
#[derive(Debug, Default)]
struct Resizer {
    /// Per destination column: left source column and weight of the right one.
    x_index: Vec<u32>,
    x_weight: Vec<u16>,
    /// Two source rows blended vertically (`u16`, weights applied).
    blend: Vec<u16>,
}

/// Size of level `level` for a level-0 image of `width x height` (ORB-SLAM2 rounding).
pub(crate) fn level_size(width: usize, height: usize, scale: f32) -> (usize, usize) {
    let inv = 1.0 / scale;
    (
        (width as f32 * inv).round() as usize,
        (height as f32 * inv).round() as usize,
    )
}

impl Pyramid {
    /// Builds levels 1..`scales.len()` from `level0`, stopping before the first level
    /// smaller than `min_side` in either direction. Returns how many levels (including
    /// level 0) are usable.
    pub(crate) fn build(
        &mut self,
        level0: ImageView<'_, u8>,
        scales: &[f32],
        min_side: usize,
    ) -> usize {
        self.built = 0;
        if level0.width() < min_side || level0.height() < min_side {
            return 0;
        }
        let mut usable = 1;
        for (k, &scale) in scales.iter().enumerate().skip(1) {
            let (w, h) = level_size(level0.width(), level0.height(), scale);
            if w < min_side || h < min_side {
                break;
            }
            if self.levels.len() < k {
                self.levels.push(GrayImage::new(w, h));
            }
            let mut dst = std::mem::replace(&mut self.levels[k - 1], GrayImage::new(0, 0));
            dst.resize(w, h);
            let src = if k == 1 {
                level0
            } else {
                self.levels[k - 2].view()
            };
            self.resizer.resize_bilinear(src, &mut dst);
            self.levels[k - 1] = dst;
            self.built = k;
            usable = k + 1;
        }
        usable
    }

    /// Level `k >= 1` (a bug to ask for one that was not built).
    pub(crate) fn level(&self, k: usize) -> ImageView<'_, u8> {
        assert!(k >= 1 && k <= self.built, "pyramid level {k} not built");
        self.levels[k - 1].view()
    }
}

impl Resizer {
    /// Bilinear resize with OpenCV's pixel-centre mapping `src = (dst + 0.5) * r - 0.5`,
    /// separable: for each destination row, two source rows blend vertically (contiguous,
    /// vectorised), then the blend is resampled horizontally.
    fn resize_bilinear(&mut self, src: ImageView<'_, u8>, dst: &mut GrayImage) {
        let (sw, sh) = (src.width(), src.height());
        let (dw, dh) = (dst.width(), dst.height());
        debug_assert!(sw >= 2 && sh >= 2 && dw >= 1 && dh >= 1);
        self.x_index.clear();
        self.x_weight.clear();
        let rx = sw as f32 / dw as f32;
        for x in 0..dw {
            let (i, w) = tap(x, rx, sw);
            self.x_index.push(i);
            self.x_weight.push(w);
        }
        self.blend.resize(sw, 0);
        let ry = sh as f32 / dh as f32;
        for y in 0..dh {
            let (y0, wy) = tap(y, ry, sh);
            let y0 = y0 as usize;
            blend_rows(src.row(y0), src.row(y0 + 1), wy, &mut self.blend);
            resample(&self.blend, &self.x_index, &self.x_weight, dst.row_mut(y));
        }
    }
}

avx2_dispatch! {
    /// `out = a * (1 - w) + b * w` in fixed point (`w` in 1/256), kept as `u16`.
    fn blend_rows(a: &[u8], b: &[u8], w: u16, out: &mut [u16]) {
        let n = out.len();
        let (a, b) = (&a[..n], &b[..n]);
        let wa = ONE as u16 - w;
        for i in 0..n {
            out[i] = u16::from(a[i]) * wa + u16::from(b[i]) * w;
        }
    }
}

/// Left source index and right weight (fixed point) for destination index `d`, ratio `r`,
/// clamped so that both taps `i` and `i + 1` lie inside `0..n` (needs `n >= 2`).
fn tap(d: usize, r: f32, n: usize) -> (u32, u16) {
    let f = ((d as f32 + 0.5) * r - 0.5).max(0.0);
    let mut i = f.floor() as usize;
    let mut a = f - i as f32;
    if i >= n - 1 {
        i = n - 2;
        a = 1.0;
    }
    (i as u32, (a * ONE as f32).round() as u16)
}

/// [`resample_row`], with AVX2 gathers when the CPU has them: one 32-bit gather at the
/// left tap reads both taps of 8 columns at once. Same integer arithmetic, same result.
fn resample(blend: &[u16], index: &[u32], weight: &[u16], out: &mut [u8]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        let n = out.len().min(index.len()).min(weight.len());
        let blocks = n / 8 * 8;
        // Every left tap must have its right neighbour inside the row for the 4-byte
        // reads; `tap` guarantees it, this check keeps the unsafe reads sound regardless.
        if index[..blocks]
            .iter()
            .all(|&i| (i as usize) + 1 < blend.len())
        {
            // SAFETY: AVX2 is available (checked above) and every gathered 4-byte read at
            // `blend[i]..=blend[i + 1]` is in bounds (checked just above).
            unsafe {
                resample_avx2(
                    blend,
                    &index[..blocks],
                    &weight[..blocks],
                    &mut out[..blocks],
                )
            };
            resample_row(
                blend,
                &index[blocks..],
                &weight[blocks..],
                &mut out[blocks..],
            );
            return;
        }
    }
    resample_row(blend, index, weight, out);
}

/// AVX2 body of [`resample`]: lengths are multiples of 8 and every `index[k] + 1` is
/// below `blend.len()` (caller contract).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn resample_avx2(blend: &[u16], index: &[u32], weight: &[u16], out: &mut [u8]) {
    use std::arch::x86_64::*;
    let half = _mm256_set1_epi32(1 << (2 * WEIGHT_BITS - 1));
    let one = _mm256_set1_epi32(ONE as i32);
    let low16 = _mm256_set1_epi32(0xFFFF);
    let base = blend.as_ptr().cast::<i32>();
    for ((idx, w), o) in index
        .chunks_exact(8)
        .zip(weight.chunks_exact(8))
        .zip(out.chunks_exact_mut(8))
    {
        // SAFETY: `idx` holds 8 u32 (16-bit weights widened below); the gather reads
        // 4 bytes at `blend + 2 * idx[k]`, in bounds by the caller contract.
        unsafe {
            let i = _mm256_loadu_si256(idx.as_ptr().cast());
            let pairs = _mm256_i32gather_epi32::<2>(base, i);
            let l = _mm256_and_si256(pairs, low16);
            let r = _mm256_srli_epi32::<16>(pairs);
            let wr = _mm256_cvtepu16_epi32(_mm_loadu_si128(w.as_ptr().cast()));
            let wl = _mm256_sub_epi32(one, wr);
            let v = _mm256_add_epi32(
                _mm256_add_epi32(_mm256_mullo_epi32(l, wl), _mm256_mullo_epi32(r, wr)),
                half,
            );
            let v = _mm256_srli_epi32::<{ 2 * WEIGHT_BITS as i32 }>(v);
            // 8 values below 256 in 32-bit lanes -> 8 bytes.
            let packed16 = _mm256_packus_epi32(v, v);
            let packed8 = _mm256_packus_epi16(packed16, packed16);
            let lo = _mm256_castsi256_si128(packed8);
            let hi = _mm256_extracti128_si256::<1>(packed8);
            let bytes = _mm_unpacklo_epi32(lo, hi);
            _mm_storel_epi64(o.as_mut_ptr().cast(), bytes);
        }
    }
}

/// Horizontal taps of a blended row, rounded back to 8 bits.
fn resample_row(blend: &[u16], index: &[u32], weight: &[u16], out: &mut [u8]) {
    let half = 1u32 << (2 * WEIGHT_BITS - 1);
    for ((o, &i), &w) in out.iter_mut().zip(index).zip(weight) {
        let i = i as usize;
        let pair: &[u16; 2] = blend[i..i + 2].try_into().expect("two taps");
        let (l, r) = (u32::from(pair[0]), u32::from(pair[1]));
        let w = u32::from(w);
        *o = ((l * (ONE - w) + r * w + half) >> (2 * WEIGHT_BITS)) as u8;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_linear_ramp_stays_a_ramp_at_every_level() {
        // I(x, y) = 2x + y is reproduced exactly by bilinear interpolation, so level k
        // must read I at the level-0 position of its pixel centres (within rounding).
        let (w, h) = (120, 90);
        let data: Vec<u8> = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x + y) as u8))
            .collect();
        let img = GrayImage::from_vec(w, h, data).unwrap();
        let scales: Vec<f32> = (0..4).map(|k| 1.2f32.powi(k)).collect();
        let mut p = Pyramid::default();
        assert_eq!(p.build(img.view(), &scales, 20), 4);
        for k in 1..4 {
            let l = p.level(k);
            let (sx, sy) = (w as f32 / l.width() as f32, h as f32 / l.height() as f32);
            for y in 2..l.height() - 2 {
                for x in 2..l.width() - 2 {
                    let u = (x as f32 + 0.5) * sx - 0.5;
                    let v = (y as f32 + 0.5) * sy - 0.5;
                    let got = f32::from(l.at(x, y));
                    assert!(
                        (got - (u + v)).abs() <= 1.5,
                        "level {k} ({x},{y}): {got} vs {}",
                        u + v
                    );
                }
            }
        }
    }

    #[test]
    fn the_vectorised_resample_equals_the_scalar_one() {
        let sw = 203;
        let mut s = 5u64;
        let blend: Vec<u16> = (0..sw)
            .map(|_| {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1);
                ((s >> 48) as u16) % 65281
            })
            .collect();
        for dw in [169, 8, 15, 100] {
            let r = sw as f32 / dw as f32;
            let (index, weight): (Vec<u32>, Vec<u16>) = (0..dw).map(|x| tap(x, r, sw)).unzip();
            let mut fast = vec![0u8; dw];
            let mut slow = vec![0u8; dw];
            resample(&blend, &index, &weight, &mut fast);
            resample_row(&blend, &index, &weight, &mut slow);
            assert_eq!(fast, slow, "{dw}");
        }
    }

    #[test]
    fn too_small_images_build_no_level() {
        let img = GrayImage::new(30, 30);
        let mut p = Pyramid::default();
        assert_eq!(p.build(img.view(), &[1.0, 1.2], 39), 0);
        let img = GrayImage::new(50, 50);
        assert_eq!(p.build(img.view(), &[1.0, 1.2, 1.44], 39), 2);
    }
}
