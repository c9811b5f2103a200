//! Anchors, EDLines step 3: pixels whose gradient magnitude is a clear local maximum
//! across the edge (ED "anchor test"), the seeds of edge routing. They are returned
//! strongest first, so that chains grow from the most reliable edge pixels.

use gfs_core::Image;

use super::gradient::{HORIZONTAL, NONE, ORIENTATION};

/// Finds the anchors of `magnitude` / `state` into `out`, as `magnitude << 32 | index`
/// sorted by decreasing magnitude (ties: decreasing pixel index, deterministic).
///
/// A horizontal-edge pixel must exceed its upper and lower neighbours by
/// `anchor_threshold`, a vertical-edge pixel its left and right ones. Horizontal-edge
/// pixels are tested on every `scan_interval`-th column and vertical-edge pixels on every
/// `scan_interval`-th row, i.e. along the edge, so that no edge direction is skipped.
pub(crate) fn find_anchors(
    magnitude: &Image<u16>,
    state: &Image<u8>,
    anchor_threshold: u16,
    scan_interval: usize,
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
    for y in 1..h - 1 {
        let row = y * w;
        let row_scanned = y % scan == 0;
        for x in 1..w - 1 {
            let i = row + x;
            let s = st[i] & ORIENTATION;
            if s == NONE {
                continue;
            }
            let m = mag[i];
            // ED's test: a clear maximum across the edge. A step edge centred between two
            // pixels gives a plateau of two equal maxima; its first pixel is the anchor.
            let across = if s == HORIZONTAL { w } else { 1 };
            let scanned = if s == HORIZONTAL {
                x % scan == 0
            } else {
                row_scanned
            };
            let (before, after) = (mag[i - across], mag[i + across]);
            // `after == m >= 1` makes pixel i + across interior, so i + 2 across exists.
            let anchor = scanned
                && m >= before.saturating_add(anchor_threshold)
                && (m >= after.saturating_add(anchor_threshold)
                    || (m == after && m >= mag[i + 2 * across].saturating_add(anchor_threshold)));
            if anchor {
                out.push(u64::from(m) << 32 | i as u64);
            }
        }
    }
    out.sort_unstable_by(|a, b| b.cmp(a));
}
