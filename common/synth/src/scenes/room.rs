//! The 6 x 5 x 2.7 m room, textured and low-texture.

use super::parts::{
    FrameBars, door, frame, jitter, poster, poster_texture, shell, wall_box, wall_panel, walls,
    window,
};
use crate::rng::SplitMix64;
use crate::scene::{Aabb, BoxLook, Scene, SceneBuilder, SceneKind};
use crate::texture::{Poster, PosterItem, Texture};
use nalgebra::Point3;
use std::f64::consts::FRAC_PI_2;

const BOUNDS: Aabb = Aabb {
    min: Point3::new(0.0, 0.0, 0.0),
    max: Point3::new(6.0, 5.0, 2.7),
};

/// At least `MIN_CLEARANCE` from every surface of both room variants (checked by a test):
/// the shelf, cabinet and corner stand are tall, the rest is below 0.9 m.
const FREE_SPACE: Aabb = Aabb {
    min: Point3::new(1.1, 1.1, 1.4),
    max: Point3::new(4.9, 3.9, 1.75),
};

const LAMP: Point3<f64> = Point3::new(3.0, 2.5, 2.6);

/// Base viewing directions: along each wall normal, so a trajectory faces into the room.
fn base_yaws() -> Vec<f64> {
    (0..4).map(|k| k as f64 * FRAC_PI_2).collect()
}

