//! Planes in the local BA: a fixed keyframe and a free one see three planes (a floor and
//! two walls); from a wrong start of the free pose and of the planes, both come back to
//! the truth, and an observation that matches no plane is flagged an outlier.

use gfs_core::camera::PinholeCamera;
use gfs_optim::residuals::{PlaneToPlane, plane_plus};
use gfs_optim::{BaConfig, BaPlaneObservation, BaPose, BaProblem, BaResult, LocalBundleAdjuster};
use nalgebra::{Isometry3, Vector3, Vector6};

/// The planes `n . p + d = 0` of the world.
const PLANES: [([f64; 3], f64); 3] = [
    ([0.0, -1.0, 0.0], 1.0),
    ([-1.0, 0.0, 0.0], 1.2),
    ([0.0, 0.0, -1.0], 4.0),
];

/// The plane `(n, d)` as `camera_from_world` measures it.
fn seen(camera_from_world: &Isometry3<f64>, n: &Vector3<f64>, d: f64) -> PlaneToPlane {
    let n_c = camera_from_world.rotation * n;
    PlaneToPlane {
        normal_in_camera: n_c,
        offset: d - n_c.dot(&camera_from_world.translation.vector),
    }
}

fn observation(pose: usize, plane: usize, measured: PlaneToPlane) -> BaPlaneObservation {
    BaPlaneObservation {
        pose,
        plane,
        measured,
        inv_sigma2_normal: 0.01f64.powi(-2),
        inv_sigma2_offset: 0.005f64.powi(-2),
    }
}

#[test]
fn a_keyframe_and_its_planes_come_back_to_the_truth_and_a_wrong_pairing_is_an_outlier() {
    let truth = gfs_core::se3::exp(&Vector6::new(0.05, -0.02, 0.1, 0.02, -0.05, 0.01));
    let mut problem = BaProblem::new(PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480));
    problem.poses.push(BaPose {
        camera_from_world: Isometry3::identity(),
        fixed: true,
    });
    problem.poses.push(BaPose {
        camera_from_world: gfs_core::se3::retract(
            &truth,
            &Vector6::new(0.02, 0.01, -0.015, 0.01, -0.01, 0.005),
        ),
        fixed: false,
    });
    for (k, (n, d)) in PLANES.iter().enumerate() {
        let n = Vector3::from(*n);
        // The planes start 1-2 degrees and 1 cm off.
        problem
            .planes
            .push(plane_plus(&n, *d, &Vector3::new(0.02, -0.03, 0.01)));
        problem
            .plane_observations
            .push(observation(0, k, seen(&Isometry3::identity(), &n, *d)));
        problem
            .plane_observations
            .push(observation(1, k, seen(&truth, &n, *d)));
    }
    // The floor, paired with the free keyframe's measurement of a wall 30 cm further.
    let wall = Vector3::from(PLANES[1].0);
    problem
        .plane_observations
        .push(observation(1, 0, seen(&truth, &wall, 1.5)));
    let mut result = BaResult::default();
    LocalBundleAdjuster::new()
        .optimize(&mut problem, &BaConfig::default(), &mut result)
        .expect("valid problem");
    let error = problem.poses[1].camera_from_world * truth.inverse();
    assert!(error.translation.vector.norm() < 1e-6, "{error}");
    assert!(error.rotation.angle() < 1e-6);
    for (k, (n, d)) in PLANES.iter().enumerate() {
        let (normal, offset) = problem.planes[k];
        assert!((normal - Vector3::from(*n)).norm() < 1e-6, "plane {k}");
        assert!((offset - d).abs() < 1e-6, "plane {k}");
    }
    let mut expected = vec![true; 6];
    expected.push(false);
    assert_eq!(result.inliers.plane_observations, expected);
    assert_eq!(problem.poses[0].camera_from_world, Isometry3::identity());
}

/// Angle between two unit normals, degrees, folded into [0, 90] (a plane's normal has no
/// sign that matters to parallelism).
fn angle_deg(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.dot(b).abs().clamp(0.0, 1.0).acos().to_degrees()
}

