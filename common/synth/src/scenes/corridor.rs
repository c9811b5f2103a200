//! A 14 x 2.2 x 2.6 m corridor with doors on both sides, skirting boards, posters,
//! ceiling lamps, a window at one end and a double door at the other.

use super::parts::{
    door, jitter, poster, poster_texture, shell, skirting, wall_box, walls, window,
};
use crate::rng::SplitMix64;
use crate::scene::{Aabb, BoxLook, Scene, SceneBuilder, SceneKind};
use crate::texture::Texture;
use nalgebra::Point3;
use std::f64::consts::PI;

const BOUNDS: Aabb = Aabb {
    min: Point3::new(0.0, 0.0, 0.0),
    max: Point3::new(14.0, 2.2, 2.6),
};

/// At least `MIN_CLEARANCE` from every surface (checked by a test).
const FREE_SPACE: Aabb = Aabb {
    min: Point3::new(1.0, 0.75, 1.35),
    max: Point3::new(13.0, 1.45, 1.7),
};

/// Door centres along the south and north walls, in wall coordinates `s`.
const SOUTH_DOORS: [f64; 3] = [3.5, 7.5, 11.5];
const NORTH_DOORS: [f64; 3] = [4.5, 8.5, 12.5];
const DOOR_WIDTH: f64 = 0.9;
/// Door frames are 7 cm wide: skirting boards stop there.
const DOOR_GAP: f64 = 0.5 * DOOR_WIDTH + 0.07;

/// The corridor; `seed` varies colours, posters and wood.
pub fn build(seed: u64) -> Scene {
    let mut rng = SplitMix64::keyed(seed, &[3]);
    let mut b = SceneBuilder::new();
    let wall_tex = b.texture(Texture::Paint {
        color: jitter(&mut rng, [0.84, 0.82, 0.72], 0.04),
        amplitude: 0.08,
        scale: 0.2,
        seed: rng.next_u64(),
    });
    let end_tex = b.texture(Texture::Blobs {
        a: jitter(&mut rng, [0.75, 0.80, 0.84], 0.04),
        b: [0.58, 0.64, 0.72],
        scale: 0.3,
        seed: rng.next_u64(),
    });
    let floor = b.texture(Texture::Tiles {
        size: 0.6,
        grout: 0.008,
        a: jitter(&mut rng, [0.62, 0.62, 0.58], 0.05),
        b: [0.38, 0.40, 0.42],
        grout_color: [0.2, 0.2, 0.2],
        seed: rng.next_u64(),
    });
    let ceiling = b.texture(Texture::Tiles {
        size: 0.6,
        grout: 0.015,
        a: [0.92, 0.92, 0.9],
        b: [0.86, 0.86, 0.84],
        grout_color: [0.6, 0.6, 0.6],
        seed: rng.next_u64(),
    });
    let wood = b.texture(Texture::Wood {
        light: jitter(&mut rng, [0.70, 0.50, 0.30], 0.08),
        dark: [0.42, 0.26, 0.14],
        period: 0.04,
        seed: rng.next_u64(),
    });
    let white = b.texture(Texture::Paint {
        color: [0.95, 0.95, 0.93],
        amplitude: 0.02,
        scale: 0.5,
        seed: rng.next_u64(),
    });
    let skirting_tex = b.texture(Texture::Paint {
        color: [0.3, 0.28, 0.26],
        amplitude: 0.03,
        scale: 0.2,
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
        height: 1.3,
        seed: rng.next_u64(),
    });
    let lamp = b.texture(Texture::Paint {
        color: [1.0, 1.0, 0.97],
        amplitude: 0.0,
        scale: 1.0,
        seed: 0,
    });
    shell(
        &mut b,
        &BOUNDS,
        [wall_tex, end_tex, wall_tex, end_tex],
        floor,
        ceiling,
    );
    let [south, east, north, west] = walls(&BOUNDS);
    let white_frame = BoxLook::all(white);
    let length = BOUNDS.max.x - BOUNDS.min.x;

    // South wall s runs from x = 14 down to 0, north wall s from x = 0 up to 14.
    for (wall, doors) in [
        (&south, SOUTH_DOORS.map(|x| length - x)),
        (&north, NORTH_DOORS),
    ] {
        let mut cuts: Vec<f64> = doors.to_vec();
        cuts.sort_by(f64::total_cmp);
        for &s in &cuts {
            door(
                &mut b,
                wall,
                [s - 0.5 * DOOR_WIDTH, s + 0.5 * DOOR_WIDTH],
                2.05,
                wood,
                white_frame,
                metal,
            );
        }
        let gaps: Vec<[f64; 2]> = cuts.iter().map(|&s| [s - DOOR_GAP, s + DOOR_GAP]).collect();
        skirting(&mut b, wall, length, &gaps, BoxLook::all(skirting_tex));
    }
    for (wall, s) in [(&south, 4.5), (&north, 6.5), (&south, 8.5), (&north, 10.5)] {
        let (w, h) = (rng.range(0.6, 1.0), rng.range(0.6, 0.9));
        let texture = poster_texture(&mut rng, w, h);
        let framed = rng.uniform() < 0.5;
        poster(
            &mut b,
            wall,
            [s - 0.5 * w, s + 0.5 * w],
            [1.2, 1.2 + h],
            texture,
            framed.then_some(white_frame),
        );
    }
    window(&mut b, &west, [0.5, 1.7], [0.9, 2.2], glass, white_frame);
    door(&mut b, &east, [0.5, 1.7], 2.1, wood, white_frame, metal);
    wall_box(&mut b, &east, [1.09, 1.11], [0.0, 2.1], 0.02, white_frame);
    for x in (1..7).map(|k| 2.0 * k as f64) {
        b.solid_box(
            Point3::new(x, 1.1, 2.55),
            [1.2, 0.3, 0.05],
            0.0,
            BoxLook::all(lamp),
        );
    }
    // Rotated objects: a bin and a box by the walls.
    b.solid_box(
        Point3::new(5.7, 0.35, 0.0),
        [0.35, 0.35, 0.6],
        0.5,
        BoxLook::all(metal),
    );
    b.solid_box(
        Point3::new(9.6, 1.85, 0.0),
        [0.5, 0.4, 0.4],
        -0.3,
        BoxLook::all(wood),
    );
    b.finish(
        SceneKind::Corridor,
        BOUNDS,
        FREE_SPACE,
        Point3::new(7.0, 1.1, 2.5),
        vec![0.0, PI],
    )
}
