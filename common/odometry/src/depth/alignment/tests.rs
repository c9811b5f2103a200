//! Unit tests of the depth alignment's association, weights and reference renewal.

use super::associator::tangent_variance_from_angles;
use super::*;
use crate::depth::grid::PosedGrid;
use crate::testing::{CORNER, planes_depth};
use gfs_core::camera::PinholeCamera;
use nalgebra::{Point3, Vector3};

/// The grid of the plane z = `depth` seen from the identity, normals towards the
/// camera.
fn wall(camera: &PinholeCamera, depth: f64) -> DepthGrid {
    planes_depth(camera, &Isometry3::identity(), &[([0.0, 0.0, 1.0], depth)])
}

#[test]
fn a_corner_determines_a_pose_and_a_corridor_leaves_its_axis_free() {
    let camera = PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480);
    let config = DepthAlignmentConfig::default();
    let analyse = |grid: &DepthGrid| {
        gfs_optim::analyse_constraint(
            &self_information(&config, grid, 0.0),
            config.lever_arm_m,
            config.max_sigma_m,
        )
    };
    let corner = planes_depth(&camera, &Isometry3::identity(), &CORNER);
    assert!(analyse(&corner).is_determined());
    let walls = [([1.0, 0.0, 0.0], -1.0), ([1.0, 0.0, 0.0], 1.0)];
    let corridor = analyse(&planes_depth(&camera, &Isometry3::identity(), &walls));
    // Free: along the corridor (z), up (y) and the roll about the walls' normal (x).
    assert_eq!(corridor.unconstrained.len(), 3, "{corridor:?}");
    for d in &corridor.unconstrained {
        assert!(
            d[0].abs() < 1e-6 && d[4].abs() < 1e-6 && d[5].abs() < 1e-6,
            "{d}"
        );
    }
}

#[test]
fn tilted_normals_lend_a_wall_information_along_itself() {
    let camera = PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480);
    let config = DepthAlignmentConfig::default();
    let reference = wall(&camera, 2.0);
    let mut current = reference.clone();
    let pose = Isometry3::identity();
    let mut associator = DepthAssociator::default();
    let count = associator
        .associate(
            &config,
            &camera,
            PosedGrid {
                grid: &current,
                camera_from_world: &pose,
            },
            PosedGrid {
                grid: &reference,
                camera_from_world: &pose,
            },
            0.015,
            1.0,
        )
        .len();
    // Exact normals: nothing lent.
    assert_eq!(
        associator.normal_noise_information(&pose, &vec![true; count]),
        Matrix6::zeros()
    );
    // Every frame normal tilted by 0.02 rad: read as the median of tilts of
    // variance 0.02^2 / (4 ln 2) per component, along the wall's x and y only.
    let tilt = [0.02f32.sin(), 0.0, -0.02f32.cos()];
    current.normals.iter_mut().for_each(|n| *n = tilt);
    let pairs = associator
        .associate(
            &config,
            &camera,
            PosedGrid {
                grid: &current,
                camera_from_world: &pose,
            },
            PosedGrid {
                grid: &reference,
                camera_from_world: &pose,
            },
            0.015,
            1.0,
        )
        .to_vec();
    let h = associator.normal_noise_information(&pose, &vec![true; pairs.len()]);
    let tilt_variance = 0.02f64.powi(2) / (4.0 * std::f64::consts::LN_2);
    let w: f64 = pairs.iter().map(|o| o.inv_sigma2).sum();
    let expected = w * tilt_variance;
    assert!(!pairs.is_empty());
    assert!((h[(0, 0)] / expected - 1.0).abs() < 1e-3, "{h}");
    assert!((h[(1, 1)] / expected - 1.0).abs() < 1e-3, "{h}");
    assert!(h[(2, 2)].abs() < 1e-9 * expected && h[(3, 3)] == 0.0, "{h}");
    // The pairs the optimisation rejected lent nothing, and have nothing taken out.
    let every_other: Vec<bool> = (0..pairs.len()).map(|k| k % 2 == 0).collect();
    let kept: f64 = pairs
        .iter()
        .zip(&every_other)
        .filter(|(_, inlier)| **inlier)
        .map(|(o, _)| o.inv_sigma2)
        .sum();
    let h = associator.normal_noise_information(&pose, &every_other);
    let expected = kept * tilt_variance;
    assert!((h[(0, 0)] / expected - 1.0).abs() < 1e-3, "{h}");
}