/// The textured room: brick, blob and painted walls, posters, a whiteboard, two doors, a
/// window, a bookshelf, a cabinet, a table and four objects rotated about the vertical.
pub fn textured(seed: u64) -> Scene {
    let mut rng = SplitMix64::keyed(seed, &[1]);
    let mut b = SceneBuilder::new();
    let bricks = b.texture(Texture::Bricks {
        width: 0.24,
        height: 0.075,
        mortar: 0.012,
        color: jitter(&mut rng, [0.62, 0.32, 0.22], 0.1),
        mortar_color: [0.78, 0.76, 0.70],
        seed: rng.next_u64(),
    });
    let blobs = b.texture(Texture::Blobs {
        a: jitter(&mut rng, [0.80, 0.82, 0.76], 0.05),
        b: jitter(&mut rng, [0.55, 0.64, 0.58], 0.1),
        scale: 0.35,
        seed: rng.next_u64(),
    });
    let warm = b.texture(Texture::Paint {
        color: jitter(&mut rng, [0.86, 0.78, 0.60], 0.05),
        amplitude: 0.14,
        scale: 0.3,
        seed: rng.next_u64(),
    });
    let cool = b.texture(Texture::Paint {
        color: jitter(&mut rng, [0.70, 0.78, 0.86], 0.05),
        amplitude: 0.12,
        scale: 0.25,
        seed: rng.next_u64(),
    });
    let floor = b.texture(Texture::Tiles {
        size: 0.5,
        grout: 0.01,
        a: jitter(&mut rng, [0.74, 0.70, 0.62], 0.05),
        b: jitter(&mut rng, [0.46, 0.43, 0.39], 0.05),
        grout_color: [0.22, 0.21, 0.2],
        seed: rng.next_u64(),
    });
    let ceiling = b.texture(Texture::Paint {
        color: [0.92, 0.92, 0.90],
        amplitude: 0.05,
        scale: 0.8,
        seed: rng.next_u64(),
    });
    let wood = b.texture(Texture::Wood {
        light: jitter(&mut rng, [0.72, 0.52, 0.32], 0.08),
        dark: [0.45, 0.28, 0.15],
        period: 0.04,
        seed: rng.next_u64(),
    });
    let dark_wood = b.texture(Texture::Wood {
        light: [0.42, 0.27, 0.16],
        dark: [0.22, 0.13, 0.08],
        period: 0.03,
        seed: rng.next_u64(),
    });
    let white = b.texture(Texture::Paint {
        color: [0.95, 0.95, 0.93],
        amplitude: 0.02,
        scale: 0.5,
        seed: rng.next_u64(),
    });
    let metal = b.texture(Texture::Paint {
        color: [0.25, 0.26, 0.28],
        amplitude: 0.05,
        scale: 0.1,
        seed: rng.next_u64(),
    });
    let glass = b.texture(Texture::Glass {
        top: [0.55, 0.75, 0.95],
        bottom: [0.92, 0.95, 0.98],
        height: 1.2,
        seed: rng.next_u64(),
    });
    let books = b.texture(Texture::Books {
        shelf: 0.36,
        seed: rng.next_u64(),
    });
    let fabric = b.texture(Texture::Blobs {
        a: jitter(&mut rng, [0.35, 0.42, 0.6], 0.1),
        b: [0.2, 0.24, 0.38],
        scale: 0.08,
        seed: rng.next_u64(),
    });
    shell(&mut b, &BOUNDS, [bricks, blobs, warm, cool], floor, ceiling);
    let [south, east, north, west] = walls(&BOUNDS);
    let white_frame = BoxLook::all(white);
    let dark_frame = BoxLook::all(dark_wood);

    // South (bricks): a door, a framed poster, a picture.
    door(&mut b, &south, [0.8, 1.7], 2.05, wood, white_frame, metal);
    poster(
        &mut b,
        &south,
        [2.4, 3.6],
        [1.1, 1.9],
        poster_texture(&mut rng, 1.2, 0.8),
        Some(dark_frame),
    );
    let painting = Texture::Blobs {
        a: jitter(&mut rng, [0.85, 0.6, 0.3], 0.1),
        b: jitter(&mut rng, [0.2, 0.35, 0.5], 0.1),
        scale: 0.07,
        seed: rng.next_u64(),
    };
    poster(
        &mut b,
        &south,
        [4.2, 4.9],
        [1.3, 1.8],
        painting,
        Some(BoxLook::all(wood)),
    );

    // East (blobs): a window, a bookshelf, a poster.
    window(&mut b, &east, [1.2, 2.8], [0.9, 2.1], glass, white_frame);
    wall_box(
        &mut b,
        &east,
        [3.5, 4.5],
        [0.0, 1.9],
        0.38,
        BoxLook {
            sides: wood,
            top: wood,
            front: books,
        },
    );
    poster(
        &mut b,
        &east,
        [0.3, 0.9],
        [1.2, 1.9],
        poster_texture(&mut rng, 0.6, 0.7),
        None,
    );

    // North (warm paint): a cabinet with two doors and a picture above, two posters.
    wall_box(
        &mut b,
        &north,
        [0.5, 1.7],
        [0.0, 0.9],
        0.5,
        BoxLook::all(wood),
    );
    for (s0, s1) in [(0.55, 1.09), (1.11, 1.65)] {
        wall_panel(
            &mut b,
            &north,
            [s0, s1],
            [0.08, 0.85],
            0.5 + 0.004,
            dark_wood,
        );
        wall_box(
            &mut b,
            &north,
            [s1 - 0.1, s1 - 0.06],
            [0.45, 0.6],
            0.53,
            BoxLook::all(metal),
        );
    }
    poster(
        &mut b,
        &north,
        [0.7, 1.5],
        [1.3, 1.8],
        poster_texture(&mut rng, 0.8, 0.5),
        Some(dark_frame),
    );
    poster(
        &mut b,
        &north,
        [2.3, 3.5],
        [1.0, 1.9],
        poster_texture(&mut rng, 1.2, 0.9),
        None,
    );
    poster(
        &mut b,
        &north,
        [3.9, 4.7],
        [1.2, 1.9],
        poster_texture(&mut rng, 0.8, 0.7),
        Some(white_frame),
    );

    // West (cool paint): a door, a whiteboard, a table with a box on it.
    door(
        &mut b,
        &west,
        [0.5, 1.4],
        2.05,
        dark_wood,
        white_frame,
        metal,
    );
    let board = whiteboard(&mut rng, 2.0, 1.0);
    poster(
        &mut b,
        &west,
        [2.2, 4.2],
        [1.0, 2.0],
        board,
        Some(BoxLook::all(metal)),
    );
    b.solid_box(
        Point3::new(0.5, 3.1, 0.71),
        [0.8, 1.4, 0.04],
        0.0,
        BoxLook::all(wood),
    );
    for (x, y) in [(0.15, 2.45), (0.85, 2.45), (0.85, 3.75), (0.15, 3.75)] {
        b.solid_box(
            Point3::new(x, y, 0.0),
            [0.05, 0.05, 0.71],
            0.0,
            BoxLook::all(metal),
        );
    }

    // Rotated objects: a print box on the table, a crate, an ottoman, a corner stand.
    let print = b.texture(poster_texture(&mut rng, 0.25, 0.12));
    b.solid_box(
        Point3::new(0.5, 3.0, 0.75),
        [0.25, 0.18, 0.12],
        0.45,
        BoxLook {
            sides: print,
            top: white,
            front: print,
        },
    );
    b.solid_box(
        Point3::new(3.3, 2.2, 0.0),
        [0.5, 0.4, 0.45],
        0.5,
        BoxLook::all(wood),
    );
    b.solid_box(
        Point3::new(2.0, 3.2, 0.0),
        [0.6, 0.6, 0.35],
        -0.35,
        BoxLook::all(fabric),
    );
    b.solid_box(
        Point3::new(5.45, 0.55, 0.0),
        [0.3, 0.3, 1.3],
        0.7,
        BoxLook {
            sides: dark_wood,
            top: metal,
            front: dark_wood,
        },
    );

    let lamp = b.texture(Texture::Paint {
        color: [1.0, 1.0, 0.97],
        amplitude: 0.0,
        scale: 1.0,
        seed: 0,
    });
    b.solid_box(
        Point3::new(3.0, 2.5, 2.64),
        [1.2, 0.3, 0.06],
        0.0,
        BoxLook::all(lamp),
    );
    b.finish(SceneKind::Room, BOUNDS, FREE_SPACE, LAMP, base_yaws())
}

