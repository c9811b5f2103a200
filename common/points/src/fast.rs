//! FAST-9 corners (Rosten & Drummond 2006) with a score, as ORB-SLAM2 runs them
//! (OpenCV `FAST(..., nonmaxSuppression = true)`).
//!
//! A pixel `c` is a corner at threshold `t` when 9 contiguous pixels of the radius-3
//! Bresenham ring are all brighter than `c + t` or all darker than `c - t`. Its score is
//! the largest `t` at which it is still a corner minus nothing: `max over arcs of min |d|`,
//! so "corner at `t`" is exactly "score > `t`", and a score map computed at a low
//! threshold holds the same values as one computed at a higher one where both are set.
//! That is what lets the extractor retry a cell at the minimum threshold without
//! touching the rest of the map.
//!
//! Speed: rows are processed in blocks of 16 (SSE2) or 32 (AVX2, chosen at run time)
//! pixels with branch-free lane loops that auto-vectorise: a compass pre-test rejects
//! flat blocks, a run-length count over the ring finds the corners, and only corners get
//! a score. The scalar test (`full_test`) handles rows narrower than a block and is the
//! reference the block paths are tested against.

use gfs_core::ImageView;

/// Ring of 16 pixels of radius 3, clockwise from the top, as `(dx, dy)`.
const RING: [(isize, isize); 16] = [
    (0, -3),
    (1, -3),
    (2, -2),
    (3, -1),
    (3, 0),
    (3, 1),
    (2, 2),
    (1, 3),
    (0, 3),
    (-1, 3),
    (-2, 2),
    (-3, 1),
    (-3, 0),
    (-3, -1),
    (-2, -2),
    (-1, -3),
];

/// Distance from the image border inside which the ring does not fit.
pub const RING_RADIUS: usize = 3;

/// A FAST corner at integer pixel `(x, y)` with its score.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Corner {
    /// Column.
    pub x: u32,
    /// Row.
    pub y: u32,
    /// Largest threshold at which it is still a corner (1..=255).
    pub score: u8,
}

/// A rectangle `[x0, x1) x [y0, y1)` of pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Rect {
    pub x0: usize,
    pub x1: usize,
    pub y0: usize,
    pub y1: usize,
}

/// Writes into `scores` (row-major, `scores_stride` apart, same pixel grid as `image`)
/// the FAST score of every pixel of `rect` that is a corner at `threshold`, 0 elsewhere,
/// and appends the position of every corner to `hits`. `rect` must keep `RING_RADIUS`
/// pixels from the border of `image` (caller invariant).
///
/// Runs 32 lanes with AVX2 when the CPU has it (checked at run time: the workspace
/// builds for baseline x86-64), else 16 lanes (SSE2).
pub(crate) fn score_rect(
    image: ImageView<'_, u8>,
    threshold: u8,
    rect: Rect,
    scores: &mut [u8],
    scores_stride: usize,
    hits: &mut Vec<(u32, u32)>,
) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2, checked just above.
        unsafe { score_rect_avx2(image, threshold, rect, scores, scores_stride, hits) };
        return;
    }
    score_rect_lanes::<16>(image, threshold, rect, scores, scores_stride, hits);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn score_rect_avx2(
    image: ImageView<'_, u8>,
    threshold: u8,
    rect: Rect,
    scores: &mut [u8],
    scores_stride: usize,
    hits: &mut Vec<(u32, u32)>,
) {
    score_rect_lanes::<32>(image, threshold, rect, scores, scores_stride, hits);
}

/// [`score_rect`] in blocks of `L` pixels; rows narrower than `L` use blocks of 16,
/// rows narrower than 16 the scalar test.
#[inline(always)]
fn score_rect_lanes<const L: usize>(
    image: ImageView<'_, u8>,
    threshold: u8,
    rect: Rect,
    scores: &mut [u8],
    scores_stride: usize,
    hits: &mut Vec<(u32, u32)>,
) {
    let r = RING_RADIUS;
    assert!(
        rect.x0 >= r
            && rect.y0 >= r
            && rect.x1 + r <= image.width()
            && rect.y1 + r <= image.height(),
        "FAST rectangle {rect:?} too close to the border of {}x{}",
        image.width(),
        image.height()
    );
    if rect.x1 <= rect.x0 || rect.y1 <= rect.y0 {
        return;
    }
    let stride = image.stride() as isize;
    let data = image.as_slice();
    let offsets: [isize; 16] = RING.map(|(dx, dy)| dy * stride + dx);
    let n = rect.x1 - rect.x0;
    for y in rect.y0..rect.y1 {
        let out = &mut scores[y * scores_stride + rect.x0..y * scores_stride + rect.x1];
        let row_base = (y * image.stride() + rect.x0) as isize;
        let first_hit = hits.len();
        if n >= L {
            row_blocks::<L>(data, row_base, &offsets, threshold, out, hits);
        } else if n >= 16 {
            row_blocks::<16>(data, row_base, &offsets, threshold, out, hits);
        } else {
            for (i, o) in out.iter_mut().enumerate() {
                *o = full_test(data, row_base + i as isize, &offsets, threshold);
                if *o != 0 {
                    hits.push((i as u32, 0));
                }
            }
        }
        // Rows report columns relative to the rect; make them image positions.
        for h in &mut hits[first_hit..] {
            *h = (h.0 + rect.x0 as u32, y as u32);
        }
    }
}

