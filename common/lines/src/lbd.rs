//! The binary Line Band Descriptor (LBD, Zhang & Koch 2013), section III-A of the paper.
//!
//! The line support region (LSR) is `BANDS` bands of `band_width` pixel rows parallel to
//! the segment, centred on it. Each pixel's gradient is expressed in the line frame
//! (`d_perp`, the normal; `d_line`, the direction) and every row of the LSR sums, along
//! the segment, the positive and negative parts of both components, weighted by the
//! global Gaussian across the LSR (`sigma_g = (BANDS * band_width - 1) / 2`). A band's
//! description matrix holds the rows of the band and of its two neighbours, weighted by
//! the local Gaussian (`sigma_l = band_width`) around the band centre; the band
//! descriptor is the mean and the standard deviation of those rows, 8 numbers.
//!
//! The 256 bits compare the 8 numbers of two bands, entry by entry, for 32 band pairs
//! (the pair layout of the binary LBD of OpenCV's `line_descriptor`, used here as data):
//! `bit = band_a[k] > band_b[k]`. The float LBD's unit normalisation does not change such
//! comparisons, so it is skipped.
//!
//! The frame is oriented by the gradient (the normal points along the mean gradient
//! across the line), so the descriptor does not depend on the order of the endpoints.
//!
//! Single scale: it reads the gradients of the detector's smoothed image at full
//! resolution (nearest pixel), as the tracker matches frames of similar scale.

use crate::Segment;
use gfs_core::ImageView;
use serde::{Deserialize, Serialize};

/// A 256-bit LBD descriptor; bit `8 p + k` is comparison `k` of band pair `p`.
pub type LbdDescriptor = gfs_core::descriptor::Descriptor;

/// Number of bands of the LSR (the binary pair layout is defined for 9).
pub const BANDS: usize = 9;

/// Band pairs compared by the binary descriptor: all pairs of the 9 bands except the
/// four farthest apart ((0, 7), (0, 8), (1, 7), (1, 8)).
const PAIRS: [(usize, usize); 32] = [
    (0, 1),
    (0, 2),
    (0, 3),
    (0, 4),
    (0, 5),
    (0, 6),
    (1, 2),
    (1, 3),
    (1, 4),
    (1, 5),
    (1, 6),
    (2, 3),
    (2, 4),
    (2, 5),
    (2, 6),
    (2, 7),
    (2, 8),
    (3, 4),
    (3, 5),
    (3, 6),
    (3, 7),
    (3, 8),
    (4, 5),
    (4, 6),
    (4, 7),
    (4, 8),
    (5, 6),
    (5, 7),
    (5, 8),
    (6, 7),
    (6, 8),
    (7, 8),
];

/// Parameters of the descriptor.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct LbdConfig {
    /// Rows (pixels) per band. Default 7, the LBD paper's and OpenCV's choice.
    pub band_width: usize,
    /// Step along the segment between samples, pixels. Default 1.0 (every pixel, as
    /// OpenCV).
    pub step: f32,
    /// Most samples along one segment; longer segments are sampled evenly with a
    /// larger step. Default 32: the band statistics are means along the line, so a
    /// long line needs no more samples, and the cost per line stays bounded (the warp
    /// matching tests give the same scores with 32 as with 64 or every pixel).
    pub max_samples: usize,
}

impl Default for LbdConfig {
    fn default() -> Self {
        Self {
            band_width: 7,
            step: 1.0,
            max_samples: 32,
        }
    }
}

/// Computes LBD descriptors; owns the per-row scratch and the weight tables.
#[derive(Clone, Debug)]
pub struct LbdExtractor {
    config: LbdConfig,
    /// Global Gaussian weight of each LSR row.
    global: Vec<f32>,
    /// Row offsets across the line, pixels (row 0 is the most negative side).
    offsets: Vec<f32>,
    /// Per-row sums [perp+, perp-, line+, line-] of the current segment.
    rows: Vec<[f32; 4]>,
    /// Local Gaussian weight of a row at distance `d` rows from a band centre, `d` in
    /// `0..2 * band_width` (index `d` for offset `d - band_width + ...`, see `local_at`).
    local: Vec<f32>,
}

