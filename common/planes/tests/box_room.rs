//! Box-room frames: every visible wall is found as a plane with the right normal, and
//! the Manhattan axes are the room's axes, on clean and Kinect-noisy depth.

mod common;

use common::{BoxRoom, Rng, add_kinect_noise, angle_deg, fr1_camera, pose, true_axes};
use gfs_planes::{ManhattanEstimator, Plane, PlaneConfig, PlaneExtractor};
use nalgebra::{Isometry3, Vector3};

/// A wall counts as visible when it covers at least this share of the image.
const VISIBLE_SHARE: f64 = 0.03;

/// Random camera poses inside the office room: position within 1 m of the centre
/// (0.4 m vertically), any orientation.
fn random_poses(rng: &mut Rng, count: usize) -> Vec<Isometry3<f64>> {
    (0..count)
        .map(|_| {
            let p = Vector3::new(
                rng.uniform() * 2.0 - 1.0,
                rng.uniform() * 0.8 - 0.4,
                rng.uniform() * 2.0 - 1.0,
            );
            pose(p, rng.rotation())
        })
        .collect()
}

struct FrameResult {
    /// Worst angle between a visible wall and its closest plane (deg).
    worst_wall_deg: f64,
    visible_walls: usize,
    /// Planes covering a visible share of the image that match no wall within 2 deg.
    spurious_planes: usize,
    ma: Option<MaResult>,
}

struct MaResult {
    /// Worst angle between a true room axis and the closest estimated axis (deg).
    worst_deg: f64,
    /// Worst angle between an observed axis and the closest room axis (deg).
    observed_deg: f64,
    observed: usize,
    confidence: f32,
}

fn run_frame(
    room: &BoxRoom,
    world_from_camera: &Isometry3<f64>,
    noise: Option<&mut Rng>,
) -> FrameResult {
    let cam = fr1_camera();
    let (mut depth, walls) = room.render(&cam, world_from_camera);
    if let Some(rng) = noise {
        add_kinect_noise(&mut depth, rng, 0.1, 6);
    }
    let config = PlaneConfig::default();
    let mut extractor = PlaneExtractor::new(&config).unwrap();
    let mut planes: Vec<Plane> = Vec::new();
    extractor.extract(&depth.view(), &cam, &mut planes).unwrap();
    let mut worst_wall_deg: f64 = 0.0;
    let mut visible_walls = 0;
    for wall in 0..6u8 {
        let share = walls.iter().filter(|&&w| w == wall).count() as f64 / walls.len() as f64;
        if share < VISIBLE_SHARE {
            continue;
        }
        visible_walls += 1;
        let truth = BoxRoom::wall_normal_in_camera(wall, world_from_camera);
        let best = planes
            .iter()
            .map(|p| angle_deg(&Vector3::from(p.normal).cast(), &truth, false))
            .fold(f64::INFINITY, f64::min);
        worst_wall_deg = worst_wall_deg.max(best);
    }
    let wall_normals: Vec<_> = (0..6u8)
        .map(|w| BoxRoom::wall_normal_in_camera(w, world_from_camera))
        .collect();
    let spurious_planes = planes
        .iter()
        .filter(|p| f64::from(p.pixels) >= VISIBLE_SHARE * walls.len() as f64)
        .filter(|p| {
            let n = Vector3::from(p.normal).cast();
            wall_normals.iter().all(|w| angle_deg(&n, w, false) > 2.0)
        })
        .count();
    let mut estimator = ManhattanEstimator::new(&config).unwrap();
    let ma = estimator.estimate(&planes, &[], &[], None).map(|axes| {
        let truth = true_axes(world_from_camera);
        let closest = |a: &Vector3<f64>| {
            (0..3)
                .map(|j| angle_deg(&truth.column(j).into_owned(), a, true))
                .fold(f64::INFINITY, f64::min)
        };
        let worst_deg = (0..3)
            .map(|i| {
                (0..3)
                    .map(|j| angle_deg(&truth.column(i).into_owned(), &axes.axis(j), true))
                    .fold(f64::INFINITY, f64::min)
            })
            .fold(0.0, f64::max);
        let observed_deg = (0..3)
            .filter(|&i| axes.observed[i])
            .map(|i| closest(&axes.axis(i)))
            .fold(0.0, f64::max);
        MaResult {
            worst_deg,
            observed_deg,
            observed: axes.observed_count(),
            confidence: axes.confidence,
        }
    });
    FrameResult {
        worst_wall_deg,
        visible_walls,
        spurious_planes,
        ma,
    }
}