/// Scores of one row (`out.len() >= L` pixels from flat index `row_base`) in blocks of
/// `L`; a tail of at most 16 pixels is one 16-lane block, a longer one an `L` block,
/// overlapping the previous block (same scores, hits pushed once). Hits are pushed as
/// `(column in the row, 0)`.
#[inline(always)]
fn row_blocks<const L: usize>(
    data: &[u8],
    row_base: isize,
    offsets: &[isize; 16],
    threshold: u8,
    out: &mut [u8],
    hits: &mut Vec<(u32, u32)>,
) {
    let n = out.len();
    let full = n / L * L;
    let mut push = |start: usize, mut found: u64| {
        while found != 0 {
            hits.push(((start + found.trailing_zeros() as usize) as u32, 0));
            found &= found - 1;
        }
    };
    for start in (0..full).step_by(L) {
        let lanes: &mut [u8; L] = (&mut out[start..start + L]).try_into().expect("L lanes");
        push(
            start,
            block_scores(data, row_base + start as isize, offsets, threshold, lanes),
        );
    }
    let tail = n - full;
    if tail == 0 {
        return;
    }
    let fresh = !0u64;
    if L > 16 && tail <= 16 {
        let start = n - 16;
        let lanes: &mut [u8; 16] = (&mut out[start..n]).try_into().expect("16 lanes");
        let found = block_scores(data, row_base + start as isize, offsets, threshold, lanes);
        push(start, found & (fresh << (16 - tail)));
    } else {
        let start = n - L;
        let lanes: &mut [u8; L] = (&mut out[start..n]).try_into().expect("L lanes");
        let found = block_scores(data, row_base + start as isize, offsets, threshold, lanes);
        push(start, found & (fresh << (L - tail)));
    }
}

/// `L` pixels from flat index `at`, as signed bytes (`x ^ 0x80`) so that unsigned
/// order becomes one signed compare instruction.
#[inline(always)]
fn load_signed<const L: usize>(data: &[u8], at: isize) -> [i8; L] {
    let at = at as usize;
    let src: &[u8; L] = data[at..at + L].try_into().expect("L bytes");
    let mut v = [0i8; L];
    for i in 0..L {
        v[i] = (src[i] ^ 0x80) as i8;
    }
    v
}

/// Lane mask: -1 (all bits) where `a > b`, else 0.
#[inline(always)]
fn greater<const L: usize>(a: &[i8; L], b: &[i8; L]) -> [i8; L] {
    let mut m = [0i8; L];
    for i in 0..L {
        m[i] = -i8::from(a[i] > b[i]);
    }
    m
}