#[test]
fn the_normals_noise_is_read_from_the_pairs_and_not_from_a_crease() {
    // Pairs of normals each tilted by two Gaussian components of 0.01 rad, and one
    // pair in ten across a crease (30 degrees or more apart).
    let mut rng = gfs_core::rng::SplitMix64::new(5);
    let sigma = 0.01;
    let mut angles2 = Vec::new();
    for k in 0..4000 {
        let angle2 = if k % 10 == 0 {
            (0.5 + rng.gaussian().abs()).powi(2)
        } else {
            // Their difference: two components of twice one normal's variance.
            (0..2).map(|_| 2.0 * (sigma * rng.gaussian()).powi(2)).sum()
        };
        angles2.push(angle2);
    }
    let variance = tangent_variance_from_angles(&mut angles2);
    // The creases' tenth moves the median to the chi-square's 56th percentile
    // (17 % above its median).
    assert!(
        (variance / sigma.powi(2) - 1.0).abs() < 0.25,
        "{variance} against {}",
        sigma.powi(2)
    );
    let mean = angles2.iter().sum::<f64>() / (4.0 * angles2.len() as f64);
    assert!(mean > 50.0 * sigma.powi(2), "{mean}");
    assert_eq!(tangent_variance_from_angles(&mut []), 0.0);
}

#[test]
fn an_averaged_node_is_weighed_with_its_normals_tilt_across_the_pair() {
    let camera = PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480);
    let config = DepthAlignmentConfig::default();
    // Every third column of the wall, the rest holes: no four nodes around a pixel
    // to blend, each pair is with the node at its pixel.
    let mut reference = wall(&camera, 2.0);
    let width = reference.width as usize;
    for (k, p) in reference.points.iter_mut().enumerate() {
        if !(k % width).is_multiple_of(3) {
            *p = [0.0; 3];
        }
    }
    // The frame 2.1 cm to the side (its nodes fall between the reference's), every
    // normal tilted by 0.2 rad: read as a variance of 0.2^2 / (4 ln 2) per tangent
    // component.
    let mut current = wall(&camera, 2.0);
    let tilt = [0.2f32.sin(), 0.0, -0.2f32.cos()];
    current.normals.iter_mut().for_each(|n| *n = tilt);
    let current_from_world = Isometry3::translation(-0.021, 0.0, 0.0);
    let gate = 0.015;
    let sensor = 2.0 * config.noise.sigma(2.0).powi(2);
    let association = (gate / 3.0f64).powi(2);
    let mut associator = DepthAssociator::default();
    let mut pair_weights = |scale: f64| {
        associator
            .associate(
                &config,
                &camera,
                PosedGrid {
                    grid: &current,
                    camera_from_world: &current_from_world,
                },
                PosedGrid {
                    grid: &reference,
                    camera_from_world: &Isometry3::identity(),
                },
                gate,
                scale,
            )
            .iter()
            .map(|o| {
                let offset = current_from_world.inverse() * Point3::from(o.point_in_camera);
                let tangential2 = (offset.coords - o.surface_in_world).xy().norm_squared();
                (o.inv_sigma2, tangential2)
            })
            .collect::<Vec<_>>()
    };
    // The Kinect model already holds the tilt: the pixel's sigma alone.
    let pixel = pair_weights(1.0);
    assert!(!pixel.is_empty());
    for (w, _) in &pixel {
        assert!((w * (sensor + association) - 1.0).abs() < 1e-9, "{w}");
    }
    // Averaged over 16 pixels: the sensor's share shrinks, the tilt across the
    // tangential offset joins it.
    let averaged = pair_weights(1.0 / 16.0);
    assert_eq!(averaged.len(), pixel.len());
    let mut offset_pairs = 0;
    for (w, tangential2) in &averaged {
        let tilt = 0.2f64.powi(2) / (4.0 * std::f64::consts::LN_2);
        let sigma2 = sensor / 16.0 + association + tangential2 * tilt;
        assert!((w * sigma2 - 1.0).abs() < 1e-6, "{w} {tangential2}");
        if *tangential2 > 1e-5 {
            offset_pairs += 1;
            assert!(*w < 1.0 / (sensor / 16.0 + association));
        }
    }
    assert!(offset_pairs > averaged.len() / 2, "{offset_pairs}");
    assert!(averaged[0].0 > 1.5 * pixel[0].0);
}

