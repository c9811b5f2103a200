//! Procedural surface textures, evaluated in a surface's own 2D coordinates (metres), so
//! that the pattern is fixed on the surface whatever the camera does.
//!
//! Each sample also returns a *region key*: an integer that changes exactly where the
//! texture has a sharp discontinuity (tile grout, poster block, glyph stroke, book). The
//! renderer supersamples only the pixels whose neighbours differ in key, which gives
//! camera-like antialiased edges at a fraction of the cost of supersampling everything.

use crate::rng::{floor, hash, lattice};

/// Linear colour, each channel in [0, 1].
pub type Rgb = [f32; 3];

/// A procedural texture. Coordinates `(s, t)` are metres along the surface's two axes
/// (`t` is "up" on walls).
#[derive(Clone, Debug)]
pub enum Texture {
    /// Paint: a colour modulated by smooth value noise of relative `amplitude` with
    /// features about `scale` metres wide.
    Paint {
        /// Mean colour.
        color: Rgb,
        /// Relative brightness variation (0 = perfectly plain).
        amplitude: f32,
        /// Feature size, metres.
        scale: f64,
        /// Noise seed.
        seed: u64,
    },
    /// Two colours in soft-edged blobs (thresholded value noise): camouflage / stone.
    Blobs {
        /// Background colour.
        a: Rgb,
        /// Blob colour.
        b: Rgb,
        /// Blob size, metres.
        scale: f64,
        /// Noise seed.
        seed: u64,
    },
    /// Wood grain: stripes along `t`, `period` metres apart across `s`, wobbled by noise.
    Wood {
        /// Light wood colour.
        light: Rgb,
        /// Dark grain colour.
        dark: Rgb,
        /// Grain spacing, metres.
        period: f64,
        /// Noise seed.
        seed: u64,
    },
    /// Square tiles of `size` metres separated by `grout` metres of grout; each tile
    /// blends `a` and `b` by a per-tile random weight.
    Tiles {
        /// Tile pitch, metres.
        size: f64,
        /// Grout width, metres.
        grout: f64,
        /// First tile colour.
        a: Rgb,
        /// Second tile colour.
        b: Rgb,
        /// Grout colour.
        grout_color: Rgb,
        /// Seed of the per-tile colours.
        seed: u64,
    },
    /// Running-bond bricks with mortar joints; per-brick colour variation.
    Bricks {
        /// Brick length, metres.
        width: f64,
        /// Brick height, metres.
        height: f64,
        /// Mortar width, metres.
        mortar: f64,
        /// Mean brick colour.
        color: Rgb,
        /// Mortar colour.
        mortar_color: Rgb,
        /// Seed of the per-brick colours.
        seed: u64,
    },
    /// Book spines on shelf boards, `shelf` metres apart.
    Books {
        /// Distance between shelf boards, metres.
        shelf: f64,
        /// Seed of book widths, heights and colours.
        seed: u64,
    },
    /// A poster: a background with coloured blocks and text-like glyph lines.
    Poster(Poster),
    /// A window view: a vertical sky gradient over `height` metres above a skyline of
    /// distant buildings with window grids (so a window is not a textureless hole).
    Glass {
        /// Sky colour at the top.
        top: Rgb,
        /// Sky colour at the bottom.
        bottom: Rgb,
        /// Height of the pane, metres.
        height: f64,
        /// Seed of the skyline.
        seed: u64,
    },
}

/// Content of a [`Texture::Poster`]; later items are drawn over earlier ones.
#[derive(Clone, Debug)]
pub struct Poster {
    /// Background colour.
    pub background: Rgb,
    /// Blocks and text, in poster coordinates (metres from the poster's corner).
    pub items: Vec<PosterItem>,
}

/// One element of a poster.
#[derive(Clone, Debug)]
pub enum PosterItem {
    /// A filled rectangle `[s0, t0, s1, t1]`.
    Block {
        /// Rectangle `[s0, t0, s1, t1]`, metres.
        rect: [f64; 4],
        /// Fill colour.
        color: Rgb,
    },
    /// Lines of 3x5 glyphs filling `rect` from the top, each `line` metres high.
    Text {
        /// Rectangle `[s0, t0, s1, t1]`, metres.
        rect: [f64; 4],
        /// Line pitch, metres.
        line: f64,
        /// Ink colour.
        ink: Rgb,
        /// Seed of the glyphs and line lengths.
        seed: u64,
    },
}

