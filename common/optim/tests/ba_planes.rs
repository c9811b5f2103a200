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
