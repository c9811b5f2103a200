//! Reusable parts of the scenes: the room shell, walls and what hangs on them (doors,
//! windows, framed posters), and random poster content.

use crate::rng::SplitMix64;
use crate::scene::{Aabb, BoxLook, EdgeKind, SceneBuilder};
use crate::texture::{Poster, PosterItem, Rgb, Texture};
use nalgebra::{Point3, Vector3};

/// How far flat panels (posters, door leaves) stand off their wall, metres: enough to
/// never tie with the wall in depth, small enough to read as "on the wall".
pub const PANEL_OFFSET: f64 = 0.004;

/// A wall of the room seen from inside: wall coordinates `(s, t, d)` are metres along
/// the wall (`u = z x n`), up, and out of the wall into the room.
#[derive(Clone, Copy)]
pub struct Wall {
    origin: Point3<f64>,
    u: Vector3<f64>,
    n: Vector3<f64>,
}

impl Wall {
    /// The world point at wall coordinates `(s, t, d)`.
    pub fn at(&self, s: f64, t: f64, d: f64) -> Point3<f64> {
        self.origin + self.u * s + Vector3::z() * t + self.n * d
    }

    fn yaw(&self) -> f64 {
        self.u.y.atan2(self.u.x)
    }
}

/// The four walls of the box `bounds`, in the order south (y = min), east (x = max),
/// north (y = max), west (x = min); each wall's `s` runs along `z x n` (left to right
/// seen from inside the room).
pub fn walls(bounds: &Aabb) -> [Wall; 4] {
    let (a, b) = (bounds.min, bounds.max);
    let wall = |origin: Point3<f64>, n: Vector3<f64>| Wall {
        origin,
        u: Vector3::z().cross(&n),
        n,
    };
    [
        wall(Point3::new(b.x, a.y, a.z), Vector3::y()),
        wall(Point3::new(b.x, b.y, a.z), -Vector3::x()),
        wall(Point3::new(a.x, b.y, a.z), -Vector3::y()),
        wall(Point3::new(a.x, a.y, a.z), Vector3::x()),
    ]
}

/// The room shell: four walls (textures in [`walls`] order), floor and ceiling facing
/// inward, and the twelve room-corner edges.
pub fn shell(
    b: &mut SceneBuilder,
    bounds: &Aabb,
    wall_textures: [usize; 4],
    floor: usize,
    ceiling: usize,
) {
    let size = bounds.max - bounds.min;
    let center = bounds.center();
    for (wall, texture) in walls(bounds).iter().zip(wall_textures) {
        let length = if wall.n.x.abs() > 0.5 { size.y } else { size.x };
        let c = center - wall.n * (0.5 * if wall.n.x.abs() > 0.5 { size.x } else { size.y });
        b.panel(c, wall.n, [length, size.z], texture, None);
    }
    b.panel(
        Point3::new(center.x, center.y, bounds.min.z),
        Vector3::z(),
        [size.x, size.y],
        floor,
        None,
    );
    b.panel(
        Point3::new(center.x, center.y, bounds.max.z),
        -Vector3::z(),
        [size.x, size.y],
        ceiling,
        None,
    );
    let (lo, hi) = (bounds.min, bounds.max);
    let corner = |i: usize| {
        Point3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    };
    for i in 0..8usize {
        for bit in [1, 2, 4] {
            if i & bit == 0 {
                b.edge(corner(i), corner(i | bit), EdgeKind::Crease);
            }
        }
    }
}

/// A box against `wall`: `s0..s1` along it, `t0..t1` up, `depth` metres into the room.
pub fn wall_box(
    b: &mut SceneBuilder,
    wall: &Wall,
    [s0, s1]: [f64; 2],
    [t0, t1]: [f64; 2],
    depth: f64,
    look: BoxLook,
) {
    b.solid_box(
        wall.at(0.5 * (s0 + s1), t0, 0.5 * depth),
        [s1 - s0, depth, t1 - t0],
        wall.yaw(),
        look,
    );
}

