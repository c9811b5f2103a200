//! Test fixtures shared by the unit tests: a reproducible PRNG, a textured scene of
//! rectangles with known edges, a similarity warp and a renderer.

use gfs_core::Image;

/// splitmix64, for reproducible fixtures.
pub(crate) struct Rng(pub(crate) u64);

impl Rng {
    /// Uniform in [0, 1).
    pub(crate) fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }
}

pub(crate) const W: usize = 640;
pub(crate) const H: usize = 480;
const TILE: f32 = 80.0;
const LATTICE: f32 = 24.0;

/// A textured scene: smooth value noise plus one bright or dark rectangle per
/// 80 x 80 tile. Returns the intensity function's data and the rectangle edges.
pub(crate) struct Scene {
    noise: Vec<f32>,
    noise_cols: usize,
    rects: Vec<([f32; 4], f32)>,
}

impl Scene {
    pub(crate) fn new(rng: &mut Rng) -> Self {
        let noise_cols = (W as f32 / LATTICE) as usize + 8;
        let noise_rows = (H as f32 / LATTICE) as usize + 8;
        let noise = (0..noise_cols * noise_rows)
            .map(|_| 60.0 + 130.0 * rng.next())
            .collect();
        let mut rects = Vec::new();
        for ty in 0..(H as f32 / TILE) as usize {
            for tx in 0..(W as f32 / TILE) as usize {
                let (ox, oy) = (tx as f32 * TILE, ty as f32 * TILE);
                let x0 = ox + 6.0 + 20.0 * rng.next();
                let y0 = oy + 6.0 + 20.0 * rng.next();
                let x1 = x0 + 30.0 + (ox + TILE - 6.0 - x0 - 30.0) * rng.next();
                let y1 = y0 + 30.0 + (oy + TILE - 6.0 - y0 - 30.0) * rng.next();
                let sign = if rng.next() < 0.5 { -1.0 } else { 1.0 };
                rects.push(([x0, y0, x1, y1], sign * (40.0 + 50.0 * rng.next())));
            }
        }
        Self {
            noise,
            noise_cols,
            rects,
        }
    }

    pub(crate) fn intensity(&self, x: f32, y: f32) -> f32 {
        // Bilinear value noise (shifted so that slightly negative x, y stay inside).
        let (gx, gy) = (x / LATTICE + 4.0, y / LATTICE + 4.0);
        let (ix, iy) = (gx.floor().max(0.0) as usize, gy.floor().max(0.0) as usize);
        let (fx, fy) = (gx - ix as f32, gy - iy as f32);
        let at = |c: usize, r: usize| {
            let c = c.min(self.noise_cols - 1);
            self.noise[(r * self.noise_cols + c).min(self.noise.len() - 1)]
        };
        let mut value = (1.0 - fy) * ((1.0 - fx) * at(ix, iy) + fx * at(ix + 1, iy))
            + fy * ((1.0 - fx) * at(ix, iy + 1) + fx * at(ix + 1, iy + 1));
        let (tx, ty) = ((x / TILE).floor(), (y / TILE).floor());
        let per_row = (W as f32 / TILE) as usize;
        if tx >= 0.0 && ty >= 0.0 && (tx as usize) < per_row && (ty as usize) < H / TILE as usize {
            let (r, delta) = self.rects[ty as usize * per_row + tx as usize];
            if x >= r[0] && x < r[2] && y >= r[1] && y < r[3] {
                value += delta;
            }
        }
        value
    }
}

/// Similarity about the image centre: rotation `angle`, scale `scale`, shift `t`.
#[derive(Clone, Copy)]
pub(crate) struct Warp {
    pub(crate) angle: f32,
    pub(crate) scale: f32,
    pub(crate) t: [f32; 2],
}

impl Warp {
    pub(crate) fn apply(&self, p: [f32; 2]) -> [f32; 2] {
        let (c, s) = (self.angle.cos() * self.scale, self.angle.sin() * self.scale);
        let (x, y) = (p[0] - W as f32 / 2.0, p[1] - H as f32 / 2.0);
        [
            c * x - s * y + W as f32 / 2.0 + self.t[0],
            s * x + c * y + H as f32 / 2.0 + self.t[1],
        ]
    }

    pub(crate) fn inverse(&self, p: [f32; 2]) -> [f32; 2] {
        let (c, s) = (self.angle.cos() / self.scale, self.angle.sin() / self.scale);
        let (x, y) = (
            p[0] - W as f32 / 2.0 - self.t[0],
            p[1] - H as f32 / 2.0 - self.t[1],
        );
        [
            c * x + s * y + W as f32 / 2.0,
            -s * x + c * y + H as f32 / 2.0,
        ]
    }
}

impl Rng {
    /// Uniform in [0, 1), double precision.
    pub(crate) fn uniform(&mut self) -> f64 {
        f64::from(self.next()) + f64::from(self.next()) / f64::from(1u32 << 24)
    }

    /// Standard normal (Box-Muller).
    pub(crate) fn gaussian(&mut self) -> f64 {
        let (a, b) = (self.uniform().max(1e-12), self.uniform());
        (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
    }
}

/// Renders the scene seen through `warp` (3 x 3 supersampling, noise sigma ~3).
pub(crate) fn render(scene: &Scene, warp: &Warp, rng: &mut Rng) -> Image<u8> {
    let mut img = Image::<u8>::new(W, H);
    for v in 0..H {
        for u in 0..W {
            let mut sum = 0.0;
            for j in 0..3 {
                for i in 0..3 {
                    let p = [
                        u as f32 + (i as f32 - 1.0) / 3.0,
                        v as f32 + (j as f32 - 1.0) / 3.0,
                    ];
                    let q = warp.inverse(p);
                    sum += scene.intensity(q[0], q[1]);
                }
            }
            // Sum of 4 uniforms: mean 2, variance 1/3 -> sigma 3 after x 5.2.
            let noise = (rng.next() + rng.next() + rng.next() + rng.next() - 2.0) * 5.2;
            img.set(u, v, (sum / 9.0 + noise).clamp(0.0, 255.0).round() as u8);
        }
    }
    img
}
