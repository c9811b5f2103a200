//! Score maps, non-maximum suppression and the public whole-image detector.

use super::kernels::{full_test, row_blocks};
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