impl LbdExtractor {
    /// An extractor with `config` (a band width of 0 counts as 1, a step below 0.25 px
    /// as 0.25).
    pub fn new(config: LbdConfig) -> Self {
        let w = config.band_width.max(1);
        let m = BANDS * w;
        let sigma_g = 0.5 * (m as f32 - 1.0).max(1.0);
        let centre = 0.5 * (m as f32 - 1.0);
        let offsets: Vec<f32> = (0..m).map(|k| k as f32 - centre).collect();
        let global = offsets
            .iter()
            .map(|o| (-o * o / (2.0 * sigma_g * sigma_g)).exp())
            .collect();
        // Distance of a row to a band centre ranges over (-1.5 w, 1.5 w); tabulate by
        // twice the distance so half-row offsets (even w) stay integral.
        let sigma_l = w as f32;
        let local = (0..=3 * w)
            .map(|twice| {
                let d = 0.5 * twice as f32;
                (-d * d / (2.0 * sigma_l * sigma_l)).exp()
            })
            .collect();
        Self {
            config: LbdConfig {
                band_width: w,
                step: config.step.max(0.25),
                max_samples: config.max_samples.max(2),
            },
            global,
            offsets,
            rows: vec![[0.0; 4]; m],
            local,
        }
    }

    /// The configuration in use.
    pub fn config(&self) -> &LbdConfig {
        &self.config
    }

