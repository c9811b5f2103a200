//! Synthetic fixtures for the detector tests: a deterministic PRNG with gaussian noise,
//! an antialiased polygon painter and the ground-truth comparison of segments.

use gfs_core::Image;

use crate::{DetectedLine, Segment};

/// splitmix64: small, deterministic, good enough for fixtures.
pub(crate) struct Rng(u64);

impl Rng {
    pub(crate) fn new(seed: u64) -> Self {
        Self(seed)
    }

    pub(crate) fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub(crate) fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [lo, hi).
    pub(crate) fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }

    /// Standard normal (Box-Muller).
    pub(crate) fn gaussian(&mut self) -> f64 {
        let u1 = self.uniform().max(1e-300);
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

/// A float canvas; pixel (u, v) covers [u - 0.5, u + 0.5] x [v - 0.5, v + 0.5].
pub(crate) struct Canvas {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<f64>,
}

/// Subsamples per pixel side for the antialiased coverage.
const SUPERSAMPLE: usize = 4;

impl Canvas {
    /// A canvas filled by `background(u, v)`.
    pub(crate) fn new(width: usize, height: usize, background: impl Fn(f64, f64) -> f64) -> Self {
        let mut pixels = Vec::with_capacity(width * height);
        for v in 0..height {
            for u in 0..width {
                pixels.push(background(u as f64, v as f64));
            }
        }
        Self {
            width,
            height,
            pixels,
        }
    }

    /// Paints the polygon `vertices` (any winding) with `value`, antialiased by coverage.
    pub(crate) fn fill_polygon(&mut self, vertices: &[[f64; 2]], value: f64) {
        let (mut lo_u, mut lo_v, mut hi_u, mut hi_v) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
        for p in vertices {
            lo_u = lo_u.min(p[0]);
            lo_v = lo_v.min(p[1]);
            hi_u = hi_u.max(p[0]);
            hi_v = hi_v.max(p[1]);
        }
        let u0 = (lo_u.floor() as isize - 1).max(0) as usize;
        let v0 = (lo_v.floor() as isize - 1).max(0) as usize;
        let u1 = ((hi_u.ceil() as isize + 1).max(0) as usize).min(self.width);
        let v1 = ((hi_v.ceil() as isize + 1).max(0) as usize).min(self.height);
        let s = SUPERSAMPLE as f64;
        for v in v0..v1 {
            for u in u0..u1 {
                let mut inside = 0;
                for sy in 0..SUPERSAMPLE {
                    for sx in 0..SUPERSAMPLE {
                        let x = u as f64 - 0.5 + (sx as f64 + 0.5) / s;
                        let y = v as f64 - 0.5 + (sy as f64 + 0.5) / s;
                        inside += usize::from(contains(vertices, x, y));
                    }
                }
                let cover = inside as f64 / (s * s);
                let p = &mut self.pixels[v * self.width + u];
                *p = *p * (1.0 - cover) + value * cover;
            }
        }
    }

    /// The 8-bit image with gaussian noise of `sigma` added.
    pub(crate) fn to_gray(&self, sigma: f64, rng: &mut Rng) -> Image<u8> {
        let data = self
            .pixels
            .iter()
            .map(|&p| (p + sigma * rng.gaussian()).round().clamp(0.0, 255.0) as u8)
            .collect();
        Image::from_vec(self.width, self.height, data).unwrap()
    }
}

/// Even-odd point-in-polygon test.
fn contains(poly: &[[f64; 2]], x: f64, y: f64) -> bool {
    let mut inside = false;
    let mut j = poly.len() - 1;
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[j]);
        if (a[1] > y) != (b[1] > y) && x < (b[0] - a[0]) * (y - a[1]) / (b[1] - a[1]) + a[0] {
            inside = !inside;
        }
        j = i;
    }
    inside
}

/// Corners of a rectangle centred at `c`, sides `w` x `h`, rotated by `angle` radians.
pub(crate) fn rectangle(c: [f64; 2], w: f64, h: f64, angle: f64) -> [[f64; 2]; 4] {
    let (s, co) = angle.sin_cos();
    let corner = |x: f64, y: f64| [c[0] + co * x - s * y, c[1] + s * x + co * y];
    [
        corner(-w / 2.0, -h / 2.0),
        corner(w / 2.0, -h / 2.0),
        corner(w / 2.0, h / 2.0),
        corner(-w / 2.0, h / 2.0),
    ]
}

/// The detections lying on the ground-truth segment `truth`: angle within 5 degrees and
/// both endpoints within 2 px of its line.
pub(crate) fn on_truth<'a>(
    truth: &Segment,
    found: &'a [DetectedLine],
) -> impl Iterator<Item = &'a DetectedLine> {
    let [a, b, c] = truth.line_coefficients();
    let t = truth.angle();
    found.iter().filter(move |d| {
        let s = &d.segment;
        let mut diff = (s.angle() - t).rem_euclid(std::f32::consts::PI);
        diff = diff.min(std::f32::consts::PI - diff);
        let off = |e: [f32; 2]| (a * e[0] + b * e[1] + c).abs();
        diff < 5f32.to_radians() && off(s.start) < 2.0 && off(s.end) < 2.0
    })
}

/// Fraction of `truth` covered by the projections of `pieces` (union of intervals).
pub(crate) fn coverage<'a>(truth: &Segment, pieces: impl Iterator<Item = &'a DetectedLine>) -> f32 {
    let len = truth.length();
    let d = [
        (truth.end[0] - truth.start[0]) / len,
        (truth.end[1] - truth.start[1]) / len,
    ];
    let along = |e: [f32; 2]| (e[0] - truth.start[0]) * d[0] + (e[1] - truth.start[1]) * d[1];
    let mut spans: Vec<(f32, f32)> = pieces
        .map(|p| {
            let (t0, t1) = (along(p.segment.start), along(p.segment.end));
            (t0.min(t1).max(0.0), t0.max(t1).min(len))
        })
        .filter(|(lo, hi)| hi > lo)
        .collect();
    spans.sort_by(|p, q| p.0.total_cmp(&q.0));
    let (mut covered, mut reach) = (0.0, 0.0f32);
    for (lo, hi) in spans {
        let lo = lo.max(reach);
        if hi > lo {
            covered += hi - lo;
            reach = hi;
        }
    }
    covered / len
}

/// Distances of the two ground-truth endpoints to the nearest endpoint of `found`.
pub(crate) fn endpoint_errors(truth: &Segment, found: &Segment) -> [f32; 2] {
    let dist = |p: [f32; 2], q: [f32; 2]| (p[0] - q[0]).hypot(p[1] - q[1]);
    let nearest = |p: [f32; 2]| dist(p, found.start).min(dist(p, found.end));
    [nearest(truth.start), nearest(truth.end)]
}