/// A 3x5 pixel font (digits and a few capitals), row-major from the top-left, one bit
/// per cell (bit 14 = top-left). Enough to make text-like strokes with real corners.
const GLYPHS: [u16; 16] = [
    0b111_101_101_101_111, // 0
    0b010_110_010_010_111, // 1
    0b111_001_111_100_111, // 2
    0b111_001_111_001_111, // 3
    0b101_101_111_001_001, // 4
    0b111_100_111_001_111, // 5
    0b111_100_111_101_111, // 6
    0b111_001_010_010_010, // 7
    0b111_101_111_101_111, // 8
    0b111_101_111_001_111, // 9
    0b010_101_111_101_101, // A
    0b111_100_110_100_111, // E
    0b101_101_111_101_101, // H
    0b100_100_100_100_111, // L
    0b111_010_010_010_010, // T
    0b111_100_110_100_100, // F
];

impl Texture {
    /// Colour and region key at surface coordinates `(s, t)` metres.
    pub fn sample(&self, s: f64, t: f64) -> (Rgb, u32) {
        match self {
            Texture::Paint {
                color,
                amplitude,
                scale,
                seed,
            } => {
                let n = fbm(*seed, s / scale, t / scale) as f32 - 0.5;
                (scale_rgb(*color, 1.0 + 2.0 * amplitude * n), 0)
            }
            Texture::Blobs { a, b, scale, seed } => {
                let n = fbm(*seed, s / scale, t / scale);
                // Soft threshold: a few millimetres of blend at typical viewing distances.
                let w = smoothstep(0.47, 0.53, n) as f32;
                let shade = 0.9 + 0.2 * value_noise(seed ^ 1, s * 40.0, t * 40.0) as f32;
                (scale_rgb(lerp_rgb(*a, *b, w), shade), 0)
            }
            Texture::Wood {
                light,
                dark,
                period,
                seed,
            } => {
                // Grain runs along t (up on doors and furniture fronts), wobbling across.
                let wobble = 1.5 * fbm(*seed, s * 3.0, t * 0.8);
                let phase = (s / period + wobble) * std::f64::consts::TAU;
                let w = 0.7 * ((0.5 + 0.5 * phase.sin()).powi(2) as f32);
                (lerp_rgb(*light, *dark, w), 0)
            }
            Texture::Tiles {
                size,
                grout,
                a,
                b,
                grout_color,
                seed,
            } => {
                let (i, j) = (floor(s / size), floor(t / size));
                let (fs, ft) = (s - i * size, t - j * size);
                if fs < *grout || ft < *grout {
                    return (*grout_color, 1);
                }
                let w = lattice(*seed, i as i64, j as i64) as f32;
                let speckle = 0.94 + 0.12 * value_noise(seed ^ 7, s * 30.0, t * 30.0) as f32;
                let key = 2 + (hash(*seed, &[i as u64, j as u64]) as u32 & 0xFFFF);
                (scale_rgb(lerp_rgb(*a, *b, w), speckle), key)
            }
            Texture::Bricks {
                width,
                height,
                mortar,
                color,
                mortar_color,
                seed,
            } => {
                let row = floor(t / height);
                let offset = if row as i64 % 2 == 0 {
                    0.0
                } else {
                    0.5 * width
                };
                let col = floor((s + offset) / width);
                let (fs, ft) = (s + offset - col * width, t - row * height);
                if fs < *mortar || ft < *mortar {
                    return (*mortar_color, 1);
                }
                let r = lattice(*seed, col as i64, row as i64) as f32;
                let grain = 0.92 + 0.16 * value_noise(seed ^ 3, s * 25.0, t * 25.0) as f32;
                let key = 2 + (hash(*seed, &[col as u64, row as u64]) as u32 & 0xFFFF);
                (scale_rgb(*color, (0.75 + 0.5 * r) * grain), key)
            }
            Texture::Books { shelf, seed } => books(*shelf, *seed, s, t),
            Texture::Poster(poster) => poster.sample(s, t),
            Texture::Glass {
                top,
                bottom,
                height,
                seed,
            } => skyline(*top, *bottom, *height, *seed, s, t),
        }
    }
}

