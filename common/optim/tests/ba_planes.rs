//! Plane observations in the local BA: a keyframe seeing three planes of the map (a
//! floor and two walls, held fixed) is moved back onto them from a wrong start, and a
//! fourth observation that matches no plane is flagged an outlier.

use gfs_core::camera::PinholeCamera;
use gfs_optim::residuals::PlaneToPlane;
use gfs_optim::{
    BaConfig, BaPlaneObservation, BaPose, BaProblem, BaResult, LocalBundleAdjuster,
    PlaneObservation,
};
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

#[test]
fn a_keyframe_is_moved_onto_its_planes_and_a_wrong_plane_is_an_outlier() {
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
    let observation = |n: Vector3<f64>, d: f64, measured: PlaneToPlane| BaPlaneObservation {
        pose: 1,
        plane: PlaneObservation {
            normal_in_world: n,
            offset_in_world: d,
            measured,
            inv_sigma2_normal: 0.01f64.powi(-2),
            inv_sigma2_offset: 0.005f64.powi(-2),
        },
    };
    for (n, d) in PLANES {
        let n = Vector3::from(n);
        problem
            .plane_observations
            .push(observation(n, d, seen(&truth, &n, d)));
    }
    // The floor's map plane, paired with a measurement of a wall 30 cm further.
    let floor = Vector3::from(PLANES[0].0);
    let wall = Vector3::from(PLANES[1].0);
    problem
        .plane_observations
        .push(observation(floor, PLANES[0].1, seen(&truth, &wall, 1.5)));
    let mut result = BaResult::default();
    LocalBundleAdjuster::new()
        .optimize(&mut problem, &BaConfig::default(), &mut result)
        .expect("valid problem");
    let error = problem.poses[1].camera_from_world * truth.inverse();
    assert!(error.translation.vector.norm() < 1e-6, "{error}");
    assert!(error.rotation.angle() < 1e-6);
    assert_eq!(
        result.inliers.plane_observations,
        vec![true, true, true, false]
    );
    assert_eq!(problem.poses[0].camera_from_world, Isometry3::identity());
}
