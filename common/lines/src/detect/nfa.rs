//! Segment validation, EDLines step 6: the a-contrario (Helmholtz principle) test of
//! Desolneux, Moisan & Morel as used by LSD and EDLines. Along a segment of `n` pixels,
//! `k` have a gradient aligned with the segment normal within `p * pi`; under the noise
//! model each pixel is aligned independently with probability `p`, so
//! `NFA(n, k) = N^4 * sum_{i >= k} C(n, i) p^i (1 - p)^(n - i)` with `N^4 = (W H)^2`
//! candidate segments (EDLines eq. 1). A segment is kept when `NFA <= epsilon`.
//!
//! The alignment uses the 2x2 gradient of the *unsmoothed* image (as LSD): neighbouring
//! samples then share few pixels, which keeps the independence assumption honest.

use gfs_core::ImageView;

/// Smallest aligned count `k` per length `n` that passes the test, computed lazily.
#[derive(Debug, Default)]
pub(crate) struct NfaTable {
    key: (usize, usize, u64, u64),
    /// `ln(i!)`.
    ln_factorial: Vec<f64>,
    /// `min_aligned[n]`, `u32::MAX` when not computed yet; `n + 1` when impossible.
    min_aligned: Vec<u32>,
    ln_p: f64,
    ln_q: f64,
    /// ln(epsilon) - ln(N^4).
    ln_threshold: f64,
}

impl NfaTable {
    /// Prepares the table for a `width x height` image, aligned probability `p` and
    /// accepted false alarms `epsilon`; keeps the previous table when nothing changed.
    pub(crate) fn prepare(&mut self, width: usize, height: usize, p: f64, epsilon: f64) {
        let key = (width, height, p.to_bits(), epsilon.to_bits());
        if key == self.key && !self.min_aligned.is_empty() {
            return;
        }
        self.key = key;
        let max_n = width + height + 4;
        self.ln_factorial.clear();
        self.ln_factorial.push(0.0);
        for i in 1..=max_n {
            let prev = self.ln_factorial[i - 1];
            self.ln_factorial.push(prev + (i as f64).ln());
        }
        self.min_aligned.clear();
        self.min_aligned.resize(max_n + 1, u32::MAX);
        let p = p.clamp(1e-6, 0.5);
        self.ln_p = p.ln();
        self.ln_q = (1.0 - p).ln();
        let ln_tests = 2.0 * ((width.max(1) as f64).ln() + (height.max(1) as f64).ln());
        self.ln_threshold = epsilon.max(1e-300).ln() - ln_tests;
    }

    /// The smallest `k` with `NFA(n, k) <= epsilon` (`n + 1` when none).
    pub(crate) fn min_aligned(&mut self, n: usize) -> usize {
        let n = n.min(self.min_aligned.len().saturating_sub(1));
        if self.min_aligned[n] == u32::MAX {
            self.min_aligned[n] = self.compute(n) as u32;
        }
        self.min_aligned[n] as usize
    }

    /// The shortest segment (in samples) that can pass at all.
    pub(crate) fn min_length(&mut self) -> usize {
        let max_n = self.min_aligned.len().saturating_sub(1);
        (1..=max_n)
            .find(|&n| self.min_aligned(n) <= n)
            .unwrap_or(max_n + 1)
    }

    /// Sums the binomial tail from `i = n` down and stops when it exceeds the threshold.
    fn compute(&self, n: usize) -> usize {
        let lf = &self.ln_factorial;
        let mut ln_tail = f64::NEG_INFINITY;
        for k in (0..=n).rev() {
            let ln_term =
                lf[n] - lf[k] - lf[n - k] + k as f64 * self.ln_p + (n - k) as f64 * self.ln_q;
            let (hi, lo) = if ln_term > ln_tail {
                (ln_term, ln_tail)
            } else {
                (ln_tail, ln_term)
            };
            ln_tail = hi + (lo - hi).exp().ln_1p();
            if ln_tail > self.ln_threshold {
                return k + 1;
            }
        }
        0
    }
}

/// Result of validating one segment.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Evidence {
    /// The segment passed the NFA test.
    pub valid: bool,
    /// The image is brighter on the side of the normal `(dv, -du) / len` of the segment.
    pub bright_on_normal_side: bool,
}

/// Minimum 2x2 gradient norm of an aligned pixel: below it the orientation is mostly
/// quantisation noise (LSD's `q / sin(tau)` with `q = 2`).
const MIN_GRADIENT_NORM: f32 = 5.2;

/// Counts the aligned samples along `[u0, v0, u1, v1]` (one per pixel of length) and runs
/// the NFA test; `cos_tolerance` is the cosine of the angle tolerance.
pub(crate) fn validate(
    gray: &ImageView<'_, u8>,
    seg: [f32; 4],
    cos_tolerance: f32,
    table: &mut NfaTable,
) -> Evidence {
    let invalid = Evidence {
        valid: false,
        bright_on_normal_side: true,
    };
    let (w, h) = (gray.width(), gray.height());
    let (du, dv) = (seg[2] - seg[0], seg[3] - seg[1]);
    let len = du.hypot(dv);
    if w < 2 || h < 2 || !len.is_finite() || len < 1.0 {
        return invalid;
    }
    let (tu, tv) = (du / len, dv / len);
    let (nu, nv) = (tv, -tu);
    let cos2 = cos_tolerance * cos_tolerance;
    let n = len as usize + 1;
    let need = table.min_aligned(n);
    let (mut along, mut against) = (0usize, 0usize);
    for s in 0..n {
        // Stop as soon as the outcome is known: long real edges reach `need` after a
        // fraction of their samples, noise falls short early.
        if along >= need || against >= need {
            break;
        }
        if along.max(against) + (n - s) < need {
            return invalid;
        }
        let (u, v) = (seg[0] + s as f32 * tu, seg[1] + s as f32 * tv);
        // The 2x2 window (x..x+1, y..y+1) whose centre is nearest: x = floor(u).
        let x = (u.max(0.0) as usize).min(w - 2);
        let y = (v.max(0.0) as usize).min(h - 2);
        let (r0, r1) = (gray.row(y), gray.row(y + 1));
        let (a, b) = (f32::from(r0[x]), f32::from(r0[x + 1]));
        let (c, d) = (f32::from(r1[x]), f32::from(r1[x + 1]));
        let gx = 0.5 * (b + d - a - c);
        let gy = 0.5 * (c + d - a - b);
        let norm2 = gx * gx + gy * gy;
        if norm2 < MIN_GRADIENT_NORM * MIN_GRADIENT_NORM {
            continue;
        }
        // |cos(angle to the normal)| >= cos_tolerance, without a square root.
        let dot = gx * nu + gy * nv;
        if dot * dot >= cos2 * norm2 {
            if dot > 0.0 {
                along += 1;
            } else {
                against += 1;
            }
        }
    }
    Evidence {
        valid: along.max(against) >= need,
        bright_on_normal_side: along >= against,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn min_length_matches_the_closed_form() {
        // A fully aligned segment passes when N^4 p^n <= 1: n >= 4 ln N / ln 8.
        let mut t = NfaTable::default();
        t.prepare(640, 480, 0.125, 1.0);
        let closed = (2.0 * (640.0f64 * 480.0).ln() / 8.0f64.ln()).ceil() as usize;
        assert_eq!(t.min_length(), closed);
        assert_eq!(closed, 13);
        // Long segments need far fewer than all pixels aligned.
        let k = t.min_aligned(200);
        assert!(k > 25 && k < 80, "k = {k}");
    }
}
