//! Joining of broken segments, in the spirit of ELSED (Suárez, Buenaposada & Baumela,
//! "ELSED: Enhanced line segment drawing", Pattern Recognition 2022): a detector that
//! stops at every small interruption of an edge (a highlight, an occluding wire, a
//! texture gap) turns one long line into short pieces, which are worse to match and to
//! lift to 3D. Three steps, all on the gradients of the detection frame:
//!
//! 1. **Extension**: each endpoint is pushed outwards along the segment direction while
//!    the pixels on the line have a gradient above the detection threshold and oriented
//!    along the segment normal with the segment's polarity (within the alignment
//!    tolerance), tolerating a few unsupported pixels in a row (ELSED's jumps).
//! 2. **Endpoint refinement**: each endpoint moves (at most 3 px either way) to where the
//!    cross-line gradient falls to half of its level along the segment, the sub-pixel
//!    end of the blurred step edge.
//! 3. **Merging**: two segments with the same orientation and polarity (angle below
//!    `merge_angle_deg`), whose endpoints lie within `merge_offset` px of each other's
//!    line and whose gap along the line is at most `merge_gap` px, are replaced by the
//!    total-least-squares line of both (each segment weighted by its length), spanning
//!    the extreme projections of their endpoints. Repeated until nothing merges.
//!
//! Polarity: segments follow the detector convention (brighter on the positive side of
//! [`crate::Segment::line_coefficients`]), so an edge and an opposite-contrast edge on the
//! same line (the two sides of a thin bar) never merge.

use gfs_core::ImageView;
use serde::{Deserialize, Serialize};

use crate::detect::{DetectConfigError, Moments, check, clamped};
use crate::{DetectedLine, Segment};

/// The `[lines.detect.join]` table: extension and merging of detected segments.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct JoinConfig {
    /// Unsupported pixels in a row that an extension may step over before it stops.
    /// Default 2 (ELSED jumps over small interruptions; larger gaps are left to merging).
    pub extension_gap: usize,
    /// Angle tolerance (degrees) between the gradient and the segment normal for a pixel
    /// to support an extension. Default 22.5: the EDLines / LSD alignment precision.
    pub aligned_angle_deg: f32,
    /// Maximum angle (degrees) between two segments that may merge. Default 3.0.
    pub merge_angle_deg: f32,
    /// Maximum distance (px) of an endpoint to the other segment's line. Default 1.5.
    pub merge_offset: f32,
    /// Maximum gap (px) between the two segments along the line. Default 10.0: covers
    /// 5 px interruptions plus the ~2 px each side that smoothing takes off the ends.
    pub merge_gap: f32,
}

impl Default for JoinConfig {
    fn default() -> Self {
        Self {
            extension_gap: 2,
            aligned_angle_deg: 22.5,
            merge_angle_deg: 3.0,
            merge_offset: 1.5,
            merge_gap: 10.0,
        }
    }
}

impl JoinConfig {
    /// Checks every value against its range.
    ///
    /// # Errors
    /// [`DetectConfigError::OutOfRange`] naming the first field out of range.
    pub fn validate(&self) -> Result<(), DetectConfigError> {
        check(
            "join.aligned_angle_deg",
            self.aligned_angle_deg.into(),
            0.0,
            90.0,
            "in (0, 90] degrees",
        )?;
        check(
            "join.merge_angle_deg",
            self.merge_angle_deg.into(),
            0.0,
            90.0,
            "in (0, 90] degrees",
        )?;
        check(
            "join.merge_offset",
            self.merge_offset.into(),
            0.0,
            100.0,
            "in (0, 100] px",
        )?;
        check(
            "join.merge_gap",
            self.merge_gap.into(),
            0.0,
            1000.0,
            "in (0, 1000] px",
        )?;
        let gap = self.extension_gap as f64;
        check(
            "join.extension_gap",
            gap + 1.0,
            0.0,
            1001.0,
            "at most 1000 px",
        )
    }
}

/// Gradient maps of the detection frame.
#[derive(Clone, Copy, Debug)]
pub(crate) struct GradientField<'a> {
    /// Sobel derivative along u.
    pub gx: ImageView<'a, i16>,
    /// Sobel derivative along v.
    pub gy: ImageView<'a, i16>,
    /// `|gx| + |gy|`.
    pub magnitude: ImageView<'a, u16>,
    /// Edge threshold on `magnitude`.
    pub threshold: u16,
}

