//! Synthetic textured scenes rendered under known warps, for the invariance and
//! distribution tests.

#![allow(dead_code)] // each test binary uses part of the fixture

use gfs_core::GrayImage;

/// splitmix64: a tiny deterministic generator (no `rand` in the tree).
pub struct SplitMix(pub u64);

impl SplitMix {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[lo, hi)`.
    pub fn uniform(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * ((self.next_u64() >> 40) as f32 / (1u64 << 24) as f32)
    }
}

/// A scene: a raster of `size x size` scene units sampled `RES` times per unit.
pub struct Scene {
    size: usize,
    raster: Vec<f32>,
}

const RES: usize = 2;

impl Scene {
    /// Value-noise background plus `shapes` random rotated rectangles and discs of
    /// random gray levels over the whole `size x size` scene.
    pub fn textured(size: usize, seed: u64, shapes: usize) -> Self {
        let mut s = Self::noise(size, seed, 30.0, 16);
        s.add_noise(seed ^ 0x1234, 20.0, 6);
        s.add_shapes(seed ^ 0xABCD, shapes, 0.0, size as f32, 1.0);
        s
    }

    /// Smooth value noise of amplitude `amp` around 128 (lattice every `period` units).
    pub fn noise(size: usize, seed: u64, amp: f32, period: usize) -> Self {
        let mut s = Self {
            size,
            raster: vec![128.0; size * RES * size * RES],
        };
        s.add_noise(seed, amp, period);
        s
    }

    /// Adds value noise of amplitude `amp` with a lattice every `period` units.
    pub fn add_noise(&mut self, seed: u64, amp: f32, period: usize) {
        let n = self.size * RES;
        let cells = self.size / period + 2;
        let mut rng = SplitMix(seed);
        let lattice: Vec<f32> = (0..cells * cells).map(|_| rng.uniform(-1.0, 1.0)).collect();
        let raster = &mut self.raster;
        for y in 0..n {
            for x in 0..n {
                let (fx, fy) = (
                    x as f32 / (period * RES) as f32,
                    y as f32 / (period * RES) as f32,
                );
                let (ix, iy) = (fx as usize, fy as usize);
                let (tx, ty) = (smooth(fx - ix as f32), smooth(fy - iy as f32));
                let l = |i: usize, j: usize| lattice[j * cells + i];
                let top = l(ix, iy) * (1.0 - tx) + l(ix + 1, iy) * tx;
                let bottom = l(ix, iy + 1) * (1.0 - tx) + l(ix + 1, iy + 1) * tx;
                raster[y * n + x] += amp * (top * (1.0 - ty) + bottom * ty);
            }
        }
    }

    /// Paints `count` shapes with centres in `x_lo..x_hi` (scene units), gray levels
    /// `128 +- 127 * contrast`.
    pub fn add_shapes(&mut self, seed: u64, count: usize, x_lo: f32, x_hi: f32, contrast: f32) {
        let mut rng = SplitMix(seed);
        let n = self.size * RES;
        for _ in 0..count {
            let cx = rng.uniform(x_lo, x_hi) * RES as f32;
            let cy = rng.uniform(0.0, self.size as f32) * RES as f32;
            let value = 128.0 + contrast * rng.uniform(-110.0, 110.0);
            // A linear shade across the shape, up to +-15 gray levels.
            let (gx, gy) = (rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
            let disc = rng.next_u64().is_multiple_of(3);
            let (hw, hh) = (
                rng.uniform(3.0, 20.0) * RES as f32,
                rng.uniform(3.0, 20.0) * RES as f32,
            );
            let angle = rng.uniform(0.0, std::f32::consts::PI);
            let (sa, ca) = angle.sin_cos();
            let reach = hw.hypot(hh).ceil() as isize + 1;
            for y in (cy as isize - reach).max(0)..(cy as isize + reach).min(n as isize) {
                for x in (cx as isize - reach).max(0)..(cx as isize + reach).min(n as isize) {
                    let (dx, dy) = (x as f32 - cx, y as f32 - cy);
                    let inside = if disc {
                        dx * dx + dy * dy <= hw * hw
                    } else {
                        let (u, v) = (dx * ca + dy * sa, -dx * sa + dy * ca);
                        u.abs() <= hw && v.abs() <= hh
                    };
                    if inside {
                        let shade = 15.0 * (gx * dx / hw.max(hh) + gy * dy / hw.max(hh));
                        self.raster[y as usize * n + x as usize] = value + contrast * shade;
                    }
                }
            }
        }
    }

    /// Bilinear sample at scene point `(x, y)` (units), clamped at the border.
    fn sample(&self, x: f32, y: f32) -> f32 {
        let n = self.size * RES;
        let fx = (x * RES as f32 - 0.5).clamp(0.0, (n - 2) as f32);
        let fy = (y * RES as f32 - 0.5).clamp(0.0, (n - 2) as f32);
        let (ix, iy) = (fx as usize, fy as usize);
        let (tx, ty) = (fx - ix as f32, fy - iy as f32);
        let r = |i: usize, j: usize| self.raster[j * n + i];
        let top = r(ix, iy) * (1.0 - tx) + r(ix + 1, iy) * tx;
        let bottom = r(ix, iy + 1) * (1.0 - tx) + r(ix + 1, iy + 1) * tx;
        top * (1.0 - ty) + bottom * ty
    }

    /// A `w x h` image whose pixel `(u, v)` shows the scene at `warp(u, v)`, averaged over
    /// 4 sub-pixel samples (anti-aliasing).
    pub fn render(&self, w: usize, h: usize, warp: impl Fn(f32, f32) -> (f32, f32)) -> GrayImage {
        let mut data = Vec::with_capacity(w * h);
        for v in 0..h {
            for u in 0..w {
                let mut acc = 0.0;
                for (du, dv) in [(-0.25, -0.25), (0.25, -0.25), (-0.25, 0.25), (0.25, 0.25)] {
                    let (x, y) = warp(u as f32 + du, v as f32 + dv);
                    acc += self.sample(x, y);
                }
                data.push((acc / 4.0).round().clamp(0.0, 255.0) as u8);
            }
        }
        GrayImage::from_vec(w, h, data).expect("w * h pixels")
    }
}

fn smooth(t: f32) -> f32 {
    t * t * (3.0 - 2.0 * t)
}