/// A floor, a wall and a back wall seen by three keyframes (two fixed, one free) with
/// normals 1-2 degrees off and offsets up to 1 cm off, the floor and the wall paired
/// perpendicular when `perpendicular`; returns the adjusted planes.
fn floor_and_wall(plane_structure_sigma_deg: f64, perpendicular: bool) -> Vec<(Vector3<f64>, f64)> {
    let floor = Vector3::new(0.0, -1.0, 0.0);
    let wall = Vector3::new(-1.0, 0.0, 0.0);
    let back = Vector3::new(0.0, 0.0, -1.0);
    let truths = [(floor, 1.0), (wall, 1.2), (back, 4.0)];
    let poses = [
        Isometry3::identity(),
        gfs_core::se3::exp(&Vector6::new(0.1, 0.0, 0.05, 0.0, 0.05, 0.0)),
        gfs_core::se3::exp(&Vector6::new(0.2, 0.02, -0.05, 0.02, 0.1, 0.0)),
    ];
    // Per keyframe and plane: the minimal step of its measurement's error (tangent
    // radians, offset metres). The second tangent of the floor turns it towards -x and
    // the wall's towards -y: both positive, the measured floor and wall are about 2.7
    // degrees off perpendicular. The back wall is there to fix the free pose's depth.
    let noise = [
        [
            [0.01, 0.03, 0.01],
            [-0.02, 0.02, -0.01],
            [0.005, -0.01, 0.0],
        ],
        [
            [-0.02, 0.02, -0.01],
            [0.0, 0.03, 0.01],
            [-0.01, 0.005, 0.005],
        ],
        [
            [0.01, 0.025, 0.0],
            [0.015, 0.015, 0.005],
            [0.0, 0.01, -0.005],
        ],
    ];
    let mut problem = BaProblem::new(PinholeCamera::new(525.0, 525.0, 319.5, 239.5, 640, 480));
    for (k, pose) in poses.iter().enumerate() {
        problem.poses.push(BaPose {
            camera_from_world: *pose,
            fixed: k < 2,
        });
    }
    for (q, (n, d)) in truths.iter().enumerate() {
        problem.planes.push((*n, *d));
        for (k, pose) in poses.iter().enumerate() {
            let (n_noisy, d_noisy) = plane_plus(n, *d, &Vector3::from(noise[k][q]));
            // Weighed as tracking weighs them: 1 degree, 1 cm.
            problem.plane_observations.push(BaPlaneObservation {
                inv_sigma2_normal: 1f64.to_radians().powi(-2),
                inv_sigma2_offset: 0.01f64.powi(-2),
                ..observation(k, q, seen(pose, &n_noisy, d_noisy))
            });
        }
    }
    if perpendicular {
        problem.plane_perpendicular.push((0, 1));
    }
    let config = BaConfig {
        plane_structure_sigma_deg,
        ..BaConfig::default()
    };
    let mut result = BaResult::default();
    LocalBundleAdjuster::new()
        .optimize(&mut problem, &config, &mut result)
        .expect("valid problem");
    println!(
        "sigma {plane_structure_sigma_deg}: floor-wall {:.3} deg, rms normal error {:.3} deg",
        angle_deg(&problem.planes[0].0, &problem.planes[1].0),
        normal_rms_deg(&problem.planes),
    );
    problem.planes
}

/// Root mean square angle of the floor's and the wall's normals from the truth.
fn normal_rms_deg(planes: &[(Vector3<f64>, f64)]) -> f64 {
    let truth = [Vector3::new(0.0, -1.0, 0.0), Vector3::new(-1.0, 0.0, 0.0)];
    let sum: f64 = planes
        .iter()
        .zip(&truth)
        .map(|((n, _), t)| angle_deg(n, t).powi(2))
        .sum();
    (sum / 2.0).sqrt()
}

#[test]
fn a_perpendicular_pair_makes_a_noisy_floor_and_wall_perpendicular_and_closer_to_the_truth() {
    let free = floor_and_wall(0.0, true);
    let held = floor_and_wall(BaConfig::default().plane_structure_sigma_deg, true);
    let unpaired = floor_and_wall(BaConfig::default().plane_structure_sigma_deg, false);
    assert_eq!(free, unpaired, "sigma 0 turns the term off");
    let free_angle = angle_deg(&free[0].0, &free[1].0);
    let held_angle = angle_deg(&held[0].0, &held[1].0);
    assert!(
        free_angle < 88.0,
        "the noise leaves them {free_angle} deg apart"
    );
    assert!(held_angle > 89.0, "with the term: {held_angle} deg");
    let (free_rms, held_rms) = (normal_rms_deg(&free), normal_rms_deg(&held));
    assert!(
        held_rms < 0.5 * free_rms,
        "normal error {held_rms} deg with the term, {free_rms} without"
    );
}