    /// Appends to `out` the descriptor of every segment, in order. `gx`, `gy` are the
    /// signed image derivatives along u and v (any common scale), of equal size.
    pub fn describe<'a, I>(
        &mut self,
        gx: &ImageView<'_, i16>,
        gy: &ImageView<'_, i16>,
        segments: I,
        out: &mut Vec<LbdDescriptor>,
    ) where
        I: IntoIterator<Item = &'a Segment>,
    {
        for s in segments {
            let d = self.describe_one(gx, gy, s);
            out.push(d);
        }
    }

    /// The descriptor of one segment; all zeros for a degenerate segment or mismatched
    /// gradient images.
    pub fn describe_one(
        &mut self,
        gx: &ImageView<'_, i16>,
        gy: &ImageView<'_, i16>,
        segment: &Segment,
    ) -> LbdDescriptor {
        let len = segment.length();
        if !(len.is_finite() && len >= 1.0)
            || gx.width() != gy.width()
            || gx.height() != gy.height()
            || gx.is_empty()
        {
            return [0; 4];
        }
        self.accumulate_rows(gx, gy, segment, len);
        let bands = self.band_descriptors();
        let mut bits = [0u64; 4];
        for (p, &(a, b)) in PAIRS.iter().enumerate() {
            for (k, (x, y)) in bands[a].iter().zip(&bands[b]).enumerate() {
                if x > y {
                    let bit = 8 * p + k;
                    bits[bit / 64] |= 1 << (bit % 64);
                }
            }
        }
        bits
    }

    /// Fills `rows` with the globally weighted per-row sums, in the gradient-oriented
    /// frame.
    fn accumulate_rows(
        &mut self,
        gx: &ImageView<'_, i16>,
        gy: &ImageView<'_, i16>,
        segment: &Segment,
        len: f32,
    ) {
        let (du, dv) = (
            (segment.end[0] - segment.start[0]) / len,
            (segment.end[1] - segment.start[1]) / len,
        );
        // Provisional normal (rotated +90 degrees from the direction).
        let (nu, nv) = (-dv, du);
        let (w, h) = (gx.width() as f32, gx.height() as f32);
        let (sx, sy) = (gx.stride(), gy.stride());
        let (dx_data, dy_data) = (gx.as_slice(), gy.as_slice());
        for r in &mut self.rows {
            *r = [0.0; 4];
        }
        let samples = ((len / self.config.step).floor() as usize + 1).min(self.config.max_samples);
        let spacing = len / (samples - 1).max(1) as f32;
        let accumulate = |row: &mut [f32; 4], xf: f32, yf: f32| {
            if !(xf >= 0.0 && yf >= 0.0 && xf < w && yf < h) {
                return;
            }
            let (x, y) = (xf as usize, yf as usize);
            let gu = f32::from(dx_data[y * sx + x]);
            let gv = f32::from(dy_data[y * sy + x]);
            let perp = gu * nu + gv * nv;
            let along = gu * du + gv * dv;
            // Positive and negative parts (LBD's four accumulators), branch-free.
            row[0] += perp.max(0.0);
            row[1] += (-perp).max(0.0);
            row[2] += along.max(0.0);
            row[3] += (-along).max(0.0);
        };
        // +0.5 so that truncation rounds to the nearest pixel (coordinates >= 0).
        let (ou, ov) = (segment.start[0] + 0.5, segment.start[1] + 0.5);
        // Memory order: the inner loop moves along image rows where it can, so that
        // consecutive reads share cache lines (LBD is bound by these scattered reads).
        if du.abs() >= dv.abs() {
            for (row, &o) in self.rows.iter_mut().zip(&self.offsets) {
                let (bu, bv) = (ou + o * nu, ov + o * nv);
                for i in 0..samples {
                    let t = i as f32 * spacing;
                    accumulate(row, bu + t * du, bv + t * dv);
                }
            }
        } else {
            for i in 0..samples {
                let t = i as f32 * spacing;
                let (pu, pv) = (ou + t * du, ov + t * dv);
                for (row, &o) in self.rows.iter_mut().zip(&self.offsets) {
                    accumulate(row, pu + o * nu, pv + o * nv);
                }
            }
        }
        // Orient by the gradient: the normal must point along the mean gradient across
        // the line. Flipping the normal (and with it the direction) reverses the rows
        // and swaps the positive and negative parts of both components.
        let perp_sum: f32 = self
            .rows
            .iter()
            .zip(&self.global)
            .map(|(r, g)| g * (r[0] - r[1]))
            .sum();
        if perp_sum < 0.0 {
            self.rows.reverse();
            for r in &mut self.rows {
                *r = [r[1], r[0], r[3], r[2]];
            }
        }
        for (r, g) in self.rows.iter_mut().zip(&self.global) {
            for v in r.iter_mut() {
                *v *= g;
            }
        }
    }

    /// Mean and standard deviation of each band's locally weighted rows:
    /// `[mean perp+, mean perp-, mean line+, mean line-, std ...]` per band.
    fn band_descriptors(&self) -> [[f32; 8]; BANDS] {
        let w = self.config.band_width;
        let m = self.rows.len();
        let mut out = [[0.0f32; 8]; BANDS];
        for (j, band) in out.iter_mut().enumerate() {
            let first = (j * w).saturating_sub(w);
            let last = ((j + 2) * w).min(m);
            // Twice the band centre, in rows.
            let twice_centre = (2 * j * w + w - 1) as isize;
            let (mut sum, mut sq) = ([0.0f32; 4], [0.0f32; 4]);
            for k in first..last {
                let twice_d = (2 * k as isize - twice_centre).unsigned_abs();
                let lw = self.local[twice_d.min(self.local.len() - 1)];
                for c in 0..4 {
                    let v = lw * self.rows[k][c];
                    sum[c] += v;
                    sq[c] += v * v;
                }
            }
            let n = (last - first) as f32;
            for c in 0..4 {
                let mean = sum[c] / n;
                band[c] = mean;
                band[4 + c] = (sq[c] / n - mean * mean).max(0.0).sqrt();
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gfs_core::Image;
    use gfs_core::descriptor::hamming;

    /// Sobel of a synthetic image: vertical step at u = 30 plus a weaker horizontal
    /// step at v = 20.
    fn gradients(w: usize, h: usize) -> (Image<i16>, Image<i16>) {
        let f = |u: usize, v: usize| -> i16 {
            (if u >= 30 { 120 } else { 40 }) + if v >= 20 { 30 } else { 0 }
        };
        let (mut gx, mut gy) = (Image::new(w, h), Image::new(w, h));
        for v in 1..h - 1 {
            for u in 1..w - 1 {
                let s = |du: isize, dv: isize| {
                    f((u as isize + du) as usize, (v as isize + dv) as usize)
                };
                gx.set(
                    u,
                    v,
                    s(1, -1) + 2 * s(1, 0) + s(1, 1) - s(-1, -1) - 2 * s(-1, 0) - s(-1, 1),
                );
                gy.set(
                    u,
                    v,
                    s(-1, 1) + 2 * s(0, 1) + s(1, 1) - s(-1, -1) - 2 * s(0, -1) - s(1, -1),
                );
            }
        }
        (gx, gy)
    }

    #[test]
    fn descriptor_ignores_endpoint_order_and_sees_the_structure() {
        let (gx, gy) = gradients(80, 80);
        let mut lbd = LbdExtractor::new(LbdConfig::default());
        let down = Segment::new(29.5, 10.0, 29.5, 70.0);
        let up = Segment::new(29.5, 70.0, 29.5, 10.0);
        let a = lbd.describe_one(&gx.view(), &gy.view(), &down);
        let b = lbd.describe_one(&gx.view(), &gy.view(), &up);
        assert_eq!(hamming(&a, &b), 0);
        // Mirrored texture (step the other way) changes many bits.
        let shifted = Segment::new(49.5, 10.0, 49.5, 70.0);
        let c = lbd.describe_one(&gx.view(), &gy.view(), &shifted);
        assert!(hamming(&a, &c) > 40, "{}", hamming(&a, &c));
        // Degenerate inputs give zeros, never a panic.
        let point = Segment::new(5.0, 5.0, 5.0, 5.0);
        assert_eq!(lbd.describe_one(&gx.view(), &gy.view(), &point), [0; 4]);
        let empty: Image<i16> = Image::new(0, 0);
        assert_eq!(
            lbd.describe_one(&empty.view(), &empty.view(), &down),
            [0; 4]
        );
        let outside = Segment::new(-500.0, -500.0, -400.0, -450.0);
        let _ = lbd.describe_one(&gx.view(), &gy.view(), &outside);
    }
}
