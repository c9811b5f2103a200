//! FAST-9 corners (Rosten & Drummond 2006) with a score, as ORB-SLAM2 runs them
//! (OpenCV `FAST(..., nonmaxSuppression = true)`).
//!
//! A pixel `c` is a corner at threshold `t` when 9 contiguous pixels of the radius-3
//! Bresenham ring are all brighter than `c + t` or all darker than `c - t`. Its score is
//! `max over 9-arcs of min |d|` (d: ring minus centre on the arc's side), so "corner at
//! `t`" is exactly "score > `t`", and a score map computed at a low
//! threshold holds the same values as one computed at a higher one where both are set.
//! That is what lets the extractor retry a cell at the minimum threshold without
//! touching the rest of the map.
//!
//! Speed: rows are processed in blocks of 16 (SSE2) or 32 (AVX2, chosen at run time)
//! pixels with branch-free lane loops that auto-vectorise (`kernels.rs`): two pre-tests
//! reject most blocks, a 9-arc test on the full ring finds the corners, and only corners
//! get a score. The scalar test (`full_test`) handles rows narrower than a block and is
//! the reference the block paths are tested against.

mod detect;
mod kernels;

pub use detect::{Corner, RING_RADIUS, detect_fast};
pub(crate) use detect::{Rect, local_maxima, score_rect};