/// The pose information of `current` (at `camera_from_world`) from its pairs with
/// `reference` (at `reference_from_world`), and the share of its nodes that paired.
fn paired_information(
    camera: &PinholeCamera,
    (current, camera_from_world): (&DepthGrid, &Isometry3<f64>),
    (reference, reference_from_world): (&DepthGrid, &Isometry3<f64>),
) -> (Matrix6<f64>, f64) {
    let config = DepthAlignmentConfig::default();
    let mut associator = DepthAssociator::default();
    let pairs = associator.associate(
        &config,
        camera,
        PosedGrid {
            grid: current,
            camera_from_world,
        },
        PosedGrid {
            grid: reference,
            camera_from_world: reference_from_world,
        },
        0.015,
        1.0,
    );
    let information = optimise_on_depth(camera, camera_from_world, pairs).information;
    (information, associator.overlap())
}

/// The pose optimised from `camera_from_world` on the depth pairs `pairs` alone.
fn optimise_on_depth(
    camera: &PinholeCamera,
    camera_from_world: &Isometry3<f64>,
    pairs: &[gfs_optim::DepthObservation],
) -> gfs_optim::PoseResult {
    let mut result = gfs_optim::PoseResult::default();
    gfs_optim::optimize_pose_with_depth(
        camera,
        camera_from_world,
        &[],
        &[],
        gfs_optim::SurfaceObservations {
            depth: pairs,
            ..gfs_optim::SurfaceObservations::default()
        },
        &gfs_optim::PoseOptimizerConfig::default(),
        &mut result,
    );
    result
}

#[test]
fn a_view_turned_off_its_reference_onto_a_corner_of_its_own_needs_a_new_one() {
    let camera = PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480);
    let config = DepthAlignmentConfig::default();
    // A room's floor, right wall, far wall and (out of the reference's view) left
    // wall; the camera turned 30 degrees to the left sees the floor, the far wall
    // and the left wall, and pairs only on the floor and the far wall: nothing of
    // the reference holds it along x.
    let room = [
        ([0.0, 1.0, 0.0], 1.0),
        ([1.0, 0.0, 0.0], 1.2),
        ([1.0, 0.0, 0.0], -3.0),
        ([0.0, 0.0, 1.0], 4.0),
    ];
    let turned = Isometry3::rotation(nalgebra::Vector3::y() * 30f64.to_radians());
    let identity = Isometry3::identity();
    let reference = planes_depth(&camera, &identity, &room);
    let current = planes_depth(&camera, &turned, &room);
    let (information, overlap) =
        paired_information(&camera, (&current, &turned), (&reference, &identity));
    assert!(
        overlap > 0.3 && overlap < config.renewal_overlap,
        "{overlap}"
    );
    assert!(needs_new_reference(
        &config,
        &information,
        overlap,
        &current
    ));
    // Against a reference seen from where it stands, every node pairs.
    let (information, overlap) =
        paired_information(&camera, (&current, &turned), (&current, &turned));
    assert!(overlap > 0.99, "{overlap}");
    assert!(!needs_new_reference(
        &config,
        &information,
        overlap,
        &current
    ));
    // Without the side walls the turned view's own surfaces leave x free too: a
    // keyframe of it would keep whatever slide its pose has.
    let wall_and_floor = [room[0], room[3]];
    let reference = planes_depth(&camera, &identity, &wall_and_floor);
    let current = planes_depth(&camera, &turned, &wall_and_floor);
    let (information, overlap) =
        paired_information(&camera, (&current, &turned), (&reference, &identity));
    assert!(overlap < config.renewal_overlap, "{overlap}");
    assert!(!needs_new_reference(
        &config,
        &information,
        overlap,
        &current
    ));
}

#[test]
fn a_view_renews_its_reference_before_it_is_as_loose_as_its_own_surfaces_may_be() {
    // A view turned onto a corner of its own, its pose held to 5 mm in every
    // direction by a reference it has half left: above the 4 mm trigger, and its own
    // surfaces hold it within the 6 mm they must.
    let camera = PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480);
    let room = [
        ([0.0, 1.0, 0.0], 1.0),
        ([1.0, 0.0, 0.0], -3.0),
        ([0.0, 0.0, 1.0], 4.0),
    ];
    let turned = Isometry3::rotation(Vector3::y() * 30f64.to_radians());
    let current = planes_depth(&camera, &turned, &room);
    let config = DepthAlignmentConfig::default();
    let held_to = |sigma_m: f64| {
        let l2 = config.lever_arm_m.powi(2);
        Matrix6::from_diagonal(&nalgebra::Vector6::new(1.0, 1.0, 1.0, l2, l2, l2))
            / (sigma_m * sigma_m)
    };
    assert!(needs_new_reference(&config, &held_to(0.005), 0.5, &current));
    // Within the trigger it keeps its reference, as it does with the trigger at the
    // own surfaces' bound (the rule before 2026-11-28).
    assert!(!needs_new_reference(
        &config,
        &held_to(0.003),
        0.5,
        &current
    ));
    let late = DepthAlignmentConfig {
        renewal_sigma_m: config.renewal_own_sigma_m,
        ..config.clone()
    };
    assert!(!needs_new_reference(&late, &held_to(0.005), 0.5, &current));
}