impl GradientField<'_> {
    /// Integer pixel nearest to (u, v) when it lies inside the image.
    #[inline]
    fn pixel(&self, u: f32, v: f32) -> Option<(usize, usize)> {
        if !(u >= -0.5 && v >= -0.5) {
            return None;
        }
        let (x, y) = ((u + 0.5) as usize, (v + 0.5) as usize);
        (x < self.magnitude.width() && y < self.magnitude.height()).then_some((x, y))
    }

    /// Mean magnitude at the pixels along the segment (one sample per pixel of length).
    pub(crate) fn mean_magnitude(&self, s: &Segment) -> f32 {
        let len = s.length();
        let n = len as usize + 1;
        let (tu, tv) = if len > 0.0 {
            ((s.end[0] - s.start[0]) / len, (s.end[1] - s.start[1]) / len)
        } else {
            (0.0, 0.0)
        };
        let (mut sum, mut count) = (0.0f32, 0usize);
        for i in 0..n {
            let t = i as f32;
            if let Some((x, y)) = self.pixel(s.start[0] + t * tu, s.start[1] + t * tv) {
                sum += f32::from(self.magnitude.at(x, y));
                count += 1;
            }
        }
        if count == 0 { 0.0 } else { sum / count as f32 }
    }

    /// True when pixel (u, v) is an edge pixel whose gradient points along `normal`
    /// within the tolerance.
    #[inline]
    fn supports(&self, u: f32, v: f32, normal: [f32; 2], cos_tolerance: f32) -> bool {
        let Some((x, y)) = self.pixel(u, v) else {
            return false;
        };
        if self.magnitude.at(x, y) < self.threshold.max(1) {
            return false;
        }
        let (gx, gy) = (f32::from(self.gx.at(x, y)), f32::from(self.gy.at(x, y)));
        let dot = gx * normal[0] + gy * normal[1];
        dot > 0.0 && dot * dot >= cos_tolerance * cos_tolerance * (gx * gx + gy * gy)
    }
}

impl GradientField<'_> {
    /// Gradient component along `normal` at (u, v), bilinear in `gx` and `gy`; 0 outside.
    fn normal_component(&self, u: f32, v: f32, normal: [f32; 2]) -> f32 {
        let (w, h) = (self.gx.width(), self.gx.height());
        if w < 2 || h < 2 || !(u >= 0.0 && v >= 0.0) {
            return 0.0;
        }
        let (x0, y0) = (u.floor() as usize, v.floor() as usize);
        if x0 + 1 >= w || y0 + 1 >= h {
            return 0.0;
        }
        let (fx, fy) = (u - x0 as f32, v - y0 as f32);
        let at = |x: usize, y: usize| {
            f32::from(self.gx.at(x, y)) * normal[0] + f32::from(self.gy.at(x, y)) * normal[1]
        };
        let top = at(x0, y0) * (1.0 - fx) + at(x0 + 1, y0) * fx;
        let bottom = at(x0, y0 + 1) * (1.0 - fx) + at(x0 + 1, y0 + 1) * fx;
        top * (1.0 - fy) + bottom * fy
    }
}

/// Scratch of the joining step, reused every frame.
#[derive(Debug, Default)]
pub(crate) struct JoinScratch {
    alive: Vec<bool>,
    geometry: Vec<Geometry>,
}

/// Extends then merges `lines` in place (see the module doc); longest first on return.
pub(crate) fn join_lines(
    config: &JoinConfig,
    field: &GradientField<'_>,
    lines: &mut Vec<DetectedLine>,
    scratch: &mut JoinScratch,
) {
    let cos_tolerance = clamped(config.aligned_angle_deg, 0.0, 90.0)
        .to_radians()
        .cos();
    for line in lines.iter_mut() {
        extend(
            &mut line.segment,
            field,
            config.extension_gap,
            cos_tolerance,
        );
        refine_endpoints(&mut line.segment, field);
    }
    merge(config, lines, scratch);
}