/// Book spines: per shelf, a board at the bottom, books of random width / height /
/// colour standing on it, and the dark back of the shelf above them.
fn books(shelf: f64, seed: u64, s: f64, t: f64) -> (Rgb, u32) {
    const BOARD: f64 = 0.025;
    const SLOT: f64 = 0.03;
    const PALETTE: [Rgb; 6] = [
        [0.65, 0.12, 0.10],
        [0.10, 0.25, 0.55],
        [0.85, 0.75, 0.35],
        [0.15, 0.45, 0.20],
        [0.90, 0.90, 0.85],
        [0.30, 0.20, 0.15],
    ];
    let row = floor(t / shelf);
    let ft = t - row * shelf;
    if ft < BOARD {
        return ([0.55, 0.40, 0.25], 1);
    }
    let slot = floor(s / SLOT);
    let h = hash(seed, &[row as u64, slot as u64]);
    let book_top = BOARD + shelf * (0.55 + 0.35 * ((h & 0xFF) as f64 / 255.0));
    let key = 2 + ((h >> 8) as u32 & 0xFFFF) * 2;
    if ft > book_top {
        return ([0.08, 0.07, 0.06], key + 1);
    }
    let base = PALETTE[((h >> 24) % PALETTE.len() as u64) as usize];
    let shade = 0.7 + 0.5 * ((h >> 32) & 0xFF) as f32 / 255.0;
    (scale_rgb(base, shade), key)
}

/// Sky gradient over buildings 0.2 m wide (as seen in the pane) with lit and dark
/// window cells.
fn skyline(top: Rgb, bottom: Rgb, height: f64, seed: u64, s: f64, t: f64) -> (Rgb, u32) {
    const BUILDING: f64 = 0.2;
    const CELL: [f64; 2] = [0.035, 0.05];
    let col = floor(s / BUILDING);
    let h = hash(seed, &[col as u64]);
    let roof = height * (0.15 + 0.45 * (h & 0xFFFF) as f64 / 65535.0);
    if t >= roof {
        let w = (t / height).clamp(0.0, 1.0) as f32;
        return (lerp_rgb(bottom, top, w), 0);
    }
    let key = 1 + 4 * ((h >> 16) as u32 & 0xFFFF);
    let grey = 0.35 + 0.3 * ((h >> 32) & 0xFF) as f32 / 255.0;
    let (fs, ft) = (s - col * BUILDING, t);
    let (ci, cj) = (floor(fs / CELL[0]), floor(ft / CELL[1]));
    let (us, ut) = (fs / CELL[0] - ci, ft / CELL[1] - cj);
    let margin = !(0.02..=BUILDING - 0.02).contains(&fs) || t > roof - 0.03;
    if margin || !(0.3..0.8).contains(&us) || !(0.25..0.75).contains(&ut) {
        return ([grey, grey, grey * 1.05], key);
    }
    let lit = hash(seed, &[col as u64, ci as u64, cj as u64]).is_multiple_of(3);
    let window = if lit {
        [0.95, 0.85, 0.55]
    } else {
        [0.15, 0.2, 0.28]
    };
    (window, key + 1 + lit as u32)
}

impl Poster {
    fn sample(&self, s: f64, t: f64) -> (Rgb, u32) {
        let mut out = (self.background, 0);
        for (k, item) in self.items.iter().enumerate() {
            let key = 2 * (k as u32 + 1);
            match item {
                PosterItem::Block { rect, color } => {
                    if inside(rect, s, t) {
                        out = (*color, key);
                    }
                }
                PosterItem::Text {
                    rect,
                    line,
                    ink,
                    seed,
                } => {
                    if inside(rect, s, t) && glyph_ink(rect, *line, *seed, s, t) {
                        out = (*ink, key + 1);
                    }
                }
            }
        }
        out
    }
}

