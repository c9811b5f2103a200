//! Rotation and scale invariance: a synthetic textured scene rendered straight and
//! under a known rotation / scaling; keypoints seen in both views must match the right
//! keypoint by descriptor alone.

mod common;

use common::Scene;
use gfs_points::{OrbConfig, OrbExtractor, OrbFeatures, best_two};

const SIZE: usize = 480;
/// Scene units between the scene origin and the straight view's origin: margin so that
/// rotated and scaled views stay inside the scene.
const OFFSET: f32 = 80.0;
const CENTRE: f32 = (SIZE as f32 - 1.0) / 2.0;
/// Distance in pixels under which two keypoints are the same point.
const SAME_PX: f32 = 2.0;

struct Outcome {
    /// Keypoints of view A whose warped position has a keypoint of view B within 2 px.
    repeated: usize,
    /// Of those, the ones whose nearest descriptor in B is such a keypoint.
    matched: usize,
}

fn extract(image: &gfs_core::GrayImage) -> OrbFeatures {
    let mut orb = OrbExtractor::new(OrbConfig::default()).unwrap();
    let mut f = OrbFeatures::default();
    orb.extract(image.view(), None, &mut f).unwrap();
    f
}

/// Renders the straight view and the view whose pixel `q` shows the scene at
/// `b_to_scene(q)`; `a_to_b` maps a straight-view pixel to the other view.
fn compare(
    b_to_scene: impl Fn(f32, f32) -> (f32, f32),
    a_to_b: impl Fn(f32, f32) -> (f32, f32),
) -> Outcome {
    let scene = Scene::textured(SIZE + 2 * OFFSET as usize, 7, 900);
    let a = scene.render(SIZE, SIZE, |u, v| (u + OFFSET, v + OFFSET));
    let b = scene.render(SIZE, SIZE, b_to_scene);
    let (fa, fb) = (extract(&a), extract(&b));
    assert!(
        fa.len() > 500 && fb.len() > 500,
        "{} / {}",
        fa.len(),
        fb.len()
    );
    let near = |k: &gfs_points::KeyPoint, (u, v): (f32, f32)| (k.u - u).hypot(k.v - v) <= SAME_PX;
    let mut outcome = Outcome {
        repeated: 0,
        matched: 0,
    };
    for (ka, da) in fa.keypoints.iter().zip(&fa.descriptors) {
        let p = a_to_b(ka.u, ka.v);
        if !fb.keypoints.iter().any(|kb| near(kb, p)) {
            continue;
        }
        outcome.repeated += 1;
        let best = best_two(da, fb.descriptors.iter().enumerate()).unwrap();
        if near(&fb.keypoints[best.index], p) {
            outcome.matched += 1;
        }
    }
    outcome
}

fn rotation(deg: f32) -> Outcome {
    let (s, c) = deg.to_radians().sin_cos();
    compare(
        // View B pixel q shows the scene at R(-θ)(q - centre) + centre.
        move |u, v| {
            let (x, y) = (u - CENTRE, v - CENTRE);
            (
                c * x + s * y + CENTRE + OFFSET,
                -s * x + c * y + CENTRE + OFFSET,
            )
        },
        move |u, v| {
            let (x, y) = (u - CENTRE, v - CENTRE);
            (c * x - s * y + CENTRE, s * x + c * y + CENTRE)
        },
    )
}

fn check(name: &str, o: &Outcome) {
    let rate = o.matched as f32 / o.repeated.max(1) as f32;
    println!(
        "{name}: {} repeated keypoints, {} matched by descriptor ({:.1} %)",
        o.repeated,
        o.matched,
        100.0 * rate
    );
    assert!(o.repeated >= 150, "{name}: only {} repeated", o.repeated);
    assert!(rate >= 0.70, "{name}: {:.1} % < 70 %", 100.0 * rate);
}

#[test]
fn rotation_by_30_degrees_keeps_70_percent_of_matches() {
    check("30 deg", &rotation(30.0));
}

#[test]
fn rotation_by_90_degrees_keeps_70_percent_of_matches() {
    check("90 deg", &rotation(90.0));
}

#[test]
fn scaling_by_0_8_keeps_70_percent_of_matches() {
    const S: f32 = 0.8;
    let o = compare(
        |u, v| {
            (
                (u - CENTRE) / S + CENTRE + OFFSET,
                (v - CENTRE) / S + CENTRE + OFFSET,
            )
        },
        |u, v| ((u - CENTRE) * S + CENTRE, (v - CENTRE) * S + CENTRE),
    );
    check("scale 0.8", &o);
}