/// Pushes both endpoints of `s` outwards while the gradient supports the line.
fn extend(s: &mut Segment, field: &GradientField<'_>, max_gap: usize, cos_tolerance: f32) {
    let len = s.length();
    if len <= f32::EPSILON || !len.is_finite() {
        return;
    }
    let [a, b, _] = s.line_coefficients();
    let normal = [a, b];
    let dir = [(s.end[0] - s.start[0]) / len, (s.end[1] - s.start[1]) / len];
    // No extension can leave the image, whatever the gap setting.
    let limit = field.magnitude.width() + field.magnitude.height();
    let reach = |from: [f32; 2], sign: f32| {
        let mut last = 0usize;
        let mut t = 1usize;
        while t - last <= max_gap.saturating_add(1) && t <= limit {
            let step = sign * t as f32;
            if field.supports(
                from[0] + step * dir[0],
                from[1] + step * dir[1],
                normal,
                cos_tolerance,
            ) {
                last = t;
            }
            t += 1;
        }
        sign * last as f32
    };
    let forward = reach(s.end, 1.0);
    let backward = reach(s.start, -1.0);
    s.end = [s.end[0] + forward * dir[0], s.end[1] + forward * dir[1]];
    s.start = [
        s.start[0] + backward * dir[0],
        s.start[1] + backward * dir[1],
    ];
}

/// How far (px) [`refine_endpoints`] looks on each side of an endpoint.
const REFINE_REACH: f32 = 3.0;
/// Samples of the reference level of [`refine_endpoints`].
const REFINE_SAMPLES: usize = 24;
/// Sampling step (px) of [`refine_endpoints`].
const REFINE_STEP: f32 = 0.5;

/// Moves each endpoint to where the gradient component across the line falls to half of
/// its mean along the segment. Where a blurred step edge ends (a corner, a T-junction, a
/// contrast change), its cross-gradient on the line drops from full to zero and passes
/// half exactly at the end of the step (for a 90-degree corner of a Gaussian-blurred
/// step, `Phi(0) = 1/2`), so this places endpoints to a fraction of a pixel where pixel
/// chains stop one or two pixels early or late.
fn refine_endpoints(s: &mut Segment, field: &GradientField<'_>) {
    let len = s.length();
    if len < 4.0 * REFINE_REACH || !len.is_finite() {
        return;
    }
    let [a, b, _] = s.line_coefficients();
    let normal = [a, b];
    let dir = [(s.end[0] - s.start[0]) / len, (s.end[1] - s.start[1]) / len];
    // The reference level: mean cross-gradient at up to REFINE_SAMPLES evenly spaced
    // pixels (a mean needs no more, and long lines would otherwise cost a pass each).
    let samples = (len as usize).min(REFINE_SAMPLES);
    let spacing = len / samples as f32;
    let mut sum = 0.0;
    for i in 0..samples {
        let t = (i as f32 + 0.5) * spacing;
        if let Some((x, y)) = field.pixel(s.start[0] + t * dir[0], s.start[1] + t * dir[1]) {
            sum +=
                f32::from(field.gx.at(x, y)) * normal[0] + f32::from(field.gy.at(x, y)) * normal[1];
        }
    }
    let half = 0.5 * sum / samples as f32;
    if half <= 0.0 {
        return;
    }
    // Walks outward from `REFINE_REACH` inside `end` (direction `sign * dir`) and returns
    // the signed shift of the half-level crossing, if found within the reach.
    let crossing = |end: [f32; 2], sign: f32| -> Option<f32> {
        let f = |t: f32| {
            let t = sign * t;
            field.normal_component(end[0] + t * dir[0], end[1] + t * dir[1], normal)
        };
        let mut t = -REFINE_REACH;
        let mut prev = f(t);
        if prev < half {
            return None;
        }
        while t < REFINE_REACH {
            let next_t = t + REFINE_STEP;
            let next = f(next_t);
            if next < half {
                return Some(sign * (t + REFINE_STEP * (prev - half) / (prev - next)));
            }
            t = next_t;
            prev = next;
        }
        None
    };
    let end_shift = crossing(s.end, 1.0);
    let start_shift = crossing(s.start, -1.0);
    if let Some(d) = end_shift {
        s.end = [s.end[0] + d * dir[0], s.end[1] + d * dir[1]];
    }
    if let Some(d) = start_shift {
        s.start = [s.start[0] + d * dir[0], s.start[1] + d * dir[1]];
    }
}

/// Length and unit direction of a segment, cached for the pairwise merge tests.
#[derive(Clone, Copy, Debug, Default)]
struct Geometry {
    len: f32,
    dir: [f32; 2],
}

impl Geometry {
    fn of(s: &Segment) -> Self {
        let len = s.length();
        let dir = if len > f32::EPSILON {
            [(s.end[0] - s.start[0]) / len, (s.end[1] - s.start[1]) / len]
        } else {
            [0.0; 2]
        };
        Self { len, dir }
    }
}