/// The low-texture room: the same shell with plain paint, a door, a window, one plain
/// picture frame, a cabinet, a table and one rotated box.
pub fn low_texture(seed: u64) -> Scene {
    let mut rng = SplitMix64::keyed(seed, &[2]);
    let mut b = SceneBuilder::new();
    let plain = |b: &mut SceneBuilder, rng: &mut SplitMix64, color, amplitude| {
        b.texture(Texture::Paint {
            color: jitter(rng, color, 0.03),
            amplitude,
            scale: 1.5,
            seed: rng.next_u64(),
        })
    };
    let walls_tex = [
        plain(&mut b, &mut rng, [0.86, 0.85, 0.80], 0.015),
        plain(&mut b, &mut rng, [0.80, 0.82, 0.84], 0.015),
        plain(&mut b, &mut rng, [0.84, 0.80, 0.74], 0.015),
        plain(&mut b, &mut rng, [0.78, 0.80, 0.76], 0.015),
    ];
    let floor = plain(&mut b, &mut rng, [0.55, 0.50, 0.45], 0.03);
    let ceiling = plain(&mut b, &mut rng, [0.93, 0.93, 0.92], 0.01);
    let frame_tex = plain(&mut b, &mut rng, [0.96, 0.96, 0.95], 0.0);
    let leaf = plain(&mut b, &mut rng, [0.62, 0.45, 0.30], 0.02);
    let furniture = plain(&mut b, &mut rng, [0.45, 0.40, 0.36], 0.02);
    let picture = plain(&mut b, &mut rng, [0.35, 0.45, 0.55], 0.02);
    let glass = b.texture(Texture::Glass {
        top: [0.6, 0.78, 0.95],
        bottom: [0.9, 0.94, 0.97],
        height: 1.2,
        seed: rng.next_u64(),
    });
    shell(&mut b, &BOUNDS, walls_tex, floor, ceiling);
    let [south, east, north, _] = walls(&BOUNDS);
    let frame_look = BoxLook::all(frame_tex);
    door(
        &mut b,
        &south,
        [0.8, 1.7],
        2.05,
        leaf,
        frame_look,
        furniture,
    );
    window(&mut b, &east, [1.2, 2.8], [0.9, 2.1], glass, frame_look);
    wall_panel(&mut b, &north, [2.6, 3.6], [1.2, 1.8], 0.004, picture);
    frame(
        &mut b,
        &north,
        [2.6, 3.6],
        [1.2, 1.8],
        FrameBars {
            width: 0.04,
            depth: 0.025,
            look: BoxLook::all(furniture),
            bottom: true,
        },
    );
    wall_box(
        &mut b,
        &north,
        [0.5, 1.7],
        [0.0, 0.9],
        0.5,
        BoxLook::all(furniture),
    );
    b.solid_box(
        Point3::new(0.5, 3.1, 0.71),
        [0.8, 1.4, 0.04],
        0.0,
        BoxLook::all(furniture),
    );
    for (x, y) in [(0.15, 2.45), (0.85, 2.45), (0.85, 3.75), (0.15, 3.75)] {
        b.solid_box(
            Point3::new(x, y, 0.0),
            [0.05, 0.05, 0.71],
            0.0,
            BoxLook::all(furniture),
        );
    }
    b.solid_box(
        Point3::new(3.3, 2.2, 0.0),
        [0.5, 0.4, 0.45],
        0.5,
        BoxLook::all(furniture),
    );
    b.finish(SceneKind::LowTexture, BOUNDS, FREE_SPACE, LAMP, base_yaws())
}

/// A whiteboard: near-white with lines of dark marker text and two sticky notes.
fn whiteboard(rng: &mut SplitMix64, w: f64, h: f64) -> Texture {
    let mut items = vec![PosterItem::Text {
        rect: [0.1, 0.15, 0.65 * w, h - 0.1],
        line: 0.08,
        ink: [0.1, 0.15, 0.45],
        seed: rng.next_u64(),
    }];
    for k in 0..2 {
        let s0 = 0.72 * w + 0.08 * k as f64;
        let t0 = 0.25 + 0.35 * k as f64;
        items.push(PosterItem::Block {
            rect: [s0, t0, s0 + 0.12, t0 + 0.12],
            color: [0.98, 0.85, 0.25],
        });
    }
    Texture::Poster(Poster {
        background: [0.96, 0.96, 0.96],
        items,
    })
}