#[test]
fn noisy_normals_do_not_pull_a_frame_onto_the_reference_nodes() {
    // The floor and a wall 4 m ahead: their geometry leaves x free, so only the
    // normals' noise acts along it. Paired with the node at each pixel, that noise
    // pulled the frame the whole 2 cm back onto the reference's nodes.
    const WALL_AND_FLOOR: [([f64; 3], f64); 2] = [([0.0, 1.0, 0.0], 1.0), ([0.0, 0.0, 1.0], 4.0)];
    let camera = PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480);
    let config = DepthAlignmentConfig::default();
    let reference_pose = Isometry3::identity();
    let mut reference = planes_depth(&camera, &reference_pose, &WALL_AND_FLOOR);
    // Each reference normal tilted by up to 0.05 rad (a fixed pseudo-random
    // pattern), as block normals of a noisy sensor are.
    for (k, n) in reference.normals.iter_mut().enumerate() {
        let k = k as f32;
        let tilt = Vector3::new(0.05 * (12.99 * k).sin(), 0.05 * (78.23 * k).sin(), 0.0);
        *n = (Vector3::from(*n) + tilt).normalize().into();
    }
    // The frame 2 cm to the side (a third of a node on the wall), started there.
    let truth = Isometry3::translation(-0.02, 0.0, 0.0);
    let current = planes_depth(&camera, &truth, &WALL_AND_FLOOR);
    let mut pose = truth;
    let mut associator = DepthAssociator::default();
    for gate in &config.max_distance_m {
        let pairs = associator.associate(
            &config,
            &camera,
            PosedGrid {
                grid: &current,
                camera_from_world: &pose,
            },
            PosedGrid {
                grid: &reference,
                camera_from_world: &reference_pose,
            },
            *gate,
            1.0,
        );
        pose = optimise_on_depth(&camera, &pose, pairs).camera_from_world;
    }
    let error = (pose * truth.inverse()).translation.vector;
    assert!(error.norm() < 0.002, "{error}");
}

#[test]
fn three_planes_alone_give_the_frame_to_frame_motion() {
    let camera = PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480);
    let config = DepthAlignmentConfig::default();
    let last_pose = Isometry3::identity();
    let last = planes_depth(&camera, &last_pose, &CORNER);
    // 2 cm and 1.5 degrees about a tilted axis, from the last pose as prediction.
    let truth = gfs_core::se3::exp(&nalgebra::Vector6::new(
        0.02, -0.01, 0.015, 0.01, 0.02, -0.012,
    ));
    let current = planes_depth(&camera, &truth, &CORNER);
    let mut pose = last_pose;
    let mut associator = DepthAssociator::default();
    for gate in &config.max_distance_m {
        let pairs = associator.associate(
            &config,
            &camera,
            PosedGrid {
                grid: &current,
                camera_from_world: &pose,
            },
            PosedGrid {
                grid: &last,
                camera_from_world: &last_pose,
            },
            *gate,
            1.0,
        );
        pose = optimise_on_depth(&camera, &pose, pairs).camera_from_world;
    }
    let error = pose * truth.inverse();
    assert!(error.translation.vector.norm() < 1e-3, "{error}");
    assert!(
        error.rotation.angle() < 0.1f64.to_radians(),
        "{}",
        error.rotation.angle().to_degrees()
    );
}