/// A skirting board 9 cm high and 1.5 cm deep along `wall` from `s = 0` to `length`,
/// interrupted by the `gaps` (sorted `[s0, s1]` ranges, e.g. door frames).
pub fn skirting(b: &mut SceneBuilder, wall: &Wall, length: f64, gaps: &[[f64; 2]], look: BoxLook) {
    let mut start = 0.0;
    for gap in gaps.iter().chain(std::iter::once(&[length, length])) {
        if gap[0] > start {
            wall_box(b, wall, [start, gap[0]], [0.0, 0.09], 0.015, look);
        }
        start = gap[1];
    }
}

/// A flat panel on `wall` over `s0..s1`, `t0..t1`, standing `d` metres off it, with its
/// outline as ground-truth edges. Returns the world corner of its texture origin.
pub fn wall_panel(
    b: &mut SceneBuilder,
    wall: &Wall,
    [s0, s1]: [f64; 2],
    [t0, t1]: [f64; 2],
    d: f64,
    texture: usize,
) -> Point3<f64> {
    b.panel(
        wall.at(0.5 * (s0 + s1), 0.5 * (t0 + t1), d),
        wall.n,
        [s1 - s0, t1 - t0],
        texture,
        Some(EdgeKind::Border),
    );
    wall.at(s0, t0, d)
}

/// The bars of a frame around an opening: `width` wide along the wall, `depth` out of
/// it; three sides without `bottom` (a door's).
#[derive(Clone, Copy)]
pub struct FrameBars {
    /// Width of a bar along the wall, metres.
    pub width: f64,
    /// How far the bars stand out of the wall, metres.
    pub depth: f64,
    /// The bars' faces.
    pub look: BoxLook,
    /// Whether the opening has a bottom bar.
    pub bottom: bool,
}

/// A frame of four (or three) boxes around the opening `s0..s1`, `t0..t1` of `wall`.
pub fn frame(
    b: &mut SceneBuilder,
    wall: &Wall,
    [s0, s1]: [f64; 2],
    [t0, t1]: [f64; 2],
    bars: FrameBars,
) {
    let FrameBars {
        width,
        depth,
        look,
        bottom,
    } = bars;
    let tb = if bottom { t0 - width } else { t0 };
    wall_box(b, wall, [s0 - width, s0], [tb, t1 + width], depth, look);
    wall_box(b, wall, [s1, s1 + width], [tb, t1 + width], depth, look);
    wall_box(b, wall, [s0, s1], [t1, t1 + width], depth, look);
    if bottom {
        wall_box(b, wall, [s0, s1], [t0 - width, t0], depth, look);
    }
}

/// A door: wooden leaf with outline, a three-sided frame and a handle.
pub fn door(
    b: &mut SceneBuilder,
    wall: &Wall,
    [s0, s1]: [f64; 2],
    height: f64,
    leaf: usize,
    frame_look: BoxLook,
    handle: usize,
) {
    wall_panel(b, wall, [s0, s1], [0.0, height], 2.0 * PANEL_OFFSET, leaf);
    frame(
        b,
        wall,
        [s0, s1],
        [0.0, height],
        FrameBars {
            width: 0.07,
            depth: 0.035,
            look: frame_look,
            bottom: false,
        },
    );
    wall_box(
        b,
        wall,
        [s1 - 0.17, s1 - 0.05],
        [0.98, 1.02],
        0.06,
        BoxLook::all(handle),
    );
}

/// A window: glass pane, a four-sided frame, a vertical mullion and a deep sill.
pub fn window(
    b: &mut SceneBuilder,
    wall: &Wall,
    s: [f64; 2],
    t: [f64; 2],
    glass: usize,
    frame_look: BoxLook,
) {
    wall_panel(b, wall, s, t, PANEL_OFFSET, glass);
    frame(
        b,
        wall,
        s,
        t,
        FrameBars {
            width: 0.06,
            depth: 0.05,
            look: frame_look,
            bottom: true,
        },
    );
    let mid = 0.5 * (s[0] + s[1]);
    wall_box(b, wall, [mid - 0.02, mid + 0.02], t, 0.03, frame_look);
    wall_box(
        b,
        wall,
        [s[0] - 0.1, s[1] + 0.1],
        [t[0] - 0.1, t[0] - 0.06],
        0.16,
        frame_look,
    );
}