/// FAST test of the `L <= 64` pixels starting at flat index `base`: scores into `out`,
/// and the bit mask of the corners (bit i = lane i) as result.
///
/// Branch-free over the lanes so that it auto-vectorises. Two pre-tests reject most
/// blocks: a 9-arc covers two adjacent compass points (ring 0, 4, 8, 12), and four
/// consecutive even points. The full test then needs only the even starts: a 9-arc
/// starting at `2e` is the 8-run `2e..2e+7` plus `2e+8`, one starting at `2e-1` is the
/// same 8-run plus `2e-1`; the 8-runs at even starts come from three rounds of pairwise
/// ANDs.
#[inline(always)]
fn block_scores<const L: usize>(
    data: &[u8],
    base: isize,
    offsets: &[isize; 16],
    t: u8,
    out: &mut [u8; L],
) -> u64 {
    let centre: &[u8; L] = data[base as usize..base as usize + L]
        .try_into()
        .expect("L bytes");
    let mut hi = [0i8; L];
    let mut lo = [0i8; L];
    for i in 0..L {
        hi[i] = (centre[i].saturating_add(t) ^ 0x80) as i8;
        lo[i] = (centre[i].saturating_sub(t) ^ 0x80) as i8;
    }
    // Masks per ring point: brighter than centre + t, darker than centre - t.
    let mut bright = [[0i8; L]; 16];
    let mut dark = [[0i8; L]; 16];
    for k in [0, 4, 8, 12] {
        classify(
            data,
            base + offsets[k],
            &hi,
            &lo,
            &mut bright[k],
            &mut dark[k],
        );
    }
    let mut any = [0i8; L];
    for m in [&bright, &dark] {
        for i in 0..L {
            any[i] |= (m[0][i] | m[8][i]) & (m[4][i] | m[12][i]);
        }
    }
    if any.iter().fold(0, |a, &b| a | b) == 0 {
        out.fill(0);
        return 0;
    }
    for k in [2, 6, 10, 14] {
        classify(
            data,
            base + offsets[k],
            &hi,
            &lo,
            &mut bright[k],
            &mut dark[k],
        );
    }
    let mut any = [0i8; L];
    for m in [&bright, &dark] {
        let mut pair = [[0i8; L]; 8];
        for e in 0..8 {
            for i in 0..L {
                pair[e][i] = m[2 * e][i] & m[(2 * e + 2) % 16][i];
            }
        }
        for e in 0..8 {
            for i in 0..L {
                any[i] |= pair[e][i] & pair[(e + 1) % 8][i];
            }
        }
    }
    if any.iter().fold(0, |a, &b| a | b) == 0 {
        out.fill(0);
        return 0;
    }
    for k in [1, 3, 5, 7, 9, 11, 13, 15] {
        classify(
            data,
            base + offsets[k],
            &hi,
            &lo,
            &mut bright[k],
            &mut dark[k],
        );
    }
    let corner_b = arc9(&bright);
    let corner_d = arc9(&dark);
    out.fill(0);
    let mut corners = 0u64;
    for i in 0..L {
        corners |= u64::from((corner_b[i] | corner_d[i]) != 0) << i;
    }
    // Corners are rare (about 1 pixel in 100 at threshold 20): score them one by one.
    let mut rest = corners;
    while rest != 0 {
        let i = rest.trailing_zeros() as usize;
        rest &= rest - 1;
        let at = base + i as isize;
        let mut ring = [0u8; 16];
        for (p, &off) in ring.iter_mut().zip(offsets) {
            *p = data[(at + off) as usize];
        }
        out[i] = arc_score(&ring, centre[i], corner_b[i] != 0);
    }
    corners
}

/// Masks of the ring pixels at `at`: brighter than `hi`, darker than `lo`.
#[inline(always)]
fn classify<const L: usize>(
    data: &[u8],
    at: isize,
    hi: &[i8; L],
    lo: &[i8; L],
    bright: &mut [i8; L],
    dark: &mut [i8; L],
) {
    let p = load_signed::<L>(data, at);
    *bright = greater(&p, hi);
    *dark = greater(lo, &p);
}

/// Lane mask of "the 16 ring masks `m` hold 9 contiguous set points".
#[inline(always)]
fn arc9<const L: usize>(m: &[[i8; L]; 16]) -> [i8; L] {
    let mut run = [[0i8; L]; 8];
    for e in 0..8 {
        for i in 0..L {
            run[e][i] = m[2 * e][i] & m[2 * e + 1][i];
        }
    }
    let mut run4 = [[0i8; L]; 8];
    for e in 0..8 {
        for i in 0..L {
            run4[e][i] = run[e][i] & run[(e + 1) % 8][i];
        }
    }
    let mut out = [0i8; L];
    for e in 0..8 {
        for i in 0..L {
            let run8 = run4[e][i] & run4[(e + 2) % 8][i];
            out[i] |= run8 & (m[(2 * e + 8) % 16][i] | m[(2 * e + 15) % 16][i]);
        }
    }
    out
}

/// Full ring test of the pixel at flat index `base`; its score when it is a corner at
/// `t`, else 0.
#[inline]
fn full_test(data: &[u8], base: isize, offsets: &[isize; 16], t: u8) -> u8 {
    let c = data[base as usize];
    let hi = c.saturating_add(t);
    let lo = c.saturating_sub(t);
    let mut ring = [0u8; 16];
    let mut bright = 0u32;
    let mut dark = 0u32;
    for (k, (&off, p)) in offsets.iter().zip(ring.iter_mut()).enumerate() {
        *p = data[(base + off) as usize];
        bright |= u32::from(*p > hi) << k;
        dark |= u32::from(*p < lo) << k;
    }
    if has_arc9(bright) {
        arc_score(&ring, c, true)
    } else if has_arc9(dark) {
        arc_score(&ring, c, false)
    } else {
        0
    }
}