/// Number of random poses per test (and the seed), enough to see 1 to 4 walls.
const POSES: usize = 20;
const SEED: u64 = 7;

#[test]
fn visible_walls_are_planes_within_1_deg_clean_and_2_deg_noisy() {
    let room = BoxRoom::office();
    let mut rng = Rng::new(SEED);
    let poses = random_poses(&mut rng, POSES);
    let (mut worst_clean, mut worst_noisy): (f64, f64) = (0.0, 0.0);
    let mut walls_seen = 0;
    for (k, p) in poses.iter().enumerate() {
        let clean = run_frame(&room, p, None);
        let noisy = run_frame(&room, p, Some(&mut rng));
        assert!(clean.visible_walls >= 1);
        walls_seen += clean.visible_walls;
        assert!(
            clean.worst_wall_deg <= 1.0,
            "pose {k}: clean {:.3} deg",
            clean.worst_wall_deg
        );
        assert!(
            noisy.worst_wall_deg <= 2.0,
            "pose {k}: noisy {:.3} deg",
            noisy.worst_wall_deg
        );
        // Every large plane is a wall (no ghost planes along creases or holes).
        assert_eq!(clean.spurious_planes, 0, "pose {k} clean");
        assert_eq!(noisy.spurious_planes, 0, "pose {k} noisy");
        worst_clean = worst_clean.max(clean.worst_wall_deg);
        worst_noisy = worst_noisy.max(noisy.worst_wall_deg);
    }
    println!(
        "{walls_seen} visible walls in {POSES} poses: worst wall normal error {worst_clean:.3} deg clean, {worst_noisy:.3} deg noisy"
    );
}

#[test]
fn manhattan_axes_are_the_room_axes_within_1_deg() {
    let room = BoxRoom::office();
    let mut rng = Rng::new(SEED);
    let poses = random_poses(&mut rng, POSES);
    let mut worst: f64 = 0.0;
    let mut full = 0;
    for (k, p) in poses.iter().enumerate() {
        for (name, frame) in [
            ("clean", run_frame(&room, p, None)),
            ("noisy", run_frame(&room, p, Some(&mut rng))),
        ] {
            let ma = frame.ma.unwrap_or_else(|| panic!("pose {k} {name}: no MA"));
            if frame.visible_walls >= 2 {
                // Two walls fix the third axis by cross product.
                assert!(ma.observed >= 2, "pose {k} {name}: {} axes", ma.observed);
                assert!(
                    ma.worst_deg <= 1.0,
                    "pose {k} {name}: {:.3} deg",
                    ma.worst_deg
                );
                worst = worst.max(ma.worst_deg);
                full += 1;
            } else {
                // One wall: one observed axis, exactly the wall's normal, low confidence.
                assert_eq!(ma.observed, 1, "pose {k} {name}");
                assert!(
                    ma.observed_deg <= 1.0,
                    "pose {k} {name}: {:.3} deg",
                    ma.observed_deg
                );
                assert!(ma.confidence <= 1.0 / 3.0 + 1e-6, "pose {k} {name}");
            }
        }
    }
    assert!(full >= 20, "only {full} frames with two walls");
    println!("{full} frames with >= 2 walls: worst MA axis error {worst:.3} deg");
}
