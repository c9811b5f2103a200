//! Anchors, EDLines step 3: pixels whose gradient magnitude is a clear local maximum
//! across the edge (ED "anchor test"), the seeds of edge routing. They are returned
//! strongest first, so that chains grow from the most reliable edge pixels.

use gfs_core::Image;

use super::gradient::{HORIZONTAL, ORIENTATION, VERTICAL};

/// Finds the anchors of `magnitude` / `state` into `out`, as `magnitude << 32 | index`
/// sorted by decreasing magnitude (ties: decreasing pixel index, deterministic);
/// `flags` is row scratch.
///
/// A horizontal-edge pixel must exceed its upper and lower neighbours by
/// `anchor_threshold`, a vertical-edge pixel its left and right ones (ED's anchor test).
/// A step edge centred between two pixels gives a plateau of two equal maxima: then the
/// first pixel of the plateau is the anchor. Horizontal-edge pixels are tested on every
/// `scan_interval`-th column and vertical-edge pixels on every `scan_interval`-th row,
/// i.e. along the edge, so that no edge direction is skipped.
pub(crate) fn find_anchors(
    magnitude: &Image<u16>,
    state: &Image<u8>,
    anchor_threshold: u16,
    scan_interval: usize,
    flags: &mut Vec<u8>,
    out: &mut Vec<u64>,
) {
    out.clear();
    let (w, h) = (magnitude.width(), magnitude.height());
    if w < 3 || h < 3 {
        return;
    }
    let scan = scan_interval.max(1);
    let mag = magnitude.as_slice();
    let st = state.as_slice();
    let t = anchor_threshold;
    let n = w - 2;
    // Column scan mask, then per-row flags: the flag pass is branch-free so that it
    // vectorises; only the (sparse) anchors take a branch.
    flags.clear();
    flags.extend((1..w - 1).map(|x| u8::from(x % scan == 0)));
    flags.resize(2 * n, 0);
    let (columns, row_flags) = flags.split_at_mut(n);
    for y in 1..h - 1 {
        let row = y * w;
        let row_scanned = y % scan == 0;
        let below2 = (y + 2).min(h - 1) * w;
        // Pixel x = i + 1 of this row for every slice index i.
        let up = &mag[row - w + 1..row - w + 1 + n];
        let mid = &mag[row + 1..row + 1 + n];
        let down = &mag[row + w + 1..row + w + 1 + n];
        let down2 = &mag[below2 + 1..below2 + 1 + n];
        let left = &mag[row..row + n];
        let right = &mag[row + 2..row + 2 + n];
        // x + 2 runs into the next row's first pixel at x = w - 2; harmless, since the
        // tie branch needs `right == m >= 1` and `right` is a zero border pixel there.
        let right2 = &mag[row + 3..row + 3 + n];
        let states = &st[row + 1..row + 1 + n];
        let columns = &columns[..n];
        let row_flags = &mut row_flags[..n];
        for i in 0..n {
            let m = mid[i];
            let s = states[i] & ORIENTATION;
            let horizontal = (s == HORIZONTAL)
                & (columns[i] != 0)
                & (m >= up[i].saturating_add(t))
                & ((m >= down[i].saturating_add(t))
                    | ((m == down[i]) & (m >= down2[i].saturating_add(t))));
            let vertical = (s == VERTICAL)
                & row_scanned
                & (m >= left[i].saturating_add(t))
                & ((m >= right[i].saturating_add(t))
                    | ((m == right[i]) & (m >= right2[i].saturating_add(t))));
            row_flags[i] = u8::from(horizontal | vertical);
        }
        // Anchors are sparse: skip eight flags at a time.
        let chunks = row_flags.chunks_exact(8);
        let tail_start = n - chunks.remainder().len();
        let mut push = |i: usize| out.push(u64::from(mid[i]) << 32 | (row + i + 1) as u64);
        for (k, chunk) in chunks.enumerate() {
            let mut word = [0u8; 8];
            word.copy_from_slice(chunk);
            let mut bits = u64::from_le_bytes(word);
            while bits != 0 {
                let byte = bits.trailing_zeros() / 8;
                bits &= !(0xff << (8 * byte));
                push(8 * k + byte as usize);
            }
        }
        for (i, &f) in row_flags.iter().enumerate().skip(tail_start) {
            if f != 0 {
                push(i);
            }
        }
    }
    out.sort_unstable_by(|a, b| b.cmp(a));
}
