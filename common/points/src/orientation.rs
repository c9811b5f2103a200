//! Keypoint orientation by intensity centroid (Rosin 1999; ORB, Rublee et al. 2011,
//! Sec. 3.2): the angle of the vector from the keypoint to the centroid of the
//! intensities on a circular patch of radius 15, `atan2(m01, m10)`.

use crate::simd::avx2_dispatch;
use gfs_core::ImageView;

/// Radius of the circular patch (ORB-SLAM2 `HALF_PATCH_SIZE`).
pub const HALF_PATCH: usize = 15;

/// Half-width of each row of the circular patch: row `v` spans `-umax[|v|]..=umax[|v|]`.
/// Built as ORB-SLAM2 does: rounded circle up to 45 degrees, mirrored above so that the
/// patch is symmetric in u and v.
pub(crate) fn umax_table() -> [usize; HALF_PATCH + 1] {
    let hp = HALF_PATCH as f64;
    let mut umax = [0usize; HALF_PATCH + 1];
    let vmax = (hp * std::f64::consts::SQRT_2 / 2.0 + 1.0).floor() as usize;
    let vmin = (hp * std::f64::consts::SQRT_2 / 2.0).ceil() as usize;
    for (v, u) in umax.iter_mut().enumerate().take(vmax + 1) {
        *u = (hp * hp - (v * v) as f64).sqrt().round() as usize;
    }
    let mut v0 = 0;
    for v in (vmin..=HALF_PATCH).rev() {
        while umax[v0] == umax[v0 + 1] {
            v0 += 1;
        }
        umax[v] = v0;
        v0 += 1;
    }
    umax
}

/// Width of the rows read: the 31 patch columns plus one of weight 0, so that every row
/// is a fixed-size array the compiler vectorises.
const ROW: usize = 32;
const ROWS: usize = 2 * HALF_PATCH + 1;

/// The disc as weight tables: `column[r][i] = u` and `row[r][i] = v` inside the disc, 0
/// outside, for row `r = v + 15` and column `i = u + 15`.
#[derive(Debug)]
pub(crate) struct Disc {
    column: [[i16; ROW]; ROWS],
    row: [[i16; ROW]; ROWS],
}

impl Default for Disc {
    fn default() -> Self {
        let umax = umax_table();
        let mut column = [[0i16; ROW]; ROWS];
        let mut row_w = [[0i16; ROW]; ROWS];
        let r = HALF_PATCH as i32;
        for (row, v) in (-r..=r).enumerate() {
            let d = umax[v.unsigned_abs() as usize] as i32;
            for (i, u) in (-r..=r).enumerate() {
                if u.abs() <= d {
                    column[row][i] = u as i16;
                    row_w[row][i] = v as i16;
                }
            }
        }
        Self { column, row: row_w }
    }
}

impl Disc {
    /// Orientation in radians in `[0, 2π)` of the patch centred on `(x, y)`, which must
    /// be at least `HALF_PATCH` pixels from the left, top and bottom borders and
    /// `HALF_PATCH + 2` from the right one (caller invariant).
    pub(crate) fn angle(&self, image: ImageView<'_, u8>, x: usize, y: usize) -> f32 {
        debug_assert!(
            x >= HALF_PATCH
                && y >= HALF_PATCH
                && x + ROW - HALF_PATCH <= image.width()
                && y + HALF_PATCH < image.height()
        );
        let top_left = (y - HALF_PATCH) * image.stride() + x - HALF_PATCH;
        let (m10, m01) = disc_moments(
            image.as_slice(),
            image.stride(),
            top_left,
            &self.column,
            &self.row,
        );
        let a = (m01 as f32).atan2(m10 as f32);
        if a < 0.0 {
            a + std::f32::consts::TAU
        } else {
            a
        }
    }
}

avx2_dispatch! {
    /// `(sum u I, sum v I)` over the disc whose 32-wide bounding rows start at `top_left`.
    /// Moments accumulate per column over the rows, then sum: element-wise products of
    /// `i16` (|u| * 255 < 2^15) into `i32` lanes, which vectorise.
    fn disc_moments(
        data: &[u8],
        stride: usize,
        top_left: usize,
        column: &[[i16; ROW]; ROWS],
        row: &[[i16; ROW]; ROWS],
    ) -> (i32, i32) {
        let mut acc10 = [0i32; ROW];
        let mut acc01 = [0i32; ROW];
        for r in 0..ROWS {
            let start = top_left + r * stride;
            let pixels: &[u8; ROW] = data[start..start + ROW].try_into().expect("row of 32");
            let (cw, rw) = (&column[r], &row[r]);
            for i in 0..ROW {
                let p = i16::from(pixels[i]);
                acc10[i] += i32::from(cw[i] * p);
                acc01[i] += i32::from(rw[i] * p);
            }
        }
        (acc10.iter().sum(), acc01.iter().sum())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gfs_core::GrayImage;

    #[test]
    fn umax_is_the_orb_slam2_table() {
        assert_eq!(
            umax_table(),
            [15, 15, 15, 15, 14, 14, 14, 13, 13, 12, 11, 10, 9, 8, 6, 3]
        );
    }

    #[test]
    fn the_disc_has_the_umax_rows() {
        let disc = Disc::default();
        let area = disc
            .column
            .iter()
            .flatten()
            .zip(disc.row.iter().flatten())
            .filter(|&(&u, &v)| u != 0 || v != 0)
            .count()
            + 1;
        let umax = umax_table();
        let expect: usize = (0..ROWS)
            .map(|r| 2 * umax[(r as i32 - 15).unsigned_abs() as usize] + 1)
            .sum();
        assert_eq!(area, expect);
        assert_eq!(expect, 749);
        assert!(disc.column.iter().all(|row| row[ROW - 1] == 0));
    }

    #[test]
    fn the_angle_points_to_the_bright_side() {
        // A ramp increasing along direction theta: the centroid lies along theta.
        let disc = Disc::default();
        for deg in [0.0f32, 30.0, 90.0, 135.0, 200.0, 300.0] {
            let t = deg.to_radians();
            let (w, h) = (41, 41);
            let data = (0..w * h)
                .map(|i| {
                    let (x, y) = ((i % w) as f32 - 20.0, (i / w) as f32 - 20.0);
                    (128.0 + 4.0 * (x * t.cos() + y * t.sin())).round() as u8
                })
                .collect();
            let img = GrayImage::from_vec(w, h, data).unwrap();
            let a = disc.angle(img.view(), 20, 20).to_degrees();
            let err = (a - deg + 540.0).rem_euclid(360.0) - 180.0;
            assert!(err.abs() < 0.5, "{deg}: got {a}");
        }
    }
}
