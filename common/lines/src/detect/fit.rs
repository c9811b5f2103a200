//! Line fitting along an edge chain, EDLines step 5: a least-squares (total least
//! squares) line is fitted to the first `min_length` pixels; if every pixel lies within
//! `max_error` of it, the line is extended pixel by pixel, refitting incrementally, while
//! the next pixel stays within `max_error`, then backwards over the pixels the sliding
//! window skipped; the segment ends there and the search resumes after it. Endpoints are the projections of the first and last pixel onto the line.
//!
//! Chain pixels are first moved to the sub-pixel peak of the gradient magnitude across
//! the edge (parabola through the three magnitudes), which removes the +-0.5 px
//! staircase of the pixel grid.

use gfs_core::Image;

use super::gradient::{HORIZONTAL, ORIENTATION};

/// Running first and second moments of 2D points, relative to an origin for precision.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Moments {
    n: f64,
    sx: f64,
    sy: f64,
    sxx: f64,
    syy: f64,
    sxy: f64,
}

/// An infinite line through `centre` with unit direction `dir`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Line {
    pub centre: [f64; 2],
    pub dir: [f64; 2],
}

impl Line {
    /// Unsigned distance of `p` to the line.
    #[inline]
    pub(crate) fn distance(&self, p: [f64; 2]) -> f64 {
        ((p[0] - self.centre[0]) * self.dir[1] - (p[1] - self.centre[1]) * self.dir[0]).abs()
    }

    /// Orthogonal projection of `p` onto the line.
    #[inline]
    pub(crate) fn project(&self, p: [f64; 2]) -> [f64; 2] {
        let t = (p[0] - self.centre[0]) * self.dir[0] + (p[1] - self.centre[1]) * self.dir[1];
        [
            self.centre[0] + t * self.dir[0],
            self.centre[1] + t * self.dir[1],
        ]
    }
}

impl Moments {
    /// Adds `weight` times the point `p`.
    #[inline]
    pub(crate) fn add(&mut self, p: [f64; 2], weight: f64) {
        self.n += weight;
        self.sx += weight * p[0];
        self.sy += weight * p[1];
        self.sxx += weight * p[0] * p[0];
        self.syy += weight * p[1] * p[1];
        self.sxy += weight * p[0] * p[1];
    }

    /// Adds raw second moments (already multiplied by their weight) about the origin.
    pub(crate) fn add_second(&mut self, xx: f64, yy: f64, xy: f64) {
        self.sxx += xx;
        self.syy += yy;
        self.sxy += xy;
    }

    /// The total-least-squares line (principal axis), `None` without spread.
    pub(crate) fn line(&self) -> Option<Line> {
        if self.n <= 0.0 {
            return None;
        }
        let (mx, my) = (self.sx / self.n, self.sy / self.n);
        let cxx = self.sxx / self.n - mx * mx;
        let cyy = self.syy / self.n - my * my;
        let cxy = self.sxy / self.n - mx * my;
        let half = 0.5 * (cxx - cyy);
        let lambda = 0.5 * (cxx + cyy) + (half * half + cxy * cxy).sqrt();
        // Eigenvector of the largest eigenvalue: the better conditioned of two forms.
        let (a, b) = (cxy, lambda - cxx);
        let (c, d) = (lambda - cyy, cxy);
        let (vx, vy) = if a * a + b * b >= c * c + d * d {
            (a, b)
        } else {
            (c, d)
        };
        let norm = (vx * vx + vy * vy).sqrt();
        if norm <= 1e-12 {
            return None;
        }
        Some(Line {
            centre: [mx, my],
            dir: [vx / norm, vy / norm],
        })
    }
}

/// Scratch and parameters of the chain fitter.
#[derive(Debug, Default)]
pub(crate) struct Fitter {
    points: Vec<[f64; 2]>,
}

impl Fitter {
    /// Fits segments to `chain` and pushes their endpoints `[u0, v0, u1, v1]` to `out`.
    ///
    /// A closed chain (its ends are neighbours) is refitted once starting where its first
    /// segment ended, so that the side holding the chain's arbitrary start is not cut in
    /// two.
    pub(crate) fn fit_chain(
        &mut self,
        chain: &[u32],
        magnitude: &Image<u16>,
        state: &Image<u8>,
        min_length: usize,
        max_error: f64,
        out: &mut Vec<[f32; 4]>,
    ) {
        let min_length = min_length.max(2);
        if chain.len() < min_length {
            return;
        }
        self.sub_pixel_points(chain, magnitude, state);
        let before = out.len();
        let first_end = fit_points(&self.points, min_length, max_error, out);
        let w = magnitude.width();
        let (a, b) = (chain[0] as usize, chain[chain.len() - 1] as usize);
        let closed = (a % w).abs_diff(b % w) <= 1 && (a / w).abs_diff(b / w) <= 1;
        if let Some(end) = first_end.filter(|&e| closed && e < self.points.len()) {
            out.truncate(before);
            self.points.rotate_left(end);
            fit_points(&self.points, min_length, max_error, out);
        }
    }