#[test]
fn a_shifted_wall_pairs_every_node_within_the_gate_with_its_distance() {
    let camera = PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480);
    let reference = wall(&camera, 2.0);
    // The frame 2 cm closer to the wall sees it at 1.98 m.
    let current = wall(&camera, 1.98);
    let current_from_world = Isometry3::translation(0.0, 0.0, -0.02);
    let config = DepthAlignmentConfig::default();
    let mut associator = DepthAssociator::default();
    let pairs = associator.associate(
        &config,
        &camera,
        PosedGrid {
            grid: &current,
            camera_from_world: &Isometry3::identity(),
        },
        PosedGrid {
            grid: &reference,
            camera_from_world: &Isometry3::identity(),
        },
        0.05,
        1.0,
    );
    assert_eq!(pairs.len(), 40 * 30);
    for pair in pairs {
        let e = gfs_optim::residuals::PointToPlane {
            point_in_camera: pair.point_in_camera,
        }
        .error(
            &Isometry3::identity(),
            &pair.surface_in_world,
            &pair.normal_in_world,
        );
        assert!((e - 0.02).abs() < 1e-6, "{e}");
        let sigma = (2.0 * 0.0060f64.powi(2) + (0.05f64 / 3.0).powi(2)).sqrt();
        assert!((pair.inv_sigma2.sqrt().recip() - sigma).abs() < 1e-3);
        let at_truth = gfs_optim::residuals::PointToPlane {
            point_in_camera: pair.point_in_camera,
        }
        .error(
            &current_from_world,
            &pair.surface_in_world,
            &pair.normal_in_world,
        );
        assert!(at_truth.abs() < 1e-6, "{at_truth}");
    }
    // A 1 cm gate pairs nothing.
    let none = associator.associate(
        &config,
        &camera,
        PosedGrid {
            grid: &current,
            camera_from_world: &Isometry3::identity(),
        },
        PosedGrid {
            grid: &reference,
            camera_from_world: &Isometry3::identity(),
        },
        0.01,
        1.0,
    );
    assert!(none.is_empty());
}

/// `grid` with every normal tilted by `tilt_rad` towards a random direction across it:
/// a tilt variance of `tilt_rad^2 / 2` per tangent direction.
fn tilt_normals(grid: &mut DepthGrid, tilt_rad: f32, seed: u64) {
    let mut rng = gfs_core::rng::SplitMix64::keyed(seed, &[]);
    for normal in grid.normals.iter_mut().filter(|n| **n != [0.0; 3]) {
        let n = Vector3::from(*normal);
        let across = n
            .cross(&Vector3::z())
            .try_normalize(1e-6)
            .unwrap_or(Vector3::x());
        let angle = std::f32::consts::TAU * rng.uniform() as f32;
        let direction =
            nalgebra::UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_normalize(n), angle)
                * across;
        *normal = (n * tilt_rad.cos() + direction * tilt_rad.sin()).into();
    }
}

#[test]
fn a_degraded_frame_renews_on_a_corner_of_its_own_or_when_its_reference_leaves() {
    let camera = PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480);
    // Every node, as `gfsvo synth`'s config aligns them; normals tilted by 0.08 rad
    // (that config's bare walls measure a tilt variance of 0.003 rad^2).
    let config = DepthAlignmentConfig {
        source_step: 1,
        ..DepthAlignmentConfig::default()
    };
    let tilt = 0.08f32;
    let normal_variance = f64::from(tilt * tilt) / 2.0;
    let mut bare_wall = wall(&camera, 2.0);
    tilt_normals(&mut bare_wall, tilt, 1);
    let mut corner = planes_depth(&camera, &Isometry3::identity(), &CORNER);
    tilt_normals(&mut corner, tilt, 2);
    let moving_off = 0.6;
    // The wall's tilted normals alone would hold its slide within the 6 mm its own
    // surfaces must: less their noise it is free, and the frame keeps its reference.
    assert!(degraded_frame_renews(&config, moving_off, &bare_wall, 0.0));
    assert!(!degraded_frame_renews(
        &config,
        moving_off,
        &bare_wall,
        normal_variance
    ));
    // A corner holds its pose less the noise too.
    assert!(degraded_frame_renews(
        &config,
        moving_off,
        &corner,
        normal_variance
    ));
    // Where the reference leaves the view, the wall renews it as well.
    assert!(degraded_frame_renews(
        &config,
        0.4,
        &bare_wall,
        normal_variance
    ));
    // A view that still pairs with its reference keeps it; so does every view with the
    // renewal off.
    assert!(!degraded_frame_renews(
        &config,
        0.9,
        &corner,
        normal_variance
    ));
    let never = DepthAlignmentConfig {
        renewal_sigma_m: 0.0,
        ..config.clone()
    };
    assert!(!degraded_frame_renews(
        &never,
        0.4,
        &bare_wall,
        normal_variance
    ));
}