/// True when the circular 16-bit mask `m` has 9 contiguous set bits.
#[inline]
fn has_arc9(m: u32) -> bool {
    let x = m | (m << 16);
    let x2 = x & (x >> 1);
    let x4 = x2 & (x2 >> 2);
    let x8 = x4 & (x4 >> 4);
    x8 & (x >> 8) != 0
}

/// `max over the 16 arcs of 9 of (min over the arc of the signed difference)`, the
/// largest threshold at which the corner holds on the `bright` (or dark) side.
#[inline]
fn arc_score(ring: &[u8; 16], c: u8, bright: bool) -> u8 {
    let mut d = [0i16; 24];
    for (k, v) in d.iter_mut().enumerate() {
        let p = i16::from(ring[k % 16]);
        *v = if bright {
            p - i16::from(c)
        } else {
            i16::from(c) - p
        };
    }
    let mut m2 = [0i16; 23];
    for k in 0..23 {
        m2[k] = d[k].min(d[k + 1]);
    }
    let mut m4 = [0i16; 21];
    for k in 0..21 {
        m4[k] = m2[k].min(m2[k + 2]);
    }
    let mut best = 0i16;
    for k in 0..16 {
        best = best.max(m4[k].min(m4[k + 4]).min(d[k + 8]));
    }
    best.clamp(0, 255) as u8
}

/// Appends to `out` the hits inside `rect` whose score is strictly larger than all 8
/// neighbours' (OpenCV's non-maximum suppression). The 1-pixel frame around `rect` must
/// lie inside the score map and hold scores or zeros.
pub(crate) fn local_maxima(
    scores: &[u8],
    stride: usize,
    rect: Rect,
    hits: &[(u32, u32)],
    out: &mut Vec<Corner>,
) {
    for &(x, y) in hits {
        let (x, y) = (x as usize, y as usize);
        if x < rect.x0 || x >= rect.x1 || y < rect.y0 || y >= rect.y1 {
            continue;
        }
        let i = y * stride + x;
        let s = scores[i];
        let above = &scores[i - stride - 1..i - stride + 2];
        let below = &scores[i + stride - 1..i + stride + 2];
        if s != 0
            && s > scores[i - 1]
            && s > scores[i + 1]
            && above.iter().all(|&a| s > a)
            && below.iter().all(|&b| s > b)
        {
            out.push(Corner {
                x: x as u32,
                y: y as u32,
                score: s,
            });
        }
    }
}

/// FAST-9 corners of the whole image at `threshold`, after non-maximum suppression,
/// appended to `out` in row-major order. Pixels within `RING_RADIUS + 1` of the border
/// are not tested. Allocates its own score map: meant for checks and tools, the
/// extractor uses its reusable scratch instead.
pub fn detect_fast(image: ImageView<'_, u8>, threshold: u8, out: &mut Vec<Corner>) {
    let (w, h) = (image.width(), image.height());
    let r = RING_RADIUS;
    if w < 2 * r + 3 || h < 2 * r + 3 || threshold == 0 {
        return;
    }
    let mut scores = vec![0u8; w * h];
    let all = Rect {
        x0: r,
        x1: w - r,
        y0: r,
        y1: h - r,
    };
    let mut hits = Vec::new();
    score_rect(image, threshold, all, &mut scores, w, &mut hits);
    let inner = Rect {
        x0: r + 1,
        x1: w - r - 1,
        y0: r + 1,
        y1: h - r - 1,
    };
    local_maxima(&scores, w, inner, &hits, out);
}

#[cfg(test)]
mod tests {
    use super::*;
    use gfs_core::GrayImage;

    /// Reference: the definition, checked arc by arc.
    fn is_corner_reference(img: &GrayImage, x: usize, y: usize, t: i32) -> bool {
        let c = i32::from(img.get(x, y).unwrap());
        let p: Vec<i32> = RING
            .iter()
            .map(|&(dx, dy)| {
                i32::from(
                    img.get((x as isize + dx) as usize, (y as isize + dy) as usize)
                        .unwrap(),
                )
            })
            .collect();
        (0..16).any(|s| (0..9).all(|k| p[(s + k) % 16] > c + t))
            || (0..16).any(|s| (0..9).all(|k| p[(s + k) % 16] < c - t))
    }

    fn noise_image(w: usize, h: usize, seed: u64) -> GrayImage {
        let mut s = seed;
        let data = (0..w * h)
            .map(|_| {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (s >> 56) as u8
            })
            .collect();
        GrayImage::from_vec(w, h, data).unwrap()
    }