/// A poster (or picture) on `wall`, optionally framed; its blocks become
/// [`EdgeKind::Border`] ground-truth edges.
pub fn poster(
    b: &mut SceneBuilder,
    wall: &Wall,
    s: [f64; 2],
    t: [f64; 2],
    texture: Texture,
    frame_look: Option<BoxLook>,
) {
    let blocks: Vec<[f64; 4]> = match &texture {
        Texture::Poster(p) => p
            .items
            .iter()
            .filter_map(|item| match item {
                PosterItem::Block { rect, .. } => Some(*rect),
                PosterItem::Text { .. } => None,
            })
            .collect(),
        _ => Vec::new(),
    };
    let texture = b.texture(texture);
    wall_panel(b, wall, s, t, PANEL_OFFSET, texture);
    for r in blocks {
        let p = |ps: f64, pt: f64| wall.at(s[0] + ps, t[0] + pt, PANEL_OFFSET);
        let c = [p(r[0], r[1]), p(r[2], r[1]), p(r[2], r[3]), p(r[0], r[3])];
        for k in 0..4 {
            b.edge(c[k], c[(k + 1) % 4], EdgeKind::Border);
        }
    }
    if let Some(look) = frame_look {
        frame(
            b,
            wall,
            s,
            t,
            FrameBars {
                width: 0.035,
                depth: 0.025,
                look,
                bottom: true,
            },
        );
    }
}

/// Random poster content for a `w x h` metre poster: a background, two to four colour
/// blocks that do not overlap, and a few lines of glyph text.
pub fn poster_texture(rng: &mut SplitMix64, w: f64, h: f64) -> Texture {
    const COLOURS: [Rgb; 8] = [
        [0.85, 0.15, 0.12],
        [0.10, 0.30, 0.70],
        [0.95, 0.80, 0.15],
        [0.12, 0.55, 0.25],
        [0.95, 0.95, 0.92],
        [0.08, 0.08, 0.10],
        [0.90, 0.45, 0.10],
        [0.45, 0.20, 0.55],
    ];
    let pick = |rng: &mut SplitMix64| COLOURS[rng.below(COLOURS.len() as u64) as usize];
    let dark = rng.uniform() < 0.4;
    let background = if dark {
        [0.12, 0.13, 0.18]
    } else {
        [0.93, 0.91, 0.86]
    };
    let ink = if dark {
        [0.95, 0.93, 0.85]
    } else {
        [0.08, 0.08, 0.1]
    };
    let mut items = Vec::new();
    // Columns of content from the top: a headline, blocks side by side, body text.
    let margin = 0.06 * w.min(h);
    let headline = (0.18 * h).min(0.14);
    items.push(PosterItem::Text {
        rect: [margin, h - margin - headline, w - margin, h - margin],
        line: headline,
        ink,
        seed: rng.next_u64(),
    });
    let blocks = 2 + rng.below(3) as usize;
    let band = [0.35 * h, h - 2.0 * margin - headline];
    let cell = (w - 2.0 * margin) / blocks as f64;
    for k in 0..blocks {
        let s0 = margin + cell * (k as f64 + rng.range(0.0, 0.15));
        let s1 = margin + cell * (k as f64 + rng.range(0.7, 0.95));
        let t0 = band[0] + (band[1] - band[0]) * rng.range(0.0, 0.3);
        let t1 = band[0] + (band[1] - band[0]) * rng.range(0.6, 1.0);
        items.push(PosterItem::Block {
            rect: [s0, t0, s1, t1],
            color: pick(rng),
        });
    }
    items.push(PosterItem::Text {
        rect: [margin, margin, w - margin, 0.33 * h],
        line: rng.range(0.05, 0.07),
        ink,
        seed: rng.next_u64(),
    });
    Texture::Poster(Poster { background, items })
}

/// `c` with each channel scaled by a random factor in `[1 - amount, 1 + amount]`.
pub fn jitter(rng: &mut SplitMix64, c: Rgb, amount: f64) -> Rgb {
    let mut out = c;
    for v in &mut out {
        *v = (*v * rng.range(1.0 - amount, 1.0 + amount) as f32).clamp(0.0, 1.0);
    }
    out
}