/// Squared length: a sort key without a square root.
fn length2(s: &Segment) -> f32 {
    let (du, dv) = (s.end[0] - s.start[0], s.end[1] - s.start[1]);
    du * du + dv * dv
}

/// Merges collinear pieces until nothing changes; sorts `lines` longest first.
fn merge(config: &JoinConfig, lines: &mut Vec<DetectedLine>, scratch: &mut JoinScratch) {
    lines.sort_by(|p, q| length2(&q.segment).total_cmp(&length2(&p.segment)));
    let JoinScratch { alive, geometry } = scratch;
    alive.clear();
    alive.resize(lines.len(), true);
    geometry.clear();
    geometry.extend(lines.iter().map(|l| Geometry::of(&l.segment)));
    let cos_angle = clamped(config.merge_angle_deg, 0.0, 90.0)
        .to_radians()
        .cos();
    for i in 0..lines.len() {
        if !alive[i] || geometry[i].len <= f32::EPSILON {
            continue;
        }
        let mut changed = true;
        while changed {
            changed = false;
            for j in i + 1..lines.len() {
                if !alive[j]
                    || !mergeable(
                        config,
                        cos_angle,
                        &lines[i],
                        &geometry[i],
                        &lines[j],
                        &geometry[j],
                    )
                {
                    continue;
                }
                lines[i] = merged(&lines[i], &lines[j]);
                geometry[i] = Geometry::of(&lines[i].segment);
                alive[j] = false;
                changed = true;
            }
        }
    }
    let mut k = 0;
    lines.retain(|_| {
        k += 1;
        alive[k - 1]
    });
    lines.sort_by(|p, q| length2(&q.segment).total_cmp(&length2(&p.segment)));
}

/// Whether `short` continues `long` (see the module doc for the three gates).
fn mergeable(
    config: &JoinConfig,
    cos_angle: f32,
    long: &DetectedLine,
    gl: &Geometry,
    short: &DetectedLine,
    gs: &Geometry,
) -> bool {
    let (p, q) = (&long.segment, &short.segment);
    let (dp, dq) = (gl.dir, gs.dir);
    // Oriented directions: same polarity and nearly the same angle.
    if gs.len <= f32::EPSILON || dp[0] * dq[0] + dp[1] * dq[1] < cos_angle {
        return false;
    }
    // Signed distance to the long segment's line (normal as `line_coefficients`).
    let offset = |e: [f32; 2]| ((e[0] - p.start[0]) * dp[1] - (e[1] - p.start[1]) * dp[0]).abs();
    if offset(q.start) > config.merge_offset || offset(q.end) > config.merge_offset {
        return false;
    }
    let along = |e: [f32; 2]| (e[0] - p.start[0]) * dp[0] + (e[1] - p.start[1]) * dp[1];
    let (t0, t1) = (along(q.start), along(q.end));
    let gap = (t0.min(t1) - gl.len).max(-t0.max(t1));
    gap <= config.merge_gap
}