    #[test]
    fn score_map_matches_the_definition_and_score_is_the_last_threshold() {
        // Blocky noise has both plain pixels and corners of every strength.
        let small = noise_image(16, 12, 7);
        let data = (0..48 * 36)
            .map(|i| small.get((i % 48) / 3, (i / 48) / 3).unwrap())
            .collect();
        let img = GrayImage::from_vec(48, 36, data).unwrap();
        let rect = Rect {
            x0: 3,
            x1: 45,
            y0: 3,
            y1: 33,
        };
        let mut corners = 0;
        for t in [1u8, 7, 20, 60] {
            let mut scores = vec![0u8; 48 * 36];
            let mut hits = Vec::new();
            score_rect(img.view(), t, rect, &mut scores, 48, &mut hits);
            assert_eq!(hits.len(), scores.iter().filter(|&&s| s != 0).count());
            for y in 3..33 {
                for x in 3..45 {
                    let s = scores[y * 48 + x];
                    let expect = is_corner_reference(&img, x, y, i32::from(t));
                    assert_eq!(s != 0, expect, "t={t} at ({x},{y})");
                    if s != 0 {
                        corners += 1;
                        assert!(s > t);
                        assert!(is_corner_reference(&img, x, y, i32::from(s) - 1));
                        assert!(!is_corner_reference(&img, x, y, i32::from(s)));
                    }
                }
            }
        }
        assert!(corners > 100, "{corners}");
    }

    #[test]
    fn both_block_widths_equal_the_scalar_test() {
        // Odd sizes so that rows end in partial blocks; rows of 20 pixels are narrower
        // than a 32-lane block and rows of 9 narrower than 16.
        let img = noise_image(203, 41, 99);
        for rect in [
            Rect {
                x0: 3,
                x1: 200,
                y0: 3,
                y1: 38,
            },
            Rect {
                x0: 5,
                x1: 25,
                y0: 4,
                y1: 30,
            },
            Rect {
                x0: 50,
                x1: 59,
                y0: 4,
                y1: 30,
            },
        ] {
            for t in [5u8, 20, 40] {
                let mut expect = vec![0u8; 203 * 41];
                let offsets: [isize; 16] = RING.map(|(dx, dy)| dy * 203 + dx);
                let mut expect_hits = Vec::new();
                for y in rect.y0..rect.y1 {
                    for x in rect.x0..rect.x1 {
                        let s = full_test(img.as_slice(), (y * 203 + x) as isize, &offsets, t);
                        expect[y * 203 + x] = s;
                        if s != 0 {
                            expect_hits.push((x as u32, y as u32));
                        }
                    }
                }
                let mut got16 = vec![0u8; 203 * 41];
                let mut hits16 = Vec::new();
                score_rect_lanes::<16>(img.view(), t, rect, &mut got16, 203, &mut hits16);
                let mut got = vec![0u8; 203 * 41];
                let mut hits = Vec::new();
                score_rect(img.view(), t, rect, &mut got, 203, &mut hits);
                assert_eq!(got16, expect, "16 lanes, t={t}");
                assert_eq!(got, expect, "dispatched, t={t}");
                hits16.sort_unstable_by_key(|&(x, y)| (y, x));
                hits.sort_unstable_by_key(|&(x, y)| (y, x));
                assert_eq!(hits16, expect_hits);
                assert_eq!(hits, expect_hits);
                assert!(!expect_hits.is_empty());
            }
        }
    }

    #[test]
    fn a_bright_square_gives_its_four_corners() {
        let mut img = GrayImage::new(40, 40);
        for y in 10..30 {
            for x in 10..30 {
                img.set(x, y, 200);
            }
        }
        // The square's edges are plateaus of equal score (suppressed); its corner
        // pixels are brighter, so they are strict maxima.
        for (x, y) in [(10, 10), (29, 10), (10, 29), (29, 29)] {
            img.set(x, y, 255);
        }
        let mut out = Vec::new();
        detect_fast(img.view(), 20, &mut out);
        let pts: Vec<(u32, u32)> = out.iter().map(|c| (c.x, c.y)).collect();
        assert_eq!(pts, vec![(10, 10), (29, 10), (10, 29), (29, 29)]);
        assert!(out.iter().all(|c| c.score == 255));
    }

    #[test]
    fn flat_and_tiny_images_have_no_corner() {
        let mut out = Vec::new();
        detect_fast(GrayImage::new(64, 48).view(), 7, &mut out);
        detect_fast(GrayImage::new(5, 5).view(), 7, &mut out);
        detect_fast(GrayImage::new(0, 0).view(), 7, &mut out);
        assert!(out.is_empty());
    }
}