/// True when `(s, t)` falls on a stroke of the glyph text filling `rect`.
fn glyph_ink(rect: &[f64; 4], line: f64, seed: u64, s: f64, t: f64) -> bool {
    let from_top = rect[3] - t;
    let li = floor(from_top / line);
    // Glyphs take 70 % of the line height; the rest is leading.
    let y = (from_top - li * line) / (0.7 * line);
    let cell_w = 0.55 * line;
    let ci = floor((s - rect[0]) / cell_w);
    let x = (s - rect[0] - ci * cell_w) / cell_w;
    let h = hash(seed, &[li as u64, ci as u64]);
    let line_len = 6 + hash(seed, &[li as u64]) % 30;
    // Only whole glyphs: the line and the character must fit inside the rectangle.
    let fits = (li + 0.7) * line <= rect[3] - rect[1] && (ci + 0.75) * cell_w <= rect[2] - rect[0];
    if !fits
        || !(0.0..1.0).contains(&y)
        || x >= 0.75
        || ci as u64 >= line_len
        || h.is_multiple_of(7)
    {
        return false; // cut glyph, leading, letter gap, end of line, or a word space
    }
    let (gx, gy) = ((x / 0.25) as u32, (y * 5.0) as u32);
    let glyph = GLYPHS[(h >> 8) as usize % GLYPHS.len()];
    glyph >> (14 - (gy * 3 + gx)) & 1 == 1
}

fn inside(rect: &[f64; 4], s: f64, t: f64) -> bool {
    s >= rect[0] && s < rect[2] && t >= rect[1] && t < rect[3]
}

/// Smooth value noise in [0, 1] on a unit lattice.
pub fn value_noise(seed: u64, x: f64, y: f64) -> f64 {
    let (x0, y0) = (floor(x), floor(y));
    let (fx, fy) = (x - x0, y - y0);
    let (i, j) = (x0 as i64, y0 as i64);
    let (sx, sy) = (fx * fx * (3.0 - 2.0 * fx), fy * fy * (3.0 - 2.0 * fy));
    let a = lattice(seed, i, j);
    let b = lattice(seed, i + 1, j);
    let c = lattice(seed, i, j + 1);
    let d = lattice(seed, i + 1, j + 1);
    let top = a + (b - a) * sx;
    let bottom = c + (d - c) * sx;
    top + (bottom - top) * sy
}

/// Three octaves of value noise, in [0, 1].
pub fn fbm(seed: u64, x: f64, y: f64) -> f64 {
    (4.0 * value_noise(seed, x, y)
        + 2.0 * value_noise(seed ^ 0xA5A5, 2.03 * x, 2.03 * y)
        + value_noise(seed ^ 0x5A5A, 4.11 * x, 4.11 * y))
        / 7.0
}

fn smoothstep(lo: f64, hi: f64, x: f64) -> f64 {
    let t = ((x - lo) / (hi - lo)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// `a + (b - a) * w`, per channel.
pub fn lerp_rgb(a: Rgb, b: Rgb, w: f32) -> Rgb {
    [
        a[0] + (b[0] - a[0]) * w,
        a[1] + (b[1] - a[1]) * w,
        a[2] + (b[2] - a[2]) * w,
    ]
}

/// `c * k`, per channel.
pub fn scale_rgb(c: Rgb, k: f32) -> Rgb {
    [c[0] * k, c[1] * k, c[2] * k]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiles_have_grout_lines_and_distinct_keys() {
        let tex = Texture::Tiles {
            size: 0.5,
            grout: 0.01,
            a: [0.8; 3],
            b: [0.5; 3],
            grout_color: [0.2; 3],
            seed: 1,
        };
        assert_eq!(tex.sample(0.505, 0.2), ([0.2; 3], 1));
        let (_, k1) = tex.sample(0.2, 0.2);
        let (_, k2) = tex.sample(0.7, 0.2);
        assert!(k1 >= 2 && k2 >= 2 && k1 != k2);
    }

    #[test]
    fn glyph_text_covers_a_reasonable_fraction() {
        let rect = [0.0, 0.0, 0.5, 0.3];
        let mut ink = 0;
        let n = 200;
        for i in 0..n {
            for j in 0..n {
                let (s, t) = (0.5 * i as f64 / n as f64, 0.3 * j as f64 / n as f64);
                ink += glyph_ink(&rect, 0.03, 5, s, t) as usize;
            }
        }
        let fraction = ink as f64 / (n * n) as f64;
        assert!((0.05..0.5).contains(&fraction), "ink fraction {fraction}");
    }

    #[test]
    fn noise_stays_in_unit_range() {
        for i in 0..1000 {
            let v = fbm(3, i as f64 * 0.137, i as f64 * 0.071);
            assert!((0.0..=1.0).contains(&v));
        }
    }
}