/// The total-least-squares line of two segments (uniform mass along each), spanning the
/// extreme projections of the four endpoints, oriented like `long`.
fn merged(long: &DetectedLine, short: &DetectedLine) -> DetectedLine {
    let mut m = Moments::default();
    let origin = long.segment.start;
    for s in [&long.segment, &short.segment] {
        let len = f64::from(s.length());
        let mid = s.midpoint();
        let c = [f64::from(mid[0] - origin[0]), f64::from(mid[1] - origin[1])];
        let d = [
            f64::from(s.end[0] - s.start[0]) / len,
            f64::from(s.end[1] - s.start[1]) / len,
        ];
        m.add(c, len);
        // A uniform segment of length L adds L^3 / 12 d d^T about its centre.
        let spread = len * len * len / 12.0;
        m.add_second(
            spread * d[0] * d[0],
            spread * d[1] * d[1],
            spread * d[0] * d[1],
        );
    }
    let Some(line) = m.line() else {
        return *long;
    };
    let sign = {
        let d = [
            long.segment.end[0] - long.segment.start[0],
            long.segment.end[1] - long.segment.start[1],
        ];
        if f64::from(d[0]) * line.dir[0] + f64::from(d[1]) * line.dir[1] >= 0.0 {
            1.0
        } else {
            -1.0
        }
    };
    let dir = [sign * line.dir[0], sign * line.dir[1]];
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for e in [
        long.segment.start,
        long.segment.end,
        short.segment.start,
        short.segment.end,
    ] {
        let r = [
            f64::from(e[0] - origin[0]) - line.centre[0],
            f64::from(e[1] - origin[1]) - line.centre[1],
        ];
        let t = r[0] * dir[0] + r[1] * dir[1];
        lo = lo.min(t);
        hi = hi.max(t);
    }
    let point = |t: f64| {
        [
            (line.centre[0] + t * dir[0]) as f32 + origin[0],
            (line.centre[1] + t * dir[1]) as f32 + origin[1],
        ]
    };
    let (a, b) = (point(lo), point(hi));
    let (ll, ls) = (long.segment.length(), short.segment.length());
    DetectedLine {
        segment: Segment::new(a[0], a[1], b[0], b[1]),
        mean_gradient: (long.mean_gradient * ll + short.mean_gradient * ls) / (ll + ls),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{DetectConfig, LineDetector};
    use gfs_core::Image;

    fn line(u0: f32, v0: f32, u1: f32, v1: f32) -> DetectedLine {
        DetectedLine {
            segment: Segment::new(u0, v0, u1, v1),
            mean_gradient: 100.0,
        }
    }

    fn merge_all(mut lines: Vec<DetectedLine>) -> Vec<DetectedLine> {
        merge(
            &JoinConfig::default(),
            &mut lines,
            &mut JoinScratch::default(),
        );
        lines
    }

    #[test]
    fn collinear_pieces_across_a_gap_merge_into_one_refitted_line() {
        // Gap of 8 px, second piece 0.4 px lower: one line from u = 0 to u = 90.
        let out = merge_all(vec![
            line(0.0, 10.0, 40.0, 10.0),
            line(48.0, 10.4, 90.0, 10.4),
        ]);
        assert_eq!(out.len(), 1, "{out:?}");
        let s = out[0].segment;
        assert!(
            s.start[0].abs() < 0.1 && (s.end[0] - 90.0).abs() < 0.1,
            "{s:?}"
        );
        // The length-weighted fit sits between the pieces (40 px at 10.0, 42 px at 10.4).
        let mid_v = s.midpoint()[1];
        assert!(mid_v > 10.1 && mid_v < 10.3, "{s:?}");
        assert!((out[0].mean_gradient - 100.0).abs() < 1e-3);
    }

    #[test]
    fn opposite_polarity_offset_or_distant_pieces_stay_apart() {
        let base = line(0.0, 10.0, 40.0, 10.0);
        // Opposite polarity (reversed direction), 3 px offset, 15 px gap, 6 degrees.
        for other in [
            line(90.0, 10.0, 48.0, 10.0),
            line(48.0, 13.0, 90.0, 13.0),
            line(55.0, 10.0, 90.0, 10.0),
            line(48.0, 10.0, 90.0, 10.0 + 42.0 * 6f32.to_radians().tan()),
        ] {
            assert_eq!(merge_all(vec![base, other]).len(), 2, "{other:?}");
        }
    }

    #[test]
    fn shortened_segments_grow_back_to_the_corners() {
        // A 60 x 40 bright rectangle with corners at (20.5, 30.5) and (80.5, 70.5).
        let mut img = Image::new(100, 100);
        for v in 31..=70 {
            for u in 21..=80 {
                img.set(u, v, 180u8);
            }
        }
        let mut detector = LineDetector::new(DetectConfig::default());
        let mut lines = Vec::new();
        detector.detect(&img.view(), &mut lines);
        assert_eq!(lines.len(), 4);
        // Cut 8 px off both ends, then let the joining find the ends again.
        for l in &mut lines {
            let s = &mut l.segment;
            let len = s.length();
            let d = [(s.end[0] - s.start[0]) / len, (s.end[1] - s.start[1]) / len];
            s.start = [s.start[0] + 8.0 * d[0], s.start[1] + 8.0 * d[1]];
            s.end = [s.end[0] - 8.0 * d[0], s.end[1] - 8.0 * d[1]];
        }
        detector.join(&mut lines);
        let corners = [[20.5, 30.5], [80.5, 30.5], [80.5, 70.5], [20.5, 70.5]];
        for l in &lines {
            for e in [l.segment.start, l.segment.end] {
                let err = corners
                    .iter()
                    .map(|c: &[f32; 2]| (c[0] - e[0]).hypot(c[1] - e[1]))
                    .fold(f32::MAX, f32::min);
                assert!(err < 0.5, "endpoint {e:?} is {err} px from a corner");
            }
        }
    }
}