    /// Chain pixels moved to the sub-pixel magnitude peak across their edge.
    fn sub_pixel_points(&mut self, chain: &[u32], magnitude: &Image<u16>, state: &Image<u8>) {
        let w = magnitude.width();
        let mag = magnitude.as_slice();
        let st = state.as_slice();
        self.points.clear();
        let Some(&first) = chain.first() else {
            return;
        };
        // Consecutive chain pixels are 8-neighbours: track (u, v) from the index steps
        // instead of dividing by the width at every pixel.
        let w_signed = w as i64;
        let (mut u, mut v) = ((first as usize % w) as i64, (first as usize / w) as i64);
        let mut previous = i64::from(first);
        self.points.extend(chain.iter().map(|&i| {
            let step = i64::from(i) - previous;
            previous = i64::from(i);
            let dv = if step > 1 {
                1
            } else if step < -1 {
                -1
            } else {
                0
            };
            v += dv;
            u += step - dv * w_signed;
            let i = i as usize;
            let (u, v) = (u as f64, v as f64);
            // Chain pixels are interior, so both neighbours across the edge exist.
            let horizontal = st[i] & ORIENTATION == HORIZONTAL;
            let step = if horizontal { w } else { 1 };
            let (gm, g0, gp) = (
                f64::from(mag[i - step]),
                f64::from(mag[i]),
                f64::from(mag[i + step]),
            );
            let curvature = gm - 2.0 * g0 + gp;
            let offset = if curvature < 0.0 {
                (0.5 * (gm - gp) / curvature).clamp(-0.5, 0.5)
            } else {
                0.0
            };
            if horizontal {
                [u, v + offset]
            } else {
                [u + offset, v]
            }
        }));
    }
}

/// The EDLines fit along `pts` (see the module doc); returns the index after the first
/// segment, if any.
fn fit_points(
    pts: &[[f64; 2]],
    min_length: usize,
    max_error: f64,
    out: &mut Vec<[f32; 4]>,
) -> Option<usize> {
    let &origin = pts.first()?;
    let rel = |p: [f64; 2]| [p[0] - origin[0], p[1] - origin[1]];
    let mut first_end = None;
    let (mut i, mut floor) = (0, 0);
    while i + min_length <= pts.len() {
        let mut m = Moments::default();
        for &p in &pts[i..i + min_length] {
            m.add(rel(p), 1.0);
        }
        let fits = m.line().is_some_and(|line| {
            pts[i..i + min_length]
                .iter()
                .all(|&p| line.distance(rel(p)) <= max_error)
        });
        if !fits {
            i += 1;
            continue;
        }
        let mut j = i + min_length;
        while j < pts.len() {
            let Some(line) = m.line() else { break };
            if line.distance(rel(pts[j])) > max_error {
                break;
            }
            m.add(rel(pts[j]), 1.0);
            j += 1;
        }
        // The window may have started a few pixels late (the first windows held a
        // corner): grow backwards too, down to the end of the previous segment.
        let mut first = i;
        while first > floor {
            let Some(line) = m.line() else { break };
            if line.distance(rel(pts[first - 1])) > max_error {
                break;
            }
            first -= 1;
            m.add(rel(pts[first]), 1.0);
        }
        if let Some(line) = m.line() {
            let a = line.project(rel(pts[first]));
            let b = line.project(rel(pts[j - 1]));
            out.push([
                (a[0] + origin[0]) as f32,
                (a[1] + origin[1]) as f32,
                (b[0] + origin[0]) as f32,
                (b[1] + origin[1]) as f32,
            ]);
            first_end.get_or_insert(j);
        }
        i = j;
        floor = j;
    }
    first_end
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn moments_recover_a_slanted_line() {
        let mut m = Moments::default();
        for t in 0..20 {
            let t = f64::from(t);
            m.add([3.0 + 0.8 * t, 1.0 + 0.6 * t], 1.0);
        }
        let line = m.line().unwrap();
        assert!((line.dir[0].abs() - 0.8).abs() < 1e-9 && (line.dir[1].abs() - 0.6).abs() < 1e-9);
        assert!(line.distance([3.0, 1.0]) < 1e-9);
        assert!((line.distance([3.0 - 0.6, 1.0 + 0.8]) - 1.0).abs() < 1e-9);
    }
}
